"""NRRD volumes: attached (.nrrd) and detached (.nhdr) headers, parsed with pynrrd.

Header fields read (http://teem.sourceforge.net/nrrd/format.html):
  dimension, sizes (x y z; a 2D image is one slice; a last axis whose ``kinds`` entry is
             ``time`` holds time points: one is read, the volume's time_steps counts them),
  kinds      (only to find a time axis), type, endian, encoding, byte skip, line skip,
  data file  (one file; ``name.%d <min> <max> <step> [<subdim>]``; or ``LIST [<subdim>]`` with one
             file name per following line),
  space directions, space origin, space   the grid: each axis's vector (spacing = its length,
             direction = the unit vectors, refused by name when sheared; an axis without one,
             ``none`` or a 2D image's third, gets spacing 1 and a direction perpendicular to the
             others) and the origin, converted from the named space to RAS (SPACE_FRAMES:
             left-posterior-superior and scanner-xyz, DICOM's frame, negate x and y;
             left-anterior-superior negates x; the 3D-right/left-handed spaces have no patient
             meaning and are taken as they are, as a file without ``space``),
  spacings   without space directions: the spacing, axes along the world's (identity direction),
  min / max  (the declared value range; the key/value ``vgraph value range:=lo hi`` written by
             vgraph's own writer takes precedence).
pynrrd parses the header; the data are read by nrrd_data.py with exact size checks (without an
explicit ``byte skip`` a raw data file must hold exactly the described bytes; a compressed stream
must decompress to exactly them).
"""

from __future__ import annotations

from pathlib import Path

import nrrd
import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_origin, check_spacing, check_time_step, header_lines,
                               make_volume, pad_to_3d, regular_file)
from vgraph.io.label_hints import nrrd_says_labels
from vgraph.io.nrrd_data import MAX_DATA_FILES, read_data
from vgraph.io.orientation import split_axes
from vgraph.volume import IDENTITY, Volume

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
# NRRD's spaces (lower case, as teem compares them) by the signs that take them to RAS.
SPACE_FRAMES = {
    (1.0, 1.0, 1.0): ("right-anterior-superior", "ras", "right-anterior-superior-time", "rast",
                      "3d-right-handed", "3d-right-handed-time", "3d-left-handed",
                      "3d-left-handed-time"),
    (-1.0, 1.0, 1.0): ("left-anterior-superior", "las", "left-anterior-superior-time", "last"),
    (-1.0, -1.0, 1.0): ("left-posterior-superior", "lps", "left-posterior-superior-time", "lpst",
                        "scanner-xyz", "scanner-xyz-time"),
}
WRITTEN_SPACE = "right-anterior-superior"


def read_nrrd(path, time_step: int = 0) -> Volume:
    path = regular_file(path)
    lines, data_offset, listed_files = _split_header(path)
    header = _parsed_header(lines, path)
    for field in ("dimension", "sizes", "type", "encoding"):
        if field not in header:
            raise VolumeFileError(path, "required field is missing", field)
    if len(header["sizes"]) != header["dimension"]:
        raise VolumeFileError(path, f"dimension is {header['dimension']} but sizes lists "
                                    f"{len(header['sizes'])} values", "sizes")
    dims, time_steps = _dims_and_time(header, path)
    time_step = check_time_step(path, time_step, time_steps)
    dtype = _dtype(header, path)
    count = dims[0] * dims[1] * dims[2]
    spacing, origin, direction = grid_of(header, path)
    declared = _declared_range(header, path)
    flat = read_data(path, header, dtype, count, data_offset, listed_files,
                     first=time_step * count, total=count * time_steps)
    return make_volume(flat.reshape(dims[::-1]), path, spacing=spacing, origin=origin,
                       direction=direction, declared_range=declared, time_steps=time_steps,
                       holds_labels=nrrd_says_labels(header))


def _dims_and_time(header: dict, path: Path) -> tuple[tuple[int, int, int], int]:
    """(x, y, z) voxel counts and the number of time points: the last axis is time when its
    ``kinds`` entry says so (the only way a NRRD tells time from a 4th spatial or vector axis)."""
    sizes = [int(s) for s in header["sizes"]]
    kinds = [str(k).lower() for k in header.get("kinds", [])]
    if len(sizes) in (3, 4) and len(kinds) == len(sizes) and kinds[-1] == "time":
        return pad_to_3d(sizes[:-1], path, "sizes"), max(sizes[-1], 1)
    while len(sizes) > 3 and sizes[-1] == 1:  # trailing axes of size 1 carry nothing
        sizes.pop()
    if len(sizes) > 3:
        raise VolumeFileError(path, f"expected a 3D scalar volume, got {len(sizes)} axes with "
                                    f"sizes {tuple(sizes)}; a 4th axis is read as time when "
                                    f"'kinds' marks it so (e.g. kinds: domain domain domain time)",
                              "sizes")
    return pad_to_3d(sizes, path, "sizes"), 1


def _parsed_header(lines: list[str], path: Path) -> dict:
    try:
        return nrrd.read_header(lines)
    except Exception as exc:  # pynrrd raises NRRDError, ValueError, IndexError... for bad text
        raise VolumeFileError(path, f"invalid NRRD header: {exc}", "header") from exc


def _split_header(path: Path) -> tuple[list[str], int, list[str] | None]:
    """Header lines (for pynrrd), the byte offset where attached data start, and the file names of
    a ``data file: LIST`` header (pynrrd would take them for fields)."""
    lines, listed = [], None
    try:
        with open(path, "rb") as fh:
            if not fh.read(4) == b"NRRD":
                raise VolumeFileError(path, "not a NRRD file (no 'NRRD000x' magic line)", "magic")
            fh.seek(0)
            for raw_line in header_lines(fh, path):
                line = raw_line.decode("latin-1").rstrip("\r\n")
                if not line.strip():
                    break
                if listed is not None:
                    listed.append(line.strip())
                    if len(listed) > MAX_DATA_FILES:
                        raise VolumeFileError(path, f"lists more than {MAX_DATA_FILES} data files",
                                              "data file")
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
        raise VolumeFileError(path, f"cannot read header: {exc.strerror}", "header") from exc
    return lines, offset, listed


def _dtype(header: dict, path: Path) -> np.dtype:
    code = _TYPE_CODES.get(header["type"])
    if code is None:
        raise VolumeFileError(path, f"unsupported type {header['type']!r}", "type")
    dtype = np.dtype(code)
    if dtype.itemsize > 1 and str(header["encoding"]).lower() not in ("ascii", "text", "txt"):
        endian = header.get("endian")
        if endian not in ("little", "big"):
            raise VolumeFileError(path, f"endian must be 'little' or 'big' for {header['type']} "
                                        f"data, got {endian!r}", "endian")
        dtype = dtype.newbyteorder("<" if endian == "little" else ">")
    return dtype


def grid_of(header: dict, path: Path):
    """(spacing, origin, direction) in RAS (module docstring)."""
    frame = _space_frame(header, path)
    if "space directions" in header:
        axes = np.zeros((3, 3))  # columns: the index axes' vectors (a 2D image's third: none)
        for c, row in enumerate(list(header["space directions"])[:3]):
            axes[:, c] = _padded(row)
        spacing, direction, _ = split_axes(frame @ axes, path, "space directions")
        spacing = check_spacing(spacing, path, "space directions")
    elif "spacings" in header:
        values = [1.0 if not np.isfinite(s) else float(s) for s in header["spacings"][:3]]
        spacing, direction = check_spacing((values + [1.0, 1.0, 1.0])[:3], path, "spacings"), IDENTITY
    else:
        spacing, direction = (1.0, 1.0, 1.0), IDENTITY
    return spacing, _origin(header, path, frame), direction


def _padded(row) -> np.ndarray:
    """An axis vector as three numbers (a 2D space's third is 0; ``none`` is NaN throughout)."""
    values = np.asarray(row, dtype=float).reshape(-1)[:3]
    return np.concatenate([values, np.zeros(3 - len(values))])


def _space_frame(header: dict, path: Path) -> np.ndarray:
    """The matrix that takes the header's ``space`` coordinates to RAS."""
    if "space" not in header:
        return np.eye(3)
    name = str(header["space"]).strip().lower()
    for frame, names in SPACE_FRAMES.items():
        if name in names:
            return np.diag(frame)
    raise VolumeFileError(path, f"unknown space {header['space']!r}; NRRD's spaces are "
                                f"{', '.join(n for names in SPACE_FRAMES.values() for n in names)}",
                          "space")


def _origin(header: dict, path: Path, frame: np.ndarray) -> tuple[float, float, float]:
    if "space origin" not in header:
        return (0.0, 0.0, 0.0)
    values = _padded(header["space origin"])
    return check_origin(frame @ values, path, "space origin")


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
    """An attached, gzip-compressed NRRD in space right-anterior-superior (vgraph's own frame:
    3D Slicer and ITK read it into their LPS themselves) with the affine's columns as space
    directions, the space origin and, if declared, the value range as the key/value
    ``vgraph value range:=lo hi``."""
    affine = volume.affine
    header = {
        "encoding": "gzip",
        "space": WRITTEN_SPACE,
        "space directions": affine[:3, :3].T,  # one row per index axis
        "space origin": affine[:3, 3],
        "kinds": ["domain", "domain", "domain"],
    }
    if volume.declared_range is not None:
        header[VALUE_RANGE_KEY] = "{!r} {!r}".format(*(float(v) for v in volume.declared_range))
    with open(file, "wb") as fh:
        # gzip level 1: about as small as level 9 on volume data and many times faster
        nrrd.write(fh, np.ascontiguousarray(volume.data), header, index_order="C", compression_level=1)
