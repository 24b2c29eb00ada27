"""MetaImage volumes (ITK/VTK): .mhd text header + data file, or .mha with the data attached.

Header ``Key = value`` fields read (keys as MetaIO writes them):
  NDims                          2, 3 or 4 (the 4th axis is time, as in ITK's 4D images: one time
                                 point is read, the volume's time_steps counts them)
  DimSize                        x y z [t] voxel counts
  ElementType                    MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT,
                                 MET_LONG (4 bytes), MET_ULONG, MET_LONG_LONG, MET_ULONG_LONG,
                                 MET_FLOAT, MET_DOUBLE
  ElementSpacing                 spacing (falls back to ElementSize, then 1)
  Offset / Origin / Position     origin
  TransformMatrix / Rotation / Orientation   the direction: NDims x NDims numbers, each run of
                                 NDims the world vector of one index axis (ITK's MetaImageIO
                                 reads and writes it so: SetDirection(axis, run)); refused by
                                 name when not a rotation (possibly mirrored)
  AnatomicalOrientation          not read (ITK does not either: TransformMatrix says it all)
  ElementByteOrderMSB / BinaryDataByteOrderMSB   True = big-endian
  ElementNumberOfChannels        must be 1
  CompressedData                 True = zlib stream; it must decompress to exactly the bytes
                                 DimSize and ElementType describe
  HeaderSize                     bytes to skip in the data file (-1: data are the last bytes)
  ElementMin / ElementMax        the declared value range, when both are given
  ElementDataFile                file name relative to the header, or LOCAL (data follow the
                                 header); it must be the last field. LIST and file patterns are
                                 not supported.
Frame: a header with TransformMatrix (or its aliases) or AnatomicalOrientation is ITK's, whose
physical space is LPS: the direction and origin are converted to RAS (x and y negated,
vgraph.io.orientation). A header with neither (VTK's older writers, hand-written ones) declares
no frame: its coordinates are taken as they are, as for files of formats without orientation.
A raw data file must hold exactly the described bytes unless HeaderSize is given.

Writing (.mha): LOCAL zlib-compressed data after a header in ITK's form: TransformMatrix, Offset
and AnatomicalOrientation in LPS, ElementMin/ElementMax if the value range is declared.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from vgraph.byte_order import to_native
from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_dims, check_origin, check_spacing, check_time_step, header_lines,
                               make_volume, parse_numbers, read_raw_array, regular_file)
from vgraph.io._inflate import file_pieces, inflate_into
from vgraph.io.orientation import LPS_TO_RAS, file_direction, lps_ras
from vgraph.memory import check_memory
from vgraph.volume import Volume

ELEMENT_TYPES = {
    "MET_CHAR": "i1", "MET_UCHAR": "u1", "MET_SHORT": "i2", "MET_USHORT": "u2",
    "MET_INT": "i4", "MET_UINT": "u4", "MET_LONG": "i4", "MET_ULONG": "u4",
    "MET_LONG_LONG": "i8", "MET_ULONG_LONG": "u8", "MET_FLOAT": "f4", "MET_DOUBLE": "f8",
}
_TRUE = ("true", "1", "yes")
_MATRIX_KEYS = ("TransformMatrix", "Rotation", "Orientation")  # MetaIO's names for one field


def read_metaimage(path, time_step: int = 0) -> Volume:
    path = regular_file(path)
    fields, data_offset = parse_header(path)
    if "ElementDataFile" not in fields:
        raise VolumeFileError(path, "required field is missing", "ElementDataFile")
    ndims = parse_numbers(fields.get("NDims", "3"), path, "NDims", 1, int)[0]
    if ndims not in (2, 3, 4):
        raise VolumeFileError(path, f"only 2D, 3D and 3D + time images are supported, got "
                                    f"NDims = {ndims}", "NDims")
    sizes = parse_numbers(_required(fields, "DimSize", path), path, "DimSize", ndims, int)
    dims = check_dims(sizes[:3] + [1] * (3 - ndims), path, "DimSize")
    time_steps = sizes[3] if ndims == 4 else 1
    if time_steps < 1:
        raise VolumeFileError(path, f"the time axis must hold at least 1 point, got {time_steps}",
                              "DimSize")
    time_step = check_time_step(path, time_step, time_steps)
    channels = parse_numbers(fields.get("ElementNumberOfChannels", "1"), path,
                             "ElementNumberOfChannels", 1, int)[0]
    if channels != 1:
        raise VolumeFileError(path, f"only scalar images are supported, got {channels} channels",
                              "ElementNumberOfChannels")
    if fields.get("BinaryData", "True").lower() not in _TRUE:
        raise VolumeFileError(path, "ASCII MetaImage data are not supported", "BinaryData")
    dtype = _dtype(fields, path)
    count = dims[0] * dims[1] * dims[2]
    flat = _read_data(path, fields, data_offset, dtype, count, time_step, time_steps)
    spacing, origin, direction = grid_of(fields, path, ndims)
    return make_volume(flat.reshape(dims[::-1]), path, spacing=spacing, origin=origin,
                       direction=direction, declared_range=_range(fields, path),
                       time_steps=time_steps)


def parse_header(path: Path) -> tuple[dict[str, str], int]:
    """Fields up to and including ElementDataFile, and the byte offset after that line."""
    fields: dict[str, str] = {}
    try:
        with open(path, "rb") as fh:
            for number, raw_line in enumerate(header_lines(fh, path), start=1):
                line = raw_line.decode("latin-1").strip()
                if not line:
                    continue
                key, equals, value = line.partition("=")
                if not equals:
                    raise VolumeFileError(path, f"line {number} is not 'Key = value': {line[:60]!r}",
                                          f"line {number}")
                fields[key.strip()] = value.strip()
                if key.strip() == "ElementDataFile":
                    break
            offset = fh.tell()
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read header: {exc.strerror}", "header") from exc
    return fields, offset


def _required(fields: dict, key: str, path: Path) -> str:
    if key not in fields:
        raise VolumeFileError(path, "required field is missing", key)
    return fields[key]


def _dtype(fields: dict, path: Path) -> np.dtype:
    name = _required(fields, "ElementType", path)
    if name not in ELEMENT_TYPES:
        raise VolumeFileError(path, f"unknown ElementType {name!r}; known: "
                                    f"{', '.join(ELEMENT_TYPES)}", "ElementType")
    msb = fields.get("ElementByteOrderMSB", fields.get("BinaryDataByteOrderMSB", "False"))
    return np.dtype((">" if msb.lower() in _TRUE else "<") + ELEMENT_TYPES[name])


def _read_data(path: Path, fields: dict, data_offset: int, dtype: np.dtype, count: int,
               time_step: int = 0, time_steps: int = 1):
    """The ``count`` values of one time point; the data file must hold all of them."""
    name = fields["ElementDataFile"]
    if not name:
        raise VolumeFileError(path, "no file name", "ElementDataFile")
    if name.split()[0].upper() == "LIST" or "%" in name:
        raise VolumeFileError(path, f"multi-file data ({name!r}) are not supported", "ElementDataFile")
    local = name.upper() == "LOCAL"
    data_file = path if local else regular_file(path.parent / name, path, "ElementDataFile")
    header_size = parse_numbers(fields["HeaderSize"], path, "HeaderSize", 1, int)[0] \
        if "HeaderSize" in fields else None
    if fields.get("CompressedData", "False").lower() in _TRUE:
        start = data_offset if local else max(header_size or 0, 0)
        return _read_compressed(path, data_file, start, dtype, count, time_step, time_steps)
    if local:
        offset = data_offset + (header_size or 0) if header_size != -1 else -1
    else:
        offset = 0 if header_size is None else header_size
    return read_raw_array(data_file, dtype, count * time_steps, offset=offset,
                          allow_trailing=header_size is not None, size_field="DimSize",
                          header=None if local else path, window=(time_step * count, count))


def _read_compressed(path, data_file, start, dtype, count, time_step, time_steps) -> np.ndarray:
    """One time point of a zlib stream; inflating stops after it."""
    check_memory(path, count * dtype.itemsize, "DimSize")
    out = np.empty(count, dtype=dtype)
    inflate_into(out.view(np.uint8), file_pieces(data_file, start, path, "ElementDataFile"), "zlib",
                 path, "DimSize", codec_field="CompressedData",
                 skip=time_step * count * dtype.itemsize, partial=time_step < time_steps - 1)
    return to_native(out, copy=False)


def _spacing(fields: dict, path: Path, ndims: int):
    """(x, y, z); a 4D image's 4th value (the time step) is not a length."""
    for key in ("ElementSpacing", "ElementSize"):
        if key in fields:
            values = parse_numbers(fields[key], path, key, ndims)[:3]
            return check_spacing(values + [1.0] * (3 - len(values)), path, key)
    return (1.0, 1.0, 1.0)


def grid_of(fields: dict, path: Path, ndims: int):
    """(spacing, origin, direction) in RAS (the module docstring says when the file is LPS)."""
    frame = LPS_TO_RAS if any(key in fields for key in (*_MATRIX_KEYS, "AnatomicalOrientation")) \
        else np.eye(3)
    key = next((k for k in _MATRIX_KEYS if k in fields), None)
    axes = np.eye(3)
    if key is not None:
        runs = np.array(parse_numbers(fields[key], path, key, ndims * ndims)).reshape(ndims, ndims)
        for axis in range(min(ndims, 3)):  # a 4D image's 4th axis is time; a 2D image's 3rd: z
            axes[:, axis] = 0.0
            axes[:min(ndims, 3), axis] = runs[axis, :3]
    direction = file_direction(frame @ axes, path, key or "TransformMatrix")
    return _spacing(fields, path, ndims), _origin(fields, path, ndims, frame), direction


def _origin(fields: dict, path: Path, ndims: int, frame=np.eye(3)):
    for key in ("Offset", "Origin", "Position"):
        if key in fields:
            values = parse_numbers(fields[key], path, key, ndims)[:3]
            return check_origin(frame @ np.array(values + [0.0] * (3 - len(values))), path, key)
    return (0.0, 0.0, 0.0)


def _range(fields: dict, path: Path):
    if "ElementMin" in fields and "ElementMax" in fields:
        lo = parse_numbers(fields["ElementMin"], path, "ElementMin", 1)[0]
        hi = parse_numbers(fields["ElementMax"], path, "ElementMax", 1)[0]
        if not lo < hi:
            raise VolumeFileError(path, f"ElementMin {lo} must be below ElementMax {hi}",
                                  "ElementMin/ElementMax")
        return (lo, hi)
    return None


# --- writing -------------------------------------------------------------------------------------
_ELEMENT_NAMES = {"i1": "MET_CHAR", "u1": "MET_UCHAR", "i2": "MET_SHORT", "u2": "MET_USHORT",
                  "i4": "MET_INT", "u4": "MET_UINT", "i8": "MET_LONG_LONG", "u8": "MET_ULONG_LONG",
                  "f4": "MET_FLOAT", "f8": "MET_DOUBLE"}
_COMPRESS_BYTES = 16 * 2**20  # compressed piece by piece: no second copy of a big volume


def write_metaimage(volume: Volume, file: Path) -> None:
    """A .mha as ITK writes one (module docstring): what SimpleITK, 3D Slicer and vgraph read back
    onto the same voxels."""
    flat = np.ascontiguousarray(volume.data).reshape(-1)
    little = flat.dtype.newbyteorder("<")
    compressor, pieces = zlib.compressobj(1), []  # level 1: near level 9's size, much faster
    step = max(1, _COMPRESS_BYTES // flat.dtype.itemsize)
    for start in range(0, flat.size, step):
        piece = np.ascontiguousarray(flat[start:start + step], dtype=little)  # no copy when native
        pieces.append(compressor.compress(memoryview(piece).cast("B")))
    pieces.append(compressor.flush())
    with open(file, "wb") as fh:
        fh.write(_header_text(volume, little, sum(map(len, pieces))).encode("ascii"))
        for piece in pieces:
            fh.write(piece)


def _header_text(volume: Volume, dtype: np.dtype, compressed_size: int) -> str:
    axes = lps_ras(np.asarray(volume.direction))  # columns: the index axes in LPS
    lines = [("ObjectType", "Image"), ("NDims", "3"), ("BinaryData", "True"),
             ("BinaryDataByteOrderMSB", "False"), ("CompressedData", "True"),
             ("CompressedDataSize", str(compressed_size)),
             ("TransformMatrix", _numbers(axes.T.reshape(-1))),  # one run per axis
             ("Offset", _numbers(lps_ras(volume.origin))), ("CenterOfRotation", "0 0 0"),
             ("AnatomicalOrientation", anatomical_orientation(axes)),
             ("ElementSpacing", _numbers(volume.spacing)),
             ("DimSize", " ".join(map(str, volume.dims)))]
    if volume.declared_range is not None:
        lines += [("ElementMin", repr(float(volume.declared_range[0]))),
                  ("ElementMax", repr(float(volume.declared_range[1])))]
    lines += [("ElementType", _ELEMENT_NAMES[dtype.str[1:]]), ("ElementDataFile", "LOCAL")]
    return "".join(f"{key} = {value}\n" for key, value in lines)


def anatomical_orientation(axes_lps: np.ndarray) -> str:
    """MetaIO's three letters: per index axis, the side it comes FROM (ITK's convention, so the
    identity in LPS is "RAI"), of the world axis it runs most along."""
    letters = ""
    for c in range(3):
        world = int(np.argmax(np.abs(axes_lps[:, c])))
        toward_plus = axes_lps[world, c] > 0  # +x is Left, +y Posterior, +z Superior in LPS
        letters += ("RL", "AP", "IS")[world][0 if toward_plus else 1]
    return letters


def _numbers(values) -> str:
    return " ".join(repr(float(v)) for v in values)
