"""DICOM series: a folder of single-frame slices (or one slice file, meaning its series), read
with pydicom.

Slices are grouped by SeriesInstanceUID (a folder with several series needs one of its files as
the path) and sorted by ImagePositionPatient projected on the slice normal
(row x column of ImageOrientationPatient). Files pydicom cannot read as DICOM and files without
an image (DICOMDIR, reports) are skipped.
  spacing   x = PixelSpacing[1] (column spacing), y = PixelSpacing[0] (row spacing),
            z = the distance between consecutive slice positions, which must be uniform
            (tolerance 1e-3 mm + 0.1 %); a single slice uses SpacingBetweenSlices, then
            SliceThickness, then 1.
  origin    ImagePositionPatient of the first slice after sorting (patient coordinates). The
            rotation in ImageOrientationPatient is not applied: axes are column, row, slice.
  values    RescaleSlope / RescaleIntercept per slice. If every slice has slope 1 and intercept 0
            the stored dtype (e.g. uint16) is kept; otherwise stored * slope + intercept is computed
            in float64 and stored as float32 (DICOM pixels have at most 16 bits here).
  range     BitsStored < BitsAllocated declares the range (e.g. 12-bit unsigned -> [0, 4095]),
            rescaled like the values; otherwise None.
Without ImagePositionPatient the slices are sorted by InstanceNumber, with a warning.
"""

from __future__ import annotations

import os
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np
import pydicom
from pydicom.errors import InvalidDicomError
from tqdm import tqdm

from vgraph.errors import VolumeFileError
from vgraph.io._common import check_memory, check_origin, check_spacing, make_volume
from vgraph.volume import Volume

_SAME_ACROSS_SLICES = ("Rows", "Columns", "BitsAllocated", "PixelRepresentation", "SamplesPerPixel")


def read_dicom_series(path) -> Volume:
    path = Path(path)
    folder, wanted_series = (path, None) if path.is_dir() else (path.parent, _series_of(path))
    slices = _image_headers(folder)
    if not slices:
        raise VolumeFileError(folder, "no DICOM image files found in the folder", "folder")
    series = _pick_series(folder, slices, wanted_series)
    _check_consistent(series)
    first = series[0][1]
    if int(first.get("NumberOfFrames", 1) or 1) > 1:
        raise VolumeFileError(series[0][0], "multi-frame DICOM files are not supported",
                              "NumberOfFrames")
    ordered, z_spacing, origin = _sort_slices(series)
    spacing = check_spacing((*_pixel_spacing(ordered[0]), z_spacing), ordered[0][0], "PixelSpacing")
    data, declared = _read_pixels(folder, ordered)
    return make_volume(data, path, spacing=spacing, origin=check_origin(origin, ordered[0][0],
                       "ImagePositionPatient"), declared_range=declared)


def _series_of(file: Path) -> str | None:
    try:
        return str(pydicom.dcmread(file, stop_before_pixels=True).get("SeriesInstanceUID", ""))
    except (InvalidDicomError, OSError, ValueError) as exc:
        raise VolumeFileError(file, f"not a readable DICOM file: {exc}", "header") from exc


def _image_headers(folder: Path) -> list[tuple[Path, pydicom.Dataset]]:
    found = []
    for name in sorted(os.listdir(folder)):
        file = folder / name
        if name.startswith(".") or not file.is_file():
            continue
        try:
            ds = pydicom.dcmread(file, stop_before_pixels=True)
        except (InvalidDicomError, OSError, ValueError, EOFError, TypeError):
            continue  # not DICOM (a licence, a CSV ...): a series folder may hold such files
        if "Rows" in ds and "Columns" in ds:
            found.append((file, ds))
    return found


def _pick_series(folder, slices, wanted):
    groups = defaultdict(list)
    for file, ds in slices:
        groups[str(ds.get("SeriesInstanceUID", ""))].append((file, ds))
    if wanted is not None:
        if not groups.get(wanted):
            raise VolumeFileError(folder, f"no image files of series {wanted!r} in the folder",
                                  "SeriesInstanceUID")
        return groups[wanted]
    if len(groups) > 1:
        listing = "; ".join(f"{uid or '(none)'}: {len(items)} files, e.g. {items[0][0].name}"
                            for uid, items in groups.items())
        raise VolumeFileError(folder, f"the folder holds {len(groups)} series ({listing}); open "
                                      f"one file of the series you want", "SeriesInstanceUID")
    return next(iter(groups.values()))


def _check_consistent(series) -> None:
    first_file, first = series[0]
    for field in _SAME_ACROSS_SLICES + ("PixelSpacing", "ImageOrientationPatient"):
        expected = _as_tuple(first.get(field))
        for file, ds in series[1:]:
            value = _as_tuple(ds.get(field))
            if value != expected and not _close(value, expected):
                raise VolumeFileError(file, f"{value} differs from {expected} in "
                                            f"{first_file.name}: slices of one volume must agree",
                                      field)
    if int(first.get("SamplesPerPixel", 1)) != 1:
        raise VolumeFileError(first_file, "only single-sample (grey) images are supported",
                              "SamplesPerPixel")


def _sort_slices(series):
    """Slices sorted along the normal, the z spacing and the first slice's position."""
    if all("ImagePositionPatient" in ds and "ImageOrientationPatient" in ds for _, ds in series):
        orientation = np.array(series[0][1].ImageOrientationPatient, dtype=float)
        normal = np.cross(orientation[:3], orientation[3:])
        positions = [np.array(ds.ImagePositionPatient, dtype=float) for _, ds in series]
        order = np.argsort([p @ normal for p in positions], kind="stable")
        ordered = [series[i] for i in order]
        distances = np.array([positions[i] @ normal for i in order])
        z_spacing = _uniform_step(ordered, distances) if len(ordered) > 1 \
            else _single_slice_thickness(ordered[0])
        return ordered, z_spacing, tuple(positions[order[0]])
    warnings.warn(f"{series[0][0].parent}: slices lack ImagePositionPatient/ImageOrientationPatient; "
                  f"sorted by InstanceNumber, spacing from SpacingBetweenSlices/SliceThickness",
                  UserWarning, stacklevel=3)
    ordered = sorted(series, key=lambda item: int(item[1].get("InstanceNumber", 0) or 0))
    return ordered, _single_slice_thickness(ordered[0]), (0.0, 0.0, 0.0)


def _uniform_step(ordered, distances: np.ndarray) -> float:
    gaps = np.diff(distances)
    for index, gap in enumerate(gaps):
        if abs(gap) < 1e-6:
            raise VolumeFileError(ordered[index + 1][0], f"same slice position as "
                                  f"{ordered[index][0].name}: duplicate slice",
                                  "ImagePositionPatient")
    step = float(np.median(gaps))
    # the gap farthest from the median; on a tie the larger one (a missing slice is the usual cause)
    worst = max(range(len(gaps)), key=lambda i: (round(abs(gaps[i] - step), 6), gaps[i]))
    if abs(gaps[worst] - step) > 1e-3 + 1e-3 * step:
        folder = ordered[0][0].parent
        raise VolumeFileError(folder, f"non-uniform slice spacing: steps between consecutive "
                                      f"slices range from {gaps.min():.4g} to {gaps.max():.4g} mm "
                                      f"(median {step:.4g} mm); {gaps[worst]:.4g} mm between "
                                      f"{ordered[worst][0].name} and {ordered[worst + 1][0].name} "
                                      f"(a missing or extra slice?)", "ImagePositionPatient")
    return step


def _single_slice_thickness(item) -> float:
    _, ds = item
    for field in ("SpacingBetweenSlices", "SliceThickness"):
        value = ds.get(field)
        if value not in (None, "") and float(value) > 0:
            return float(value)
    return 1.0


def _pixel_spacing(item) -> tuple[float, float]:
    file, ds = item
    for field in ("PixelSpacing", "ImagerPixelSpacing"):
        value = ds.get(field)
        if value is not None and len(value) == 2:
            row_spacing, column_spacing = (float(v) for v in value)
            return column_spacing, row_spacing
    warnings.warn(f"{file}: no PixelSpacing; using 1 x 1", UserWarning, stacklevel=4)
    return 1.0, 1.0


def _read_pixels(folder, ordered):
    rescale = [_rescale(file, ds) for file, ds in ordered]
    scaled = any(r != (1.0, 0.0) for r in rescale)
    first_file, first = ordered[0]
    rows, columns = int(first.Rows), int(first.Columns)
    stored_itemsize = int(first.BitsAllocated + 7) // 8
    out_dtype = np.dtype(np.float32) if scaled else None
    count = rows * columns * len(ordered)
    check_memory(folder, count * (stored_itemsize + (4 if scaled else 0)), "Rows/Columns")
    data = None
    for index, (file, _) in enumerate(tqdm(ordered, desc=f"reading {folder.name}", unit="slice",
                                           leave=False, disable=None if len(ordered) > 20 else True)):
        pixels = _slice_pixels(file)
        if data is None:
            data = np.empty((len(ordered), rows, columns), dtype=out_dtype or pixels.dtype)
        if pixels.shape != (rows, columns):
            raise VolumeFileError(file, f"pixel array has shape {pixels.shape}, expected "
                                        f"{(rows, columns)}", "Rows/Columns")
        slope, inter = rescale[index]
        data[index] = pixels.astype(np.float64) * slope + inter if scaled else pixels
    return data, _declared_range(first, rescale)


def _slice_pixels(file: Path) -> np.ndarray:
    try:
        return pydicom.dcmread(file).pixel_array
    except Exception as exc:  # pydicom raises a range of types for missing codecs or bad data
        syntax = "?"
        try:
            syntax = str(pydicom.dcmread(file, stop_before_pixels=True).file_meta.TransferSyntaxUID)
        except Exception:
            pass
        raise VolumeFileError(file, f"cannot decode pixel data (transfer syntax {syntax}): {exc}",
                              "PixelData") from exc


def _rescale(file, ds) -> tuple[float, float]:
    try:
        slope = float(ds.get("RescaleSlope", 1.0) or 1.0)
        inter = float(ds.get("RescaleIntercept", 0.0) or 0.0)
    except (TypeError, ValueError) as exc:
        raise VolumeFileError(file, f"bad rescale value: {exc}", "RescaleSlope/RescaleIntercept")
    if not (np.isfinite(slope) and np.isfinite(inter)) or slope == 0:
        raise VolumeFileError(file, f"slope {slope}, intercept {inter} do not map values",
                              "RescaleSlope/RescaleIntercept")
    return slope, inter


def _declared_range(first, rescale):
    bits, allocated = int(first.get("BitsStored", 0) or 0), int(first.BitsAllocated)
    if not 0 < bits < allocated:
        return None
    signed = int(first.get("PixelRepresentation", 0)) == 1
    lo, hi = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2 ** bits - 1)
    ends = [v * slope + inter for slope, inter in rescale for v in (lo, hi)]
    return (float(min(ends)), float(max(ends)))


def _as_tuple(value):
    if value is None:
        return None
    try:
        return tuple(float(v) for v in value)
    except TypeError:
        return (float(value),)


def _close(a, b) -> bool:
    return a is not None and b is not None and len(a) == len(b) and np.allclose(a, b, atol=1e-4)
