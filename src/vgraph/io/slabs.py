"""Input volumes read slab by slab (runs of z slices), for ``vgraph convert``.

Files whose voxels lie uncompressed in one data file, x fastest, are read slab by slab with plain
seeks and reads (not memory maps: the pages of a map count in the process's memory until it is
closed, so a 100 GiB map would show as 100 GiB resident): headerless raw, NRRD with raw encoding
and one data file, unscaled uncompressed NIfTI (.nii), MetaImage with raw data in one file, and
C-ordered NumPy .npy. Everything else (compressed or ascii data, multi-file NRRD, scaled NIfTI,
Fortran-ordered .npy, DICOM, .npz, SLC, VTI, QVis) is read whole by vgraph.io.read_volume, and
``SlabInput.how`` says so. Header checks are the readers' own functions, so bad input gets the
same errors as VolumeSource (missing file, truncated data, bad header field).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vgraph.byte_order import to_native
from vgraph.errors import VolumeFileError
from vgraph.io import extension_of, read_volume
from vgraph.io import metaimage, nifti, nrrd_data, nrrd_format, numpy_format
from vgraph.io._common import data_start, check_dims, check_time_step, parse_numbers, regular_file
from vgraph.io.label_hints import nifti_says_labels, nrrd_says_labels
from vgraph.io.raw import checked_raw_description, description_from_name
from vgraph.volume_grid import IDENTITY


@dataclass
class SlabInput:
    """A volume's grid and a way to read its slices [z0, z1)."""

    shape: tuple[int, int, int]           # [z, y, x]
    dtype: np.dtype                       # native byte order
    spacing: tuple[float, float, float]   # (x, y, z)
    origin: tuple[float, float, float]    # (x, y, z)
    declared_range: tuple[float, float] | None
    source: str
    how: str                              # "streamed ..." or "read whole ..." with the reason
    file: Path | None = None              # the data file and where its (time point's) voxels start
    start: int = 0
    file_dtype: np.dtype | None = None    # the stored byte order
    volume: object = None                 # the whole Volume when it was read whole
    direction: tuple = IDENTITY           # in RAS, as the reader gives it (vgraph.io.orientation)
    holds_labels: bool = False            # the header declares labels (vgraph.io.label_hints)

    @property
    def streamed(self) -> bool:
        return self.volume is None

    def slab(self, z0: int, z1: int) -> np.ndarray:
        if self.volume is not None:
            return self.volume.data[z0:z1]
        plane = self.shape[1] * self.shape[2]
        out = np.empty((z1 - z0) * plane, dtype=self.file_dtype)
        with open(self.file, "rb") as fh:
            fh.seek(self.start + z0 * plane * self.file_dtype.itemsize)
            got = fh.readinto(memoryview(out.view(np.uint8)))
        if got != out.nbytes:  # the file shrank after it was checked
            raise VolumeFileError(self.file, f"file ended after {got} of {out.nbytes} bytes of "
                                             f"slices {z0}..{z1}")
        return to_native(out, copy=False).reshape(z1 - z0, *self.shape[1:])


def open_input(path, raw: dict | None = None, time_step: int = 0) -> SlabInput:
    """The input of a conversion: streamed where the format allows, else read whole."""
    path = Path(path)
    ext = extension_of(path)
    opener = {".nrrd": _nrrd, ".nhdr": _nrrd, ".nii": _nifti, ".mhd": _metaimage,
              ".mha": _metaimage, ".npy": _npy}.get(ext)
    if raw is not None or ext == ".raw":
        opener = _raw
    reason = f"{ext or 'this'} files are not streamed"
    if opener is not None and not path.is_dir():
        found = opener(path, raw, time_step) if opener is _raw else opener(path, time_step)
        if isinstance(found, SlabInput):
            return found
        reason = found
    return _whole(path, raw, time_step, reason)


def _whole(path: Path, raw, time_step: int, reason: str) -> SlabInput:
    volume = read_volume(path, raw=raw, time_step=time_step)
    return SlabInput(volume.data.shape, volume.data.dtype, volume.spacing, volume.origin,
                     volume.declared_range, str(path), f"read whole ({reason})", volume=volume,
                     direction=volume.direction, holds_labels=bool(volume.holds_labels))


def _streamed(path, data_file, start, file_dtype, dims, grid, declared, kind,
              holds_labels: bool = False) -> SlabInput:
    """``grid``: (spacing, origin, direction) as the format's reader works them out."""
    spacing, origin, direction = grid
    return SlabInput(tuple(dims[::-1]), np.dtype(file_dtype).newbyteorder("="), tuple(spacing),
                     tuple(origin), declared, str(path), f"streamed ({kind}, slab by slab)",
                     file=Path(data_file), start=start, file_dtype=np.dtype(file_dtype),
                     direction=direction, holds_labels=holds_labels)


def _checked_start(data_file, header, dims, dtype, offset, allow_trailing, field,
                   time_step=0, time_steps=1) -> int:
    """Where time point ``time_step`` starts, after the reader's own size checks (truncated
    file, trailing bytes)."""
    count = math.prod(dims)
    try:
        size = os.path.getsize(data_file)
    except OSError as exc:
        raise VolumeFileError(header, f"cannot read data file {str(data_file)!r}: {exc.strerror}",
                              field) from exc
    start = data_start(data_file, header, size, count * time_steps * dtype.itemsize, offset,
                        allow_trailing, field)
    return start + time_step * count * dtype.itemsize


# --- formats ------------------------------------------------------------------------------------
def _raw(path: Path, description, time_step: int):
    description = description_from_name(path) if description is None else description
    dims, dtype, spacing, origin, offset = checked_raw_description(description, path)
    regular_file(path)
    check_time_step(path, time_step, 1)
    start = _checked_start(path, path, dims, dtype, 0 if offset is None else offset,
                           offset is not None, "dims")
    return _streamed(path, path, start, dtype, dims, (spacing, origin, IDENTITY), None, "raw")


def _nrrd(path: Path, time_step: int):
    path = regular_file(path)
    lines, data_offset, listed = nrrd_format._split_header(path)
    header = nrrd_format._parsed_header(lines, path)
    for field in ("dimension", "sizes", "type", "encoding"):
        if field not in header:
            raise VolumeFileError(path, "required field is missing", field)
    if nrrd_data._encoding(header, path) != "raw":
        return f"NRRD with {header['encoding']} encoding"
    data_file = header.get("data file", header.get("datafile"))
    if listed is not None or (data_file is not None and "%" in str(data_file)):
        return "NRRD with several data files"
    dims, time_steps = nrrd_format._dims_and_time(header, path)
    time_step = check_time_step(path, time_step, time_steps)
    dtype = nrrd_format._dtype(header, path)
    byte_skip, line_skip, explicit = nrrd_data._skips(header, path, "raw")
    file = path if data_file is None else regular_file(path.parent / str(data_file), path, "data file")
    start = nrrd_data._after_lines(file, data_offset if data_file is None else 0, line_skip, path)
    offset = -1 if byte_skip == -1 else start + byte_skip
    start = _checked_start(file, path, dims, dtype, offset, explicit, "sizes", time_step, time_steps)
    return _streamed(path, file, start, dtype, dims, nrrd_format.grid_of(header, path),
                     nrrd_format._declared_range(header, path), "NRRD raw", nrrd_says_labels(header))


def _nifti(path: Path, time_step: int):
    path = regular_file(path)
    header = nifti._header(path, False)
    dims, time_steps = nifti._dims_and_time(nifti._checked(path, "dim", header.get_data_shape), path)
    time_step = check_time_step(path, time_step, time_steps)
    stored = np.dtype(nifti._checked(path, "datatype", header.get_data_dtype))
    if stored.kind not in "uif" or stored.fields is not None:
        raise VolumeFileError(path, f"unsupported datatype {stored} (scalar integer or float only)",
                              "datatype")
    if nifti._scaling(header, path) != (1.0, 0.0):
        return "NIfTI with scl_slope/scl_inter scaling"
    start = _checked_start(path, path, dims, stored, header.get_data_offset(), True, "dim",
                           time_step, time_steps)
    return _streamed(path, path, start, stored, dims, nifti.grid_of(header, path),
                     nifti._declared_range(header), "NIfTI", nifti_says_labels(header))


def _metaimage(path: Path, time_step: int):
    path = regular_file(path)
    fields, data_offset = metaimage.parse_header(path)
    if fields.get("CompressedData", "False").lower() in metaimage._TRUE:
        return "compressed MetaImage"
    name = fields.get("ElementDataFile", "")
    if not name or name.split()[0].upper() == "LIST" or "%" in name \
            or fields.get("BinaryData", "True").lower() not in metaimage._TRUE:
        return "MetaImage without one binary data file"  # read_volume names the problem
    ndims = parse_numbers(fields.get("NDims", "3"), path, "NDims", 1, int)[0]
    if ndims not in (2, 3, 4) or fields.get("ElementNumberOfChannels", "1").strip() != "1":
        return "MetaImage that is not one scalar 3D image"
    sizes = parse_numbers(metaimage._required(fields, "DimSize", path), path, "DimSize", ndims, int)
    dims = check_dims(sizes[:3] + [1] * (3 - ndims), path, "DimSize")
    time_steps = sizes[3] if ndims == 4 else 1
    time_step = check_time_step(path, time_step, max(time_steps, 1))
    dtype = metaimage._dtype(fields, path)
    local = name.upper() == "LOCAL"
    data_file = path if local else regular_file(path.parent / name, path, "ElementDataFile")
    header_size = parse_numbers(fields["HeaderSize"], path, "HeaderSize", 1, int)[0] \
        if "HeaderSize" in fields else None
    if local:
        offset = data_offset + (header_size or 0) if header_size != -1 else -1
    else:
        offset = 0 if header_size is None else header_size
    start = _checked_start(data_file, path, dims, dtype, offset,
                           header_size is not None, "DimSize", time_step, time_steps)
    return _streamed(path, data_file, start, dtype, dims, metaimage.grid_of(fields, path, ndims),
                     metaimage._range(fields, path), "MetaImage raw")


def _npy(path: Path, time_step: int):
    path = regular_file(path)
    try:
        with open(path, "rb") as fh:
            shape, fortran, dtype, data_offset = numpy_format._npy_header(fh, path, "header")
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read the file: {exc.strerror}", "header") from exc
    numpy_format._check_shape_dtype(path, "shape", shape, dtype)
    time_steps = shape[0] if len(shape) == 4 else 1
    time_step = check_time_step(path, time_step, time_steps)
    if fortran:
        return "Fortran-ordered .npy"
    zyx = shape[-3:] if len(shape) >= 3 else (1, *shape)
    start = _checked_start(path, path, zyx[::-1], dtype, data_offset, False, "shape",
                           time_step, time_steps)
    return _streamed(path, path, start, dtype, zyx[::-1], ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), IDENTITY),
                     None, "NumPy .npy")
