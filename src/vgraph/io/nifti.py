"""NIfTI-1/2 volumes (.nii, .nii.gz): nibabel parses the header, the data are read here.

nibabel is given at most MAX_HEADER_BYTES of header and extensions (its own loader would read an
extension of any size it is told, from a stream of any length), and the voxel data are read with
an exact size: a .nii.gz stream must decompress to exactly vox_offset + the data, a .nii file
may have bytes after the data.

Header fields used:
  dim          voxel counts (x, y, z[, t]); the 4th axis is time: one time point is read (only
               its bytes, from a .nii; inflating stops after it in a .nii.gz) and the volume's
               time_steps says how many there are. A 5th axis (vectors, tensors) is refused.
  datatype     stored type (uint8 ... float64; complex and RGB are refused)
  sform/qform  the grid: nibabel's affine (the sform if sform_code > 0, else the qform if
               qform_code > 0, else nibabel's fallback diag(-pixdim[1], pixdim[2], pixdim[3])
               about the centre, as img.affine), which is in RAS already: spacing = its
               column lengths, direction = its unit columns, origin = its translation. A
               sheared affine is refused naming the field; a zero-length column (a zero
               pixdim) gets spacing 1 with a warning.
  pixdim       must be finite (the qform and the fallback are built from it)
  scl_slope / scl_inter   value scaling
Orientation: the array keeps the file's voxel order (x fastest) -> [z, y, x]; the affine goes
into the volume's direction, spacing and origin (voxels are not resampled). Byte order is
converted to native (big-endian files load fine).
Scaling: with slope 1 and intercept 0 (or unset) the stored integer dtype is kept. Otherwise the
values are computed in float64 as stored * slope + intercept and kept as float32 when the stored
type has at most 16 bits or is float32 (float32 holds those exactly to ~7 digits) and every
result lies within float32's range, else as float64.
cal_min / cal_max are display windows, not value ranges: they are ignored (declared_range None),
except in files vgraph wrote itself (descrip "vgraph volume"), where they carry the value range.
"""

from __future__ import annotations

import io
import logging
import warnings
from pathlib import Path

import nibabel as nib
import numpy as np

from vgraph.byte_order import to_native
from vgraph.errors import VolumeFileError
from vgraph.io._common import (MAX_HEADER_BYTES, check_origin, check_time_step, make_volume, pad_to_3d,
                               read_raw_array, regular_file)
from vgraph.io._inflate import file_pieces, inflate_into, inflated_prefix
from vgraph.io._values import rescaled
from vgraph.io.label_hints import nifti_says_labels
from vgraph.io.orientation import split_axes
from vgraph.memory import check_memory
from vgraph.volume import Volume

WRITER_TAG = "vgraph volume"
_FIXES_LOG = logging.getLogger(__name__ + ".fixes")
_FIXES_LOG.addHandler(logging.NullHandler())
_FIXES_LOG.propagate = False
# sizeof_hdr -> (header class, byte offset and type of vox_offset)
_HEADERS = {348: (nib.Nifti1Header, 108, "f4"), 540: (nib.Nifti2Header, 168, "i8")}


def read_nifti(path, time_step: int = 0) -> Volume:
    path = regular_file(path)
    gzipped = path.name.lower().endswith(".gz")
    header = _header(path, gzipped)
    dims, time_steps = _dims_and_time(_checked(path, "dim", header.get_data_shape), path)
    time_step = check_time_step(path, time_step, time_steps)
    stored = np.dtype(_checked(path, "datatype", header.get_data_dtype))
    if stored.kind not in "uif" or stored.fields is not None:
        raise VolumeFileError(path, f"unsupported datatype {stored} (scalar integer or float only)",
                              "datatype")
    slope, inter = _scaling(header, path)
    count = dims[0] * dims[1] * dims[2]
    # the stored array + its [z, y, x] copy (+ the scaled result, float64 at most)
    check_memory(path, count * (2 * stored.itemsize + (8 if (slope, inter) != (1, 0) else 0)), "dim")
    flat = _stored_values(path, gzipped, header.get_data_offset(), stored, count,
                          time_step, time_steps)
    data = np.ascontiguousarray(flat.reshape(dims, order="F").T)
    if (slope, inter) != (1.0, 0.0):
        data = rescaled(data, slope, inter)
    spacing, origin, direction = grid_of(header, path)
    return make_volume(data, path, spacing=spacing, origin=origin, direction=direction,
                       declared_range=_declared_range(header), time_steps=time_steps,
                       holds_labels=nifti_says_labels(header))


def grid_of(header, path: Path):
    """(spacing, origin, direction) in RAS from nibabel's choice of affine (module docstring)."""
    _check_pixdim(header, path)
    affine = _checked(path, "qform/sform", header.get_best_affine)
    field = "srow_x/y/z (sform)" if header["sform_code"] > 0 else \
        "quatern/qoffset (qform)" if header["qform_code"] > 0 else "pixdim"
    spacing, direction, missing = split_axes(affine[:3, :3], path, field)
    if missing:
        warnings.warn(f"{path}: the affine ({field}) gives index axes {missing} (0 = x) no length "
                      f"(a zero pixdim?); using spacing 1 for those", UserWarning, stacklevel=3)
    return spacing, check_origin(affine[:3, 3], path, field), direction


def _dims_and_time(shape, path: Path) -> tuple[tuple[int, int, int], int]:
    """(x, y, z) voxel counts and the number of time points (dim[4]); trailing axes of size 1
    carry nothing, a 5th axis longer than 1 (vector or tensor data) is refused."""
    shape = [int(s) for s in shape]
    while len(shape) > 3 and shape[-1] == 1:
        shape.pop()
    if len(shape) > 4:
        raise VolumeFileError(path, f"expected a 3D volume or a time series of them, got "
                                    f"{len(shape)} axes with sizes {tuple(shape)} (vector or "
                                    f"tensor data are not supported)", "dim")
    time_steps = shape.pop() if len(shape) == 4 else 1
    if time_steps < 1:
        raise VolumeFileError(path, f"the time axis must hold at least 1 point, got {time_steps}",
                              "dim")
    return pad_to_3d(shape, path, "dim"), time_steps


def _header(path: Path, gzipped: bool):
    """The header (and extensions), parsed by nibabel from at most MAX_HEADER_BYTES read here:
    nibabel would read an extension of any declared size, from a stream of any length."""
    klass, vox_offset = _kind_and_offset(_leading_bytes(path, gzipped, 544), path)
    if vox_offset > MAX_HEADER_BYTES:
        raise VolumeFileError(path, f"the data start at byte {vox_offset}, beyond the "
                                    f"{MAX_HEADER_BYTES} bytes a header (with extensions) may take",
                              "vox_offset")
    # at least the header and the 4-byte extension flag (nibabel fixes a vox_offset below that)
    blob = _leading_bytes(path, gzipped, max(vox_offset, klass.template_dtype.itemsize + 4))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        header = _checked(path, "header", lambda: klass.from_fileobj(io.BytesIO(blob), check=False))
        # nibabel fixes what it can (logging each fix, here to nowhere) and raises for the rest
        _checked(path, "header", lambda: header.check_fix(logger=_FIXES_LOG))
    magic = bytes(header["magic"])
    if magic[:3] not in (b"n+1", b"n+2"):
        raise VolumeFileError(path, f"not a single-file NIfTI image (magic {magic!r})", "magic")
    return header


def _leading_bytes(path: Path, gzipped: bool, size: int) -> bytes:
    """Up to ``size`` bytes from the start of the (decompressed) file."""
    if gzipped:
        return inflated_prefix(file_pieces(path, 0, path, "header"), "gzip", size, path, "header")
    try:
        with open(path, "rb") as fh:
            return fh.read(size)
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read the header: {exc.strerror}", "header") from exc


def _kind_and_offset(start: bytes, path: Path):
    """The header class (NIfTI-1 or -2, by sizeof_hdr in either byte order) and vox_offset."""
    for order in "<>":
        sizeof_hdr = int(np.frombuffer(start[:4], order + "i4")[0]) if len(start) >= 4 else None
        if sizeof_hdr in _HEADERS and len(start) >= _HEADERS[sizeof_hdr][1] + 8:
            klass, at, kind = _HEADERS[sizeof_hdr]
            value = float(np.frombuffer(start[at:at + 8], order + kind, count=1)[0])
            if not np.isfinite(value) or value < 0:
                raise VolumeFileError(path, f"must be a byte offset, got {value}", "vox_offset")
            return klass, int(value)
    raise VolumeFileError(path, f"not a NIfTI file (the first {min(len(start), 4)} bytes are no "
                                f"NIfTI-1 or NIfTI-2 header size)", "sizeof_hdr")


def _checked(path: Path, field: str, compute):
    """A value nibabel derives from the header; nibabel raises many types for a bad header
    (HeaderDataError, ValueError, TypeError, IndexError...)."""
    try:
        return compute()
    except Exception as exc:
        raise VolumeFileError(path, f"not a readable NIfTI header: {exc}", field) from exc


def _stored_values(path: Path, gzipped: bool, offset: int, stored: np.dtype, count: int,
                   time_step: int, time_steps: int):
    """The ``count`` stored values of time point ``time_step`` (of ``time_steps`` stored one
    after the other from ``offset``), flat, native byte order. A .nii must hold every time point;
    a .nii.gz stream must end where the last one does, which is checked only when reading it:
    inflating stops after the time point asked for."""
    if not gzipped:
        return read_raw_array(path, stored, count * time_steps, offset=offset, allow_trailing=True,
                              size_field="dim", window=(time_step * count, count))
    out = np.empty(count, dtype=stored)
    inflate_into(out.view(np.uint8), file_pieces(path, 0, path, "dim"), "gzip", path, "dim",
                 skip=offset + time_step * count * stored.itemsize,
                 partial=time_step < time_steps - 1)
    return to_native(out, copy=False)


def _declared_range(header):
    """Only files vgraph wrote (descrip tag) have cal_min/cal_max meaning the value range."""
    if np.asarray(header["descrip"]).item().decode("latin-1") != WRITER_TAG:
        return None
    lo, hi = float(header["cal_min"]), float(header["cal_max"])
    return (lo, hi) if np.isfinite(lo) and np.isfinite(hi) and lo < hi else None


def _scaling(header, path: Path) -> tuple[float, float]:
    """scl_slope / scl_inter; nibabel reads a zero or non-finite slope as 'no scaling'."""
    slope, inter = _checked(path, "scl_inter", header.get_slope_inter)
    return (1.0, 0.0) if slope is None else (float(slope), float(inter or 0.0))


def _check_pixdim(header, path: Path) -> None:
    zooms = [float(z) for z in _checked(path, "pixdim", header.get_zooms)[:3]]
    if not all(np.isfinite(zooms)):
        raise VolumeFileError(path, f"spacing must be finite, got {zooms}", "pixdim")


def write_nifti(volume: Volume, file: Path) -> None:
    """NIfTI-1 (.nii or .nii.gz, chosen by the name) with the volume's affine (RAS, as NIfTI's) as
    both sform and qform (code 1, scanner), no scaling, and cal_min/cal_max set to the value
    range for viewers. The array is stored x fastest, as it is read back. The qform holds a
    mirrored direction too (its qfac is -1 then)."""
    affine = volume.affine
    image = nib.Nifti1Image(np.ascontiguousarray(volume.data).T, affine)
    image.header.set_sform(affine, code=1)
    image.header.set_qform(affine, code=1)
    image.header.set_slope_inter(1.0, 0.0)
    image.header["descrip"] = WRITER_TAG
    if volume.declared_range is not None:
        image.header["cal_min"], image.header["cal_max"] = volume.declared_range
    nib.save(image, str(file))
