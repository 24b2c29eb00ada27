"""NRRD volumes: attached (.nrrd) and detached (.nhdr) headers, parsed with pynrrd.

Header fields read (http://teem.sourceforge.net/nrrd/format.html):
  dimension, sizes (x y z; a 2D image is one slice), type, endian, encoding, byte skip, line skip,
  data file  (one file; ``name.%d <min> <max> <step> [<subdim>]``; or ``LIST [<subdim>]`` with one
             file name per following line), spacings or space directions (spacing = length of each
             axis vector; the orientation itself is not applied), space origin (origin),
  min / max  (the declared value range; the key/value ``vgraph value range:=lo hi`` written by
             vgraph's own writer takes precedence).
pynrrd parses the header. Raw data (attached, detached or multi-file) are read here with exact
size checks: without an explicit ``byte skip`` a data file must hold exactly the described bytes.
Compressed single-file data (gzip, bzip2) and ASCII go through pynrrd; multi-file data may be raw
or gzip/bzip2.
"""

from __future__ import annotations

import bz2
import gzip
import re
import zlib
from pathlib import Path

import nrrd
import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_memory, check_origin, check_spacing, existing_file,
                               make_volume, pad_to_3d, read_raw_array, to_native)
from vgraph.volume import Volume

VALUE_RANGE_KEY = "vgraph value range"
_TYPES = {
    "i1": ("signed char", "int8", "int8_t"),
    "u1": ("uchar", "unsigned char", "uint8", "uint8_t"),
    "i2": ("short", "short int", "signed short", "signed short int", "int16", "int16_t"),
    "u2": ("ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"),
    "i4": ("int", "signed int", "int32", "int32_t"),
    "u4": ("uint", "unsigned int", "uint32", "uint32_t"),
    "i8": ("longlong", "long long", "long long int", "signed long long", "signed long long int",
           "int64", "int64_t"),
    "u8": ("ulonglong", "unsigned long long", "unsigned long long int", "uint64", "uint64_t"),
    "f4": ("float",), "f8": ("double",),
}
_TYPE_CODES = {name: code for code, names in _TYPES.items() for name in names}
_PATTERN = re.compile(r"^(\S*%\S*)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)(?:\s+(\d+))?$")
_COMPRESSED = {"gzip": gzip.decompress, "gz": gzip.decompress, "bzip2": bz2.decompress,
               "bz2": bz2.decompress}


def read_nrrd(path) -> Volume:
    path = Path(path)
    lines, data_offset, listed_files = _split_header(path)
    try:
        header = nrrd.read_header(lines)
    except (nrrd.NRRDError, ValueError) as exc:
        raise VolumeFileError(path, f"invalid NRRD header: {exc}", "header") from exc
    for field in ("dimension", "sizes", "type", "encoding"):
        if field not in header:
            raise VolumeFileError(path, "required field is missing", field)
    if len(header["sizes"]) != header["dimension"]:
        raise VolumeFileError(path, f"dimension is {header['dimension']} but sizes lists "
                                    f"{len(header['sizes'])} values", "sizes")
    dims = pad_to_3d(header["sizes"], path, "sizes")
    dtype = _dtype(header, path)
    count = dims[0] * dims[1] * dims[2]
    flat = _read_data(path, header, dtype, count, data_offset, listed_files)
    return make_volume(flat.reshape(dims[::-1]), path, spacing=_spacing(header, path),
                       origin=_origin(header, path), declared_range=_declared_range(header, path))


def _split_header(path: Path) -> tuple[list[str], int, list[str] | None]:
    """Header lines (for pynrrd), the byte offset where attached data start, and the file names of
    a ``data file: LIST`` header (pynrrd would take them for fields)."""
    lines, listed = [], None
    try:
        with open(path, "rb") as fh:
            if not fh.read(4) == b"NRRD":
                raise VolumeFileError(path, "not a NRRD file (no 'NRRD000x' magic line)", "magic")
            fh.seek(0)
            for raw_line in fh:
                line = raw_line.decode("latin-1").rstrip("\r\n")
                if not line.strip():
                    break
                if listed is not None:
                    listed.append(line.strip())
                    continue
                if not line.startswith("#") and ":" not in line and lines:
                    raise VolumeFileError(path, f"header line {len(lines) + 1} is not "
                                                f"'field: value': {line[:60]!r}",
                                          f"line {len(lines) + 1}")
                lines.append(line)
                key, _, value = line.partition(":")
                if key.strip() in ("data file", "datafile") and value.strip().split()[:1] == ["LIST"]:
                    listed = []
            offset = fh.tell()
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read header: {exc.strerror}") from exc
    return lines, offset, listed


def _dtype(header: dict, path: Path) -> np.dtype:
    code = _TYPE_CODES.get(header["type"])
    if code is None:
        raise VolumeFileError(path, f"unsupported type {header['type']!r}", "type")
    dtype = np.dtype(code)
    if dtype.itemsize > 1 and header["encoding"] not in ("ascii", "ASCII", "text", "txt"):
        endian = header.get("endian")
        if endian not in ("little", "big"):
            raise VolumeFileError(path, f"endian must be 'little' or 'big' for {header['type']} "
                                        f"data, got {endian!r}", "endian")
        dtype = dtype.newbyteorder("<" if endian == "little" else ">")
    return dtype


def _read_data(path, header, dtype, count, data_offset, listed_files) -> np.ndarray:
    data_file = header.get("data file", header.get("datafile"))
    if data_file is not None:
        files, subdim = _data_files(path, data_file, listed_files, header["dimension"])
        if len(files) > 1 or subdim is not None:
            return _read_multi_file(path, header, dtype, count, files, subdim)
    encoding = header["encoding"]
    explicit_skip = "byte skip" in header or "byteskip" in header
    byte_skip = header.get("byte skip", header.get("byteskip", 0))
    line_skip = header.get("line skip", header.get("lineskip", 0))
    if encoding == "raw" and line_skip == 0:
        source = path if data_file is None else files[0]
        start = (0 if data_file is not None else data_offset) + max(byte_skip, 0)
        return read_raw_array(source, dtype, count, offset=-1 if byte_skip == -1 else start,
                              allow_trailing=explicit_skip, size_field="sizes",
                              header=None if data_file is None else path)
    return _read_with_pynrrd(path, header, dtype, count, data_offset)


def _data_files(path: Path, value: str, listed: list[str] | None, dimension: int):
    """Data file paths (relative to the header's folder) and the sub-dimension per file."""
    if listed is not None:  # data file: LIST [subdim]
        parts = value.split()
        subdim = int(parts[1]) if len(parts) > 1 else dimension - 1
        names = listed
    else:
        match = _PATTERN.match(value.strip())
        if match is None:
            return [existing_file(path.parent / value, path, "data file")], None
        pattern, first, last, step, sub = match.groups()
        first, last, step = int(first), int(last), int(step)
        if step == 0 or (last - first) * step < 0:
            raise VolumeFileError(path, f"file number range {first}..{last} step {step} is empty",
                                  "data file")
        try:
            names = [pattern % i for i in range(first, last + (1 if step > 0 else -1), step)]
        except (TypeError, ValueError) as exc:
            raise VolumeFileError(path, f"bad file name pattern {pattern!r}: {exc}", "data file")
        subdim = int(sub) if sub else dimension - 1
    if not 1 <= subdim <= dimension:
        raise VolumeFileError(path, f"sub-dimension must be in 1..{dimension}, got {subdim}",
                              "data file")
    return [existing_file(path.parent / name, path, "data file") for name in names], subdim


def _read_multi_file(path, header, dtype, count, files, subdim) -> np.ndarray:
    sizes = [int(s) for s in header["sizes"]]
    per_file = int(np.prod(sizes[:subdim]))
    if per_file * len(files) != count:
        raise VolumeFileError(path, f"{len(files)} data files of {per_file} values each do not make "
                                    f"up the {count} values of sizes {sizes}", "data file")
    check_memory(path, count * dtype.itemsize, "sizes")
    explicit_skip = "byte skip" in header or "byteskip" in header
    byte_skip = header.get("byte skip", header.get("byteskip", 0))
    encoding = header["encoding"]
    if encoding != "raw" and encoding not in _COMPRESSED:
        raise VolumeFileError(path, f"encoding {encoding!r} is not supported for multi-file data",
                              "encoding")
    out = np.empty(count, dtype=dtype.newbyteorder("="))
    for index, file in enumerate(files):
        if encoding == "raw":
            part = read_raw_array(file, dtype, per_file, offset=byte_skip,
                                  allow_trailing=explicit_skip, size_field="sizes", header=path)
        else:
            part = _decompressed_part(path, file, encoding, dtype, per_file, byte_skip)
        out[index * per_file:(index + 1) * per_file] = part
    return out


def _decompressed_part(path, file, encoding, dtype, per_file, byte_skip) -> np.ndarray:
    try:
        payload = _COMPRESSED[encoding](Path(file).read_bytes())
    except (OSError, EOFError, ValueError) as exc:
        raise VolumeFileError(path, f"cannot decompress data file {str(file)!r}: {exc}",
                              "encoding") from exc
    start = len(payload) - per_file * dtype.itemsize if byte_skip == -1 else byte_skip
    payload = payload[start:]
    if len(payload) < per_file * dtype.itemsize:
        raise VolumeFileError(path, f"data file {str(file)!r} is truncated: expected "
                                    f"{per_file * dtype.itemsize} bytes after decompression, "
                                    f"found {len(payload)}", "sizes")
    return to_native(np.frombuffer(payload, dtype=dtype, count=per_file))


def _read_with_pynrrd(path, header, dtype, count, data_offset) -> np.ndarray:
    check_memory(path, count * dtype.itemsize + path.stat().st_size, "sizes")
    try:
        with open(path, "rb") as fh:
            fh.seek(data_offset)
            data = nrrd.read_data(header, fh, str(path), index_order="C")
    except (nrrd.NRRDError, OSError, EOFError, ValueError, zlib.error) as exc:
        field = "sizes" if "Size of the data" in str(exc) else "encoding"  # pynrrd's count check
        raise VolumeFileError(path, f"cannot read {header['encoding']} data (truncated or corrupt? "
                                    f"sizes describe {count} values): {exc}", field) from exc
    return to_native(np.asarray(data)).reshape(-1)


def _spacing(header: dict, path: Path) -> tuple[float, float, float]:
    if "space directions" in header:
        field, values = "space directions", []
        for row in list(header["space directions"])[:3]:
            row = np.asarray(row, dtype=float)
            values.append(1.0 if not np.all(np.isfinite(row)) else float(np.linalg.norm(row)))
    elif "spacings" in header:
        field = "spacings"
        values = [1.0 if not np.isfinite(s) else float(s) for s in header["spacings"][:3]]
    else:
        return (1.0, 1.0, 1.0)
    return check_spacing((values + [1.0, 1.0, 1.0])[:3], path, field)


def _origin(header: dict, path: Path) -> tuple[float, float, float]:
    if "space origin" not in header:
        return (0.0, 0.0, 0.0)
    values = [float(v) for v in np.asarray(header["space origin"], dtype=float)[:3]]
    return check_origin((values + [0.0, 0.0, 0.0])[:3], path, "space origin")


def _declared_range(header: dict, path: Path):
    if VALUE_RANGE_KEY in header:
        try:
            lo, hi = (float(v) for v in str(header[VALUE_RANGE_KEY]).split())
        except ValueError:
            raise VolumeFileError(path, f"expected two numbers, got {header[VALUE_RANGE_KEY]!r}",
                                  VALUE_RANGE_KEY) from None
    elif "min" in header and "max" in header:
        lo, hi = float(header["min"]), float(header["max"])
    else:
        return None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise VolumeFileError(path, f"value range must be finite with low < high, got ({lo}, {hi})",
                              VALUE_RANGE_KEY if VALUE_RANGE_KEY in header else "min/max")
    return (lo, hi)


def write_nrrd(volume: Volume, file: Path) -> None:
    """An attached, gzip-compressed NRRD with diagonal space directions (the spacing), the space
    origin and, if declared, the value range as the key/value ``vgraph value range:=lo hi``."""
    header = {
        "encoding": "gzip",
        "space dimension": 3,
        "space directions": np.diag(np.asarray(volume.spacing, dtype=float)),
        "space origin": np.asarray(volume.origin, dtype=float),
        "kinds": ["domain", "domain", "domain"],
    }
    if volume.declared_range is not None:
        header[VALUE_RANGE_KEY] = "{!r} {!r}".format(*(float(v) for v in volume.declared_range))
    with open(file, "wb") as fh:
        # gzip level 1: about as small as level 9 on volume data and many times faster
        nrrd.write(fh, np.ascontiguousarray(volume.data), header, index_order="C", compression_level=1)
