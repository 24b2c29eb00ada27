"""DICOM series: a folder of single-frame slices (or one slice file, meaning its series), read
with pydicom.

Slices are grouped by SeriesInstanceUID (a folder with several series needs one of its files as
the path) and sorted by ImagePositionPatient projected on the slice normal
(row x column of ImageOrientationPatient). Files pydicom cannot read as DICOM and files without
an image (DICOMDIR, reports) are skipped.
  spacing   x = PixelSpacing[1] (column spacing), y = PixelSpacing[0] (row spacing),
            z = the distance between the first and last slice positions over the number of
            gaps; the gaps along the normal must be uniform (tolerance 1e-3 mm + 0.1 %); a
            single slice uses SpacingBetweenSlices, then SliceThickness, then 1.
  direction the index axes i (along a row), j (down a column) and k (slice to slice) point along
            ImageOrientationPatient's row cosines, its column cosines and the slice normal
            (row x column, the way the sorted positions go), converted from DICOM's LPS
            patient frame to RAS (x and y negated: vgraph.io.orientation). Slices whose
            positions step off the normal (a CT gantry tilt) make a sheared grid: refused
            naming ImagePositionPatient.
  origin    ImagePositionPatient of the first slice after sorting, in RAS (x and y negated).
  values    RescaleSlope / RescaleIntercept per slice. If every slice has slope 1 and intercept 0
            the stored dtype (e.g. uint16) is kept; otherwise stored * slope + intercept is computed
            in float64 and kept as float32, or as float64 for 32-bit stored values or results
            beyond float32's range.
  range     none declared: BitsStored is the storage's width, not the data's range (the MR
            scout holds 0..346 in 12 bits; mapped over [0, 4095] it rendered nearly black), so
            the value range is the data's min..max like any other volume's.
Without ImagePositionPatient or ImageOrientationPatient the slices are sorted by InstanceNumber,
with a warning, and the grid has no orientation (identity direction, origin 0).
Damaged files: pydicom reads through a file whose reads stop at its end (element lengths are not
trusted), a deflated data set may inflate to at most MAX_DEFLATED_BYTES, and header values are
read through _numbers/_integer, which name the field of anything that is not finite numbers.
"""

from __future__ import annotations

import math
import os
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np
import pydicom
import pydicom.filereader
from pydicom.uid import DeflatedExplicitVRLittleEndian

from vgraph.errors import VolumeFileError
from vgraph.io._common import check_origin, check_spacing, make_volume, open_capped, regular_file
from vgraph.io._inflate import check_inflates_within, file_pieces
from vgraph.io._values import rescaled
from vgraph.io.orientation import file_direction, lps_ras, split_axes
from vgraph.memory import check_memory
from vgraph.progress import steps
from vgraph.volume import IDENTITY, Volume

_SAME_ACROSS_SLICES = ("Rows", "Columns", "BitsAllocated", "PixelRepresentation", "SamplesPerPixel")
# pydicom inflates a deflated data set whole, in one call, before it parses anything; a slice
# (even 8192 x 8192 x 16 bits with its header) is far below this, a deflate bomb far above.
MAX_DEFLATED_BYTES = 256 * 2**20
# Elements above this size are left in the file while the headers of a folder are scanned.
_DEFER_BYTES = 2**20


def read_dicom_series(path) -> Volume:
    path = Path(path)
    if path.is_dir():
        folder, wanted_series = path, None
    else:
        folder, wanted_series = regular_file(path).parent, _series_of(path)
    slices = _image_headers(folder)
    if not slices:
        raise VolumeFileError(folder, "no DICOM image files found in the folder", "folder")
    series = _pick_series(folder, slices, wanted_series)
    _check_consistent(series)
    first_file, first = series[0]
    if _integer(first_file, first, "NumberOfFrames", 1) > 1:
        raise VolumeFileError(first_file, "multi-frame DICOM files are not supported",
                              "NumberOfFrames")
    ordered, slice_step, origin = _sort_slices(series)
    spacing, direction = _grid(ordered, slice_step)
    data = _read_pixels(folder, ordered)
    return make_volume(data, path, spacing=spacing, direction=direction,
                       origin=check_origin(lps_ras(origin), ordered[0][0], "ImagePositionPatient"))


# --- reading files -------------------------------------------------------------------------------
def _dataset(file: Path, headers_only: bool) -> pydicom.Dataset:
    """pydicom's reading of one file, after the check that a deflated data set stays small."""
    _check_deflated_size(file)
    with open_capped(file) as fh:
        if headers_only:
            return pydicom.dcmread(fh, stop_before_pixels=True, defer_size=_DEFER_BYTES)
        return pydicom.dcmread(fh)


def _check_deflated_size(file: Path) -> None:
    try:
        with open_capped(file) as fh:
            pydicom.filereader.read_preamble(fh, False)
            # pydicom's own meta reader (private, but stable since pydicom 1.0): it leaves the
            # file at the start of the data set, which is where the deflated stream begins
            meta = pydicom.filereader._read_file_meta_info(fh)
            start = fh.tell()
    except Exception:  # not DICOM, or no file meta: dcmread reports it, nothing is inflated
        return
    if meta.get("TransferSyntaxUID") == DeflatedExplicitVRLittleEndian:
        check_inflates_within(file_pieces(file, start, file, "TransferSyntaxUID"), "deflate",
                              MAX_DEFLATED_BYTES, file, "TransferSyntaxUID",
                              what="the deflated data set")


def _series_of(file: Path) -> str | None:
    try:
        return str(_value(file, _dataset(file, headers_only=True), "SeriesInstanceUID") or "")
    except VolumeFileError:
        raise
    except Exception as exc:  # pydicom raises many types for damaged files
        raise VolumeFileError(file, f"not a readable DICOM file: {exc}", "header") from exc


def _image_headers(folder: Path) -> list[tuple[Path, pydicom.Dataset]]:
    found = []
    for name in sorted(os.listdir(folder)):
        file = folder / name
        if name.startswith(".") or not file.is_file():
            continue
        try:
            ds = _dataset(file, headers_only=True)
        except VolumeFileError:
            raise
        except Exception:
            continue  # not DICOM (a licence, a CSV ...): a series folder may hold such files
        if "Rows" in ds and "Columns" in ds:
            found.append((file, ds))
    return found


# --- header values -------------------------------------------------------------------------------
def _value(file: Path, ds, field: str):
    """A field's value; pydicom decodes values when first read and raises for damaged ones."""
    try:
        return ds.get(field)
    except Exception as exc:
        raise VolumeFileError(file, f"cannot decode the value: {exc}", field) from exc


def _numbers(file: Path, ds, field: str, count: int | None = None) -> tuple[float, ...] | None:
    """A field as finite numbers (None when absent); anything else is refused with its name."""
    value = _value(file, ds, field)
    if value is None or value == "":
        return None
    items = value if isinstance(value, (list, tuple, pydicom.multival.MultiValue)) else [value]
    try:
        numbers = tuple(float(v) for v in items)
    except (TypeError, ValueError, OverflowError):
        raise VolumeFileError(file, f"expected numbers, got {value!r}", field) from None
    if (count is not None and len(numbers) != count) or not all(map(math.isfinite, numbers)):
        raise VolumeFileError(file, f"expected {count or 'some'} finite numbers, got {value!r}",
                              field)
    return numbers


def _integer(file: Path, ds, field: str, default: int | None = None) -> int:
    numbers = _numbers(file, ds, field, 1)
    if numbers is None:
        if default is None:
            raise VolumeFileError(file, "required field is missing", field)
        return default
    if numbers[0] != int(numbers[0]):
        raise VolumeFileError(file, f"expected an integer, got {numbers[0]}", field)
    return int(numbers[0])


def _pick_series(folder, slices, wanted):
    groups = defaultdict(list)
    for file, ds in slices:
        groups[str(_value(file, ds, "SeriesInstanceUID") or "")].append((file, ds))
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
        expected = _numbers(first_file, first, field)
        for file, ds in series[1:]:
            value = _numbers(file, ds, field)
            if value != expected and not _close(value, expected):
                raise VolumeFileError(file, f"{value} differs from {expected} in "
                                            f"{first_file.name}: slices of one volume must agree",
                                      field)
    if _integer(first_file, first, "SamplesPerPixel", 1) != 1:
        raise VolumeFileError(first_file, "only single-sample (grey) images are supported",
                              "SamplesPerPixel")


def _sort_slices(series):
    """Slices sorted along the normal, the step from slice to slice (a vector in LPS, or a
    thickness along the normal when the positions do not say) and the first slice's position."""
    orientation = _numbers(*series[0], "ImageOrientationPatient", 6)
    positions = [_numbers(file, ds, "ImagePositionPatient", 3) for file, ds in series]
    if orientation is not None and all(p is not None for p in positions):
        normal = np.cross(orientation[:3], orientation[3:])
        distances = [float(np.dot(p, normal)) for p in positions]
        order = np.argsort(distances, kind="stable")
        ordered = [series[i] for i in order]
        if len(ordered) == 1:
            return ordered, _single_slice_thickness(ordered[0]), positions[0]
        _uniform_step(ordered, np.array(distances)[order])
        first, last = np.asarray(positions[order[0]]), np.asarray(positions[order[-1]])
        return ordered, (last - first) / (len(ordered) - 1), positions[order[0]]
    warnings.warn(f"{series[0][0].parent}: slices lack ImagePositionPatient/ImageOrientationPatient; "
                  f"sorted by InstanceNumber, spacing from SpacingBetweenSlices/SliceThickness, "
                  f"no orientation", UserWarning, stacklevel=3)
    ordered = sorted(series, key=lambda item: _integer(*item, "InstanceNumber", 0))
    return ordered, _single_slice_thickness(ordered[0]), (0.0, 0.0, 0.0)


def _grid(ordered, slice_step) -> tuple:
    """(spacing, direction in RAS): the rows' and columns' cosines times the pixel spacing, and
    the slice step (a vector from position to position, or a thickness along the normal)."""
    file, ds = ordered[0]
    column_spacing, row_spacing = _pixel_spacing(ordered[0])
    orientation = _numbers(file, ds, "ImageOrientationPatient", 6)
    if orientation is None:  # no orientation at all: the axes of the world
        return check_spacing((column_spacing, row_spacing, slice_step), file, "PixelSpacing"), IDENTITY
    row, column = np.asarray(orientation[:3]), np.asarray(orientation[3:])
    file_direction(np.column_stack([row, column, np.cross(row, column)]), file,
                   "ImageOrientationPatient")  # unit, perpendicular cosines before anything else
    step = np.asarray(slice_step) if np.ndim(slice_step) else np.cross(row, column) * slice_step
    axes = np.column_stack([row * column_spacing, column * row_spacing, step])
    check_spacing((column_spacing, row_spacing, float(np.linalg.norm(step))), file, "PixelSpacing")
    try:
        spacing, direction, _ = split_axes(lps_ras(axes), file, "ImagePositionPatient")
    except VolumeFileError as error:
        raise VolumeFileError(ordered[0][0].parent, f"the slice positions do not step along the "
                                                    f"normal of ImageOrientationPatient (a gantry "
                                                    f"tilt?): {error.reason}", error.field) from None
    return spacing, direction


def _uniform_step(ordered, distances: np.ndarray) -> None:
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


def _single_slice_thickness(item) -> float:
    file, ds = item
    for field in ("SpacingBetweenSlices", "SliceThickness"):
        value = _numbers(file, ds, field, 1)
        if value is not None and value[0] > 0:
            return value[0]
    return 1.0


def _pixel_spacing(item) -> tuple[float, float]:
    file, ds = item
    for field in ("PixelSpacing", "ImagerPixelSpacing"):
        value = _numbers(file, ds, field)
        if value is not None and len(value) == 2:
            row_spacing, column_spacing = value
            return column_spacing, row_spacing
    warnings.warn(f"{file}: no PixelSpacing; using 1 x 1", UserWarning, stacklevel=4)
    return 1.0, 1.0


def _read_pixels(folder, ordered):
    """The stored values of every slice, then (if any slice rescales) the rescaled values."""
    rescale = [_rescale(file, ds) for file, ds in ordered]
    scaled = any(r != (1.0, 0.0) for r in rescale)
    first_file, first = ordered[0]
    rows, columns = _integer(first_file, first, "Rows"), _integer(first_file, first, "Columns")
    allocated = _integer(first_file, first, "BitsAllocated")
    if allocated not in (8, 16, 32) or min(rows, columns) < 1:
        raise VolumeFileError(first_file, f"need 8, 16 or 32 bits allocated and at least one row "
                                          f"and column, got {allocated} bits, {rows} x {columns}",
                              "Rows/Columns/BitsAllocated")
    count = rows * columns * len(ordered)
    check_memory(folder, count * (allocated // 8 + (8 if scaled else 0)), "Rows/Columns")
    stored = None
    for index, (file, _) in enumerate(steps(ordered, f"reading {folder.name}", unit="slice",
                                            show=None if len(ordered) > 20 else False)):
        pixels = _slice_pixels(file)
        if pixels.shape != (rows, columns):
            raise VolumeFileError(file, f"pixel array has shape {pixels.shape}, expected "
                                        f"{(rows, columns)}", "Rows/Columns")
        if stored is None:
            stored = np.empty((len(ordered), rows, columns), dtype=pixels.dtype)
        stored[index] = pixels
    return rescaled(stored, *zip(*rescale)) if scaled else stored


def _slice_pixels(file: Path) -> np.ndarray:
    try:
        return _dataset(file, headers_only=False).pixel_array
    except VolumeFileError:
        raise
    except Exception as exc:  # pydicom raises a range of types for missing codecs or bad data
        syntax = "?"
        try:
            syntax = str(pydicom.filereader.read_file_meta_info(file).TransferSyntaxUID)
        except Exception:
            pass
        raise VolumeFileError(file, f"cannot decode pixel data (transfer syntax {syntax}): {exc}",
                              "PixelData") from exc


def _rescale(file, ds) -> tuple[float, float]:
    slope = (_numbers(file, ds, "RescaleSlope", 1) or (1.0,))[0]
    inter = (_numbers(file, ds, "RescaleIntercept", 1) or (0.0,))[0]
    if slope == 0:
        raise VolumeFileError(file, f"slope {slope}, intercept {inter} do not map values",
                              "RescaleSlope")
    return slope, inter


def _close(a, b) -> bool:
    return a is not None and b is not None and len(a) == len(b) and np.allclose(a, b, atol=1e-4)
