"""NIfTI-1/2 volumes (.nii, .nii.gz), read with nibabel.

Header fields used:
  dim          voxel counts (x, y, z[, t = 1]); a 4th axis longer than 1 is refused
  datatype     stored type (uint8 ... float64; complex and RGB are refused)
  pixdim[1:4]  spacing (x, y, z) = nibabel's zooms; a zero pixdim is replaced by 1 with a warning
  sform/qform  origin = translation column of nibabel's affine (sform if set, else qform)
  scl_slope / scl_inter   value scaling
Orientation: the array keeps the file's voxel order (x fastest) -> [z, y, x]; it is NOT
reoriented to RAS and the rotation part of the affine is not applied. Byte order is converted to
native (big-endian files load fine).
Scaling: with slope 1 and intercept 0 (or unset) the stored integer dtype is kept. Otherwise the
values are computed in float64 as stored * slope + intercept and kept as float32 when the stored
type has at most 16 bits or is float32 (float32 holds those exactly to ~7 digits), else as float64.
cal_min / cal_max are display windows, not value ranges: they are ignored (declared_range None),
except in files vgraph wrote itself (descrip "vgraph volume"), where they carry the value range.
"""

from __future__ import annotations

import warnings
import zlib
from pathlib import Path

import nibabel as nib
import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import check_memory, check_origin, make_volume, pad_to_3d, to_native
from vgraph.volume import Volume

WRITER_TAG = "vgraph volume"


def read_nifti(path) -> Volume:
    path = Path(path)
    if not path.is_file():
        raise VolumeFileError(path, "file does not exist")
    try:
        image = nib.load(str(path))
    except Exception as exc:  # nibabel raises many types for a bad header (ImageFileError, ValueError, EOFError...)
        raise VolumeFileError(path, f"not a readable NIfTI file: {exc}", "header") from exc
    if not isinstance(image, (nib.Nifti1Image, nib.Nifti2Image)):
        raise VolumeFileError(path, f"expected a NIfTI image, nibabel found {type(image).__name__}",
                              "header")
    header = image.header
    dims = pad_to_3d(header.get_data_shape(), path, "dim")
    stored = np.dtype(header.get_data_dtype())
    if stored.kind not in "uif" or stored.fields is not None:
        raise VolumeFileError(path, f"unsupported datatype {stored} (scalar integer or float only)",
                              "datatype")
    slope, inter = _scaling(image)
    scaled = not (slope == 1.0 and inter == 0.0)
    out_dtype = _scaled_dtype(stored) if scaled else stored
    count = dims[0] * dims[1] * dims[2]
    # stored array + its [z, y, x] copy (+ the scaled result)
    check_memory(path, count * (2 * stored.itemsize + (out_dtype.itemsize if scaled else 0)), "dim")
    data_xyz = _unscaled_data(image, path)
    data = np.ascontiguousarray(to_native(data_xyz).reshape(dims, order="F").T)
    if scaled:
        data = (data.astype(np.float64) * slope + inter).astype(out_dtype, copy=False)
    return make_volume(data, path, spacing=_spacing(header, path),
                       origin=check_origin(image.affine[:3, 3], path, "qoffset/srow"),
                       declared_range=_declared_range(header))


def _declared_range(header):
    """Only files vgraph wrote (descrip tag) have cal_min/cal_max meaning the value range."""
    if np.asarray(header["descrip"]).item().decode("latin-1") != WRITER_TAG:
        return None
    lo, hi = float(header["cal_min"]), float(header["cal_max"])
    return (lo, hi) if np.isfinite(lo) and np.isfinite(hi) and lo < hi else None


def _scaling(image) -> tuple[float, float]:
    """nibabel moves scl_slope/scl_inter into the data proxy and clears them in image.header."""
    slope = getattr(image.dataobj, "slope", 1.0)
    inter = getattr(image.dataobj, "inter", 0.0)
    slope = 1.0 if slope is None or not np.isfinite(slope) or slope == 0 else float(slope)
    inter = 0.0 if inter is None or not np.isfinite(inter) else float(inter)
    return slope, inter


def _scaled_dtype(stored: np.dtype) -> np.dtype:
    small = (stored.kind in "ui" and stored.itemsize <= 2) or stored == np.float32
    return np.dtype(np.float32 if small else np.float64)


def _unscaled_data(image, path: Path) -> np.ndarray:
    try:
        return np.asanyarray(image.dataobj.get_unscaled())
    except (OSError, EOFError, ValueError, zlib.error) as exc:  # truncated or corrupt data
        raise VolumeFileError(path, f"cannot read the voxel data: {exc}", "dim") from exc


def _spacing(header, path: Path) -> tuple[float, float, float]:
    zooms = [abs(float(z)) for z in header.get_zooms()[:3]]
    zooms += [1.0] * (3 - len(zooms))
    if not all(np.isfinite(zooms)):
        raise VolumeFileError(path, f"spacing must be finite, got {zooms}", "pixdim")
    if min(zooms) == 0:
        warnings.warn(f"{path}: pixdim has zero entries {zooms}; using 1 for those", UserWarning,
                      stacklevel=3)
        zooms = [z if z > 0 else 1.0 for z in zooms]
    return tuple(zooms)


def write_nifti(volume: Volume, file: Path) -> None:
    """NIfTI-1 (.nii or .nii.gz, chosen by the name) with the affine diag(spacing) + origin as both
    sform and qform (code 1), no scaling, and cal_min/cal_max set to the value range for viewers.
    The array is stored x fastest, as it is read back."""
    affine = np.diag([*volume.spacing, 1.0])
    affine[:3, 3] = volume.origin
    image = nib.Nifti1Image(np.ascontiguousarray(volume.data).T, affine)
    image.header.set_sform(affine, code=1)
    image.header.set_qform(affine, code=1)
    image.header.set_slope_inter(1.0, 0.0)
    image.header["descrip"] = WRITER_TAG
    if volume.declared_range is not None:
        image.header["cal_min"], image.header["cal_max"] = volume.declared_range
    nib.save(image, str(file))
