"""The voxel data of a NRRD file, read here rather than by pynrrd so that every size is checked
before it is trusted: attached or detached, one data file or many, raw, gzip, bzip2 or ascii.

Fields used (http://teem.sourceforge.net/nrrd/format.html):
  encoding    raw | gzip (gz) | bzip2 (bz2) | ascii (text, txt)
  line skip   lines to skip at the start of each data file (before decompression)
  byte skip   bytes to skip after the line skip (after decompression for gzip/bzip2);
              -1 (raw only): the data are the last bytes of the file
  data file   one file; ``<pattern> <first> <last> <step> [<subdim>]`` (pattern with one %d);
              or ``LIST [<subdim>]`` with one file name per following header line

Limits (docs/guide/volumes.md): a compressed stream must decompress to exactly the bytes the sizes
declare, refused as soon as it holds more; at most MAX_DATA_FILES data files, and their number
must match the sizes before any name is built or any file is looked at.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vgraph.byte_order import to_native
from vgraph.errors import VolumeFileError
from vgraph.io._common import read_raw_array, regular_file
from vgraph.io._inflate import file_pieces, inflate_into
from vgraph.io._values import ascii_values
from vgraph.memory import check_memory

ENCODINGS = {"raw": "raw", "gzip": "gzip", "gz": "gzip", "bzip2": "bzip2", "bz2": "bzip2",
             "ascii": "ascii", "text": "ascii", "txt": "ascii"}
# A volume texture has at most a few thousand slices; more files than this is a damaged header
# (and a list of a billion names would take minutes and gigabytes to build).
MAX_DATA_FILES = 65536
_PATTERN = re.compile(r"^(\S*%\S*)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)(?:\s+(\d+))?$")
# One integer conversion with an optional zero flag and a width below 100 (``%d``, ``%03d``):
# Python's % would also take ``%.1000000000d`` and build a gigabyte name.
_NUMBER_FORMAT = re.compile(r"%0?\d{0,2}[diu]")


@dataclass(frozen=True)
class _Layout:
    """How the values lie in each data file."""
    encoding: str          # raw, gzip, bzip2 or ascii
    dtype: np.dtype        # in the file's byte order
    values: int            # values per data file
    byte_skip: int
    line_skip: int
    explicit_skip: bool    # a byte skip was given: trailing bytes are allowed


def read_data(path: Path, header: dict, dtype: np.dtype, count: int, data_offset: int,
              listed_files: list[str] | None, *, first: int = 0,
              total: int | None = None) -> np.ndarray:
    """``count`` values of ``dtype`` from value ``first`` on of the ``total`` (default: count)
    the header describes, flat, in native byte order. Only the data files holding them are
    read (one time point of a 4D file), and of those only the bytes needed where the encoding
    allows (raw: a seek; compressed: inflating stops after them)."""
    total = count if total is None else total
    encoding = _encoding(header, path)
    byte_skip, line_skip, explicit_skip = _skips(header, path, encoding)
    check_memory(path, count * dtype.itemsize, "sizes")
    data_file = header.get("data file", header.get("datafile"))
    if data_file is None:
        sources, per_file = [(path, data_offset)], total
    else:
        files, per_file = _data_files(path, str(data_file), listed_files, header, total)
        sources = [(file, 0) for file in files]
    layout = _Layout(encoding, dtype, per_file, byte_skip, line_skip, explicit_skip)
    wanted = range(first // per_file, (first + count - 1) // per_file + 1)
    if len(wanted) == 1 and per_file == count:
        return _read_part(path, *sources[wanted[0]], layout)
    out = np.empty(count, dtype=dtype.newbyteorder("="))
    for index in wanted:
        lo, hi = max(first, index * per_file), min(first + count, (index + 1) * per_file)
        out[lo - first:hi - first] = _read_part(path, *sources[index], layout,
                                                skip=lo - index * per_file, take=hi - lo)
    return out


def _encoding(header: dict, path: Path) -> str:
    encoding = ENCODINGS.get(str(header["encoding"]).lower())
    if encoding is None:
        raise VolumeFileError(path, f"unsupported encoding {header['encoding']!r}; supported: "
                                    f"{', '.join(ENCODINGS)}", "encoding")
    return encoding


def _skips(header: dict, path: Path, encoding: str) -> tuple[int, int, bool]:
    byte_skip = _integer(header, ("byte skip", "byteskip"), path)
    line_skip = _integer(header, ("line skip", "lineskip"), path)
    if byte_skip < -1:
        raise VolumeFileError(path, f"must be >= -1, got {byte_skip}", "byte skip")
    if byte_skip == -1 and encoding != "raw":
        # the data's start would be known only after inflating the whole stream, however large
        raise VolumeFileError(path, f"byte skip -1 (data at the end) is supported only for raw "
                                    f"data, not {encoding}", "byte skip")
    if line_skip < 0:
        raise VolumeFileError(path, f"must be >= 0, got {line_skip}", "line skip")
    return byte_skip, line_skip, any(key in header for key in ("byte skip", "byteskip"))


def _integer(header: dict, keys: tuple[str, str], path: Path) -> int:
    value = next((header[key] for key in keys if key in header), 0)
    try:
        return int(value)
    except (TypeError, ValueError, OverflowError):
        raise VolumeFileError(path, f"expected an integer, got {value!r}", keys[0]) from None


# --- data files ----------------------------------------------------------------------------------
def _data_files(path: Path, value: str, listed: list[str] | None, header: dict, count: int):
    """The data files (checked to exist) and the values each holds; their number is checked
    against the sizes before any name is built."""
    dimension = len(header["sizes"])
    if listed is not None:  # data file: LIST [subdim]
        parts = value.split()
        subdim = _subdim(parts[1] if len(parts) > 1 else None, dimension, path)
        per_file = _check_file_count(len(listed), subdim, header, count, path)
        names = listed
    else:
        match = _PATTERN.match(value.strip())
        if match is None:
            return [regular_file(path.parent / value, path, "data file")], count
        pattern, first, last, step, sub = match.groups()
        subdim = _subdim(sub, dimension, path)
        first, last, step = (_pattern_number(text, path) for text in (first, last, step))
        number = _range_length(first, last, step, path)
        per_file = _check_file_count(number, subdim, header, count, path)
        names = _numbered_names(pattern, first, step, number, path)
    return [regular_file(path.parent / name, path, "data file") for name in names], per_file


def _pattern_number(text: str, path: Path) -> int:
    if len(text) > 18:  # Python refuses to convert more than 4300 digits, and no range needs 19
        raise VolumeFileError(path, f"file number {text[:20]}... is out of range", "data file")
    return int(text)


def _subdim(text: str | None, dimension: int, path: Path) -> int:
    try:
        subdim = dimension - 1 if text is None else int(text)
    except ValueError:
        raise VolumeFileError(path, f"sub-dimension must be an integer, got {text!r}",
                              "data file") from None
    if not 1 <= subdim <= dimension:
        raise VolumeFileError(path, f"sub-dimension must be in 1..{dimension}, got {subdim}",
                              "data file")
    return subdim


def _range_length(first: int, last: int, step: int, path: Path) -> int:
    if step == 0 or (last - first) * step < 0:
        raise VolumeFileError(path, f"file number range {first}..{last} step {step} is empty",
                              "data file")
    return (last - first) // step + 1


def _check_file_count(number: int, subdim: int, header: dict, count: int, path: Path) -> int:
    """Values per file; refuses a file count that does not match the sizes or is beyond the
    limit."""
    sizes = [int(s) for s in header["sizes"]]
    per_file = math.prod(sizes[:subdim])
    expected = math.prod(sizes[subdim:])
    if number != expected:
        raise VolumeFileError(path, f"names {number} data files, but sizes {sizes} with "
                                    f"sub-dimension {subdim} need {expected} files of {per_file} "
                                    f"values each", "data file")
    if number > MAX_DATA_FILES:
        raise VolumeFileError(path, f"names {number} data files; at most {MAX_DATA_FILES} are "
                                    f"read", "data file")
    return per_file


def _numbered_names(pattern: str, first: int, step: int, number: int, path: Path) -> list[str]:
    conversions = _NUMBER_FORMAT.findall(pattern.replace("%%", ""))
    if len(conversions) != 1 or pattern.replace("%%", "").count("%") != 1:
        raise VolumeFileError(path, f"file name pattern {pattern!r} must hold one integer "
                                    f"conversion such as %d or %03d", "data file")
    return [pattern % (first + k * step) for k in range(number)]


# --- one data file -------------------------------------------------------------------------------
def _read_part(header_path, file, start: int, layout: _Layout, skip: int = 0,
               take: int | None = None) -> np.ndarray:
    """Values ``skip`` .. ``skip + take`` of one data file (or of the attached data, from
    ``start``), native order; by default all of them."""
    take = layout.values - skip if take is None else take
    blame = None if file == header_path else header_path
    start = _after_lines(file, start, layout.line_skip, header_path)
    if layout.encoding == "raw":
        offset = -1 if layout.byte_skip == -1 else start + layout.byte_skip
        return read_raw_array(file, layout.dtype, layout.values, offset=offset,
                              allow_trailing=layout.explicit_skip, size_field="sizes", header=blame,
                              window=(skip, take))
    pieces = file_pieces(file, start, header_path, "data file")
    if layout.encoding == "ascii":  # text cannot be skipped unparsed; ascii files are small
        return ascii_values(_skipped(pieces, layout.byte_skip), layout.dtype, layout.values,
                            header_path, "sizes")[skip:skip + take]
    out = np.empty(take, dtype=layout.dtype)
    inflate_into(out.view(np.uint8), pieces, layout.encoding, header_path, "sizes",
                 skip=layout.byte_skip + skip * layout.dtype.itemsize, codec_field="encoding",
                 what="the data" if blame is None else f"data file {str(file)!r}",
                 partial=skip + take < layout.values)
    return to_native(out, copy=False)


def _skipped(pieces, nbytes: int):
    for piece in pieces:
        if nbytes >= len(piece):
            nbytes -= len(piece)
            continue
        yield piece[nbytes:]
        nbytes = 0


def _after_lines(file, start: int, lines: int, header_path) -> int:
    """The offset after ``lines`` line ends from ``start`` (found chunk by chunk)."""
    if lines == 0:
        return start
    position = start
    for piece in file_pieces(file, start, header_path, "line skip"):
        found = piece.count(b"\n")
        if found >= lines:
            index = -1
            for _ in range(lines):
                index = piece.index(b"\n", index + 1)
            return position + index + 1
        lines -= found
        position += len(piece)
    raise VolumeFileError(header_path, f"the data file {str(file)!r} ends before the lines to "
                                       f"skip", "line skip")
