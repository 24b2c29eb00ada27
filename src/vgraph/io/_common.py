"""Shared pieces of the volume readers: header-value parsing, the memory check, the checks that
a file is a readable regular file and a header a header, exact-size raw reading with progress,
and turning a [z, y, x] array into a checked ``Volume``.

Conventions kept by every reader (docs/guide/volumes.md says the same for users):
- arrays come back indexed [z, y, x] in native byte order, x fastest (the file's order);
- spacing and origin are (x, y, z), origin and direction in RAS patient space (orientation.py);
- a reader either returns a complete Volume or raises ``VolumeFileError``; nothing half-loaded,
  and no size from a file is trusted before it is checked (see the Limits in docs/guide/volumes.md);
- float volumes with NaN/Inf voxels load, but a ``NonFiniteVoxelsWarning`` names the file and
  the counts;
- a file with a time axis (4D NIfTI, NRRD with a ``time`` kind, 4D MetaImage, NumPy [t, z, y, x])
  gives one time point per read, read alone where the format allows (the volume records how many
  there are in ``time_steps``); asking for one the file does not have raises ``TimeStepError``.
"""

from __future__ import annotations

import io
import math
import os
import stat
import warnings
from pathlib import Path

import numpy as np
from vgraph.byte_order import to_native
from vgraph.errors import TimeStepError, VGraphError, VolumeFileError
from vgraph.memory import check_memory, format_bytes
from vgraph.progress import Steps
from vgraph.volume import IDENTITY, Volume, VolumeGeometryError

# Reads above this size show a tqdm bar (which tqdm itself hides when stderr is not a terminal);
# every read reports its progress to a vgraph.progress listener (the GUI's status bar).
PROGRESS_THRESHOLD_BYTES = 64 * 2**20
_CHUNK_BYTES = 16 * 2**20
# Text headers (.dat, .nhdr, .mhd, the NRRD data file LIST) are small; a "header" beyond this is
# a data file opened by mistake, and reading it whole (or one endless line of it) would eat memory.
MAX_HEADER_BYTES = 8 * 2**20
MAX_HEADER_LINE = 2**20


class NonFiniteVoxelsWarning(UserWarning):
    """A float volume holds NaN or +-Inf voxels. It was loaded; value ranges, histograms and
    textures skip or clamp those voxels."""


def check_time_step(file, time_step, time_steps: int) -> int:
    """``time_step`` as an int if the file holds it, before any data are read."""
    if isinstance(time_step, bool) or not isinstance(time_step, (int, np.integer)) \
            or not 0 <= time_step < time_steps:
        raise TimeStepError(file, time_step, time_steps)
    return int(time_step)


# --- header values -------------------------------------------------------------------------------
def parse_numbers(text: str, file, field: str, count: int | None = 3, kind=float) -> list:
    """Whitespace- or comma-separated numbers of a header field, with a message naming the field."""
    parts = str(text).replace(",", " ").split()
    try:
        values = [kind(p) for p in parts]
    except ValueError:
        raise VolumeFileError(file, f"expected {'integers' if kind is int else 'numbers'}, "
                                    f"got {text!r}", field) from None
    if count is not None and len(values) != count:
        raise VolumeFileError(file, f"expected {count} values, got {len(values)} ({text!r})", field)
    return values


def check_dims(dims, file, field: str) -> tuple[int, int, int]:
    """(x, y, z) voxel counts: three positive integers."""
    dims = tuple(int(d) for d in dims)
    if len(dims) != 3:
        raise VolumeFileError(file, f"expected 3 dimensions (x, y, z), got {len(dims)}: {dims}", field)
    if min(dims) <= 0:
        raise VolumeFileError(file, f"every dimension must be at least 1, got (x, y, z) = {dims}",
                              field)
    return dims


def check_spacing(spacing, file, field: str) -> tuple[float, float, float]:
    values = tuple(float(s) for s in spacing)
    if len(values) != 3 or not all(math.isfinite(v) and v > 0 for v in values):
        raise VolumeFileError(file, f"spacing must be three positive finite numbers, got {values}",
                              field)
    return values


def check_origin(origin, file, field: str) -> tuple[float, float, float]:
    values = tuple(float(s) for s in origin)
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise VolumeFileError(file, f"origin must be three finite numbers, got {values}", field)
    return values


def pad_to_3d(shape_xyz, file, field: str) -> tuple[int, int, int]:
    """A 2D image (x, y) is a volume with one slice; more than three non-trivial axes is refused."""
    shape = [int(s) for s in shape_xyz]
    while len(shape) > 3 and shape[-1] == 1:  # trailing singleton axes (NIfTI t = 1) carry nothing
        shape.pop()
    if len(shape) > 3:
        raise VolumeFileError(file, f"expected a 3D scalar volume, got {len(shape)} axes "
                                    f"with sizes {tuple(shape)}", field)
    if len(shape) < 2:
        raise VolumeFileError(file, f"expected a 3D scalar volume, got {len(shape)} axis", field)
    return check_dims(shape + [1] * (3 - len(shape)), file, field)


# --- files and headers ---------------------------------------------------------------------------
_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def file_problem(path) -> str | None:
    """Why ``path`` cannot be read as a file ('does not exist', 'is not a regular file (a FIFO)',
    'cannot be read: Permission denied'), or None. Checked before opening: opening a FIFO blocks
    until a writer appears, and /dev/zero never ends."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "does not exist"
    except OSError as exc:  # permission denied on a parent folder, a name too long, a loop
        return f"cannot be read: {exc.strerror}"
    except ValueError as exc:  # a NUL character in a name taken from a header
        return f"cannot be read: {exc}"
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _KINDS if test(mode)), "not a file")
        return f"is not a regular file ({kind})"
    if not os.access(path, os.R_OK):
        return "cannot be read: Permission denied"
    return None


def regular_file(path, referenced_by=None, field: str | None = None) -> Path:
    """``path`` if it is a readable regular file. A data file named in a header
    (``referenced_by``) is reported against the header and its field."""
    path = Path(path)
    problem = file_problem(path)
    if problem is None:
        return path
    if referenced_by is None:
        raise VolumeFileError(path, "file " + problem, field)
    raise VolumeFileError(referenced_by, f"data file {str(path)!r} {problem}", field)


class _CappedReader(io.BufferedReader):
    """A binary file whose read(n) asks for no more than what is left of it. Python's read(n)
    allocates n bytes before reading, and libraries (zipfile, pydicom) pass lengths taken from a
    possibly damaged header: a 4 GiB length in a 1 KiB file would reserve 4 GiB."""

    def read(self, size=-1):
        if size is not None and size > 0:
            size = min(size, max(os.fstat(self.fileno()).st_size - self.tell(), 0)) or 1
        return super().read(size)


def open_capped(path) -> io.BufferedReader:
    """``path`` opened for reading by a library that trusts lengths in the file."""
    return _CappedReader(io.FileIO(path, "rb"))


def read_header_bytes(path, limit: int = MAX_HEADER_BYTES) -> bytes:
    """The whole of a file that is only a header (.dat), refused when it is larger than a header
    can be."""
    size = regular_file(path).stat().st_size
    if size > limit:
        raise VolumeFileError(path, f"a {format_bytes(size)} file is not a header (the limit is "
                                    f"{format_bytes(limit)}): is this the data file?", "header")
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read header: {exc.strerror}", "header") from exc


def header_lines(fh, path, limit: int = MAX_HEADER_BYTES):
    """Lines (bytes, with their line ends) from an open file until the header budget is spent;
    each line is read with a length cap, so a binary file without line ends costs at most
    MAX_HEADER_LINE bytes."""
    used = 0
    while True:
        line = fh.readline(MAX_HEADER_LINE + 1)
        if not line:
            return
        used += len(line)
        if len(line) > MAX_HEADER_LINE:
            raise VolumeFileError(path, f"a header line is longer than "
                                        f"{format_bytes(MAX_HEADER_LINE)}: not a header, or a "
                                        f"damaged one", "header")
        if used > limit:
            raise VolumeFileError(path, f"the header is longer than {format_bytes(limit)} (or has "
                                        f"no end): not a header, or a damaged one", "header")
        yield line


# --- raw bytes -----------------------------------------------------------------------------------


def read_raw_array(path, dtype: np.dtype, count: int, *, offset: int = 0,
                   allow_trailing: bool = False, size_field: str | None = None,
                   header=None, window: tuple[int, int] | None = None) -> np.ndarray:
    """``count`` elements of ``dtype`` (any byte order) from ``path``, returned in native order.

    The data start ``offset`` bytes into the file (-1: they are the last bytes of the file, as
    with NRRD byte skip -1 or MetaImage HeaderSize -1). The file must end exactly where the data
    end unless ``allow_trailing`` (an explicit header size was given). ``header`` is the file to
    blame in messages (the .dat/.nhdr/.mhd), if it is not the data file itself. ``window`` =
    (first, number) reads only those of the ``count`` elements (one time point of several); the
    file is still checked to hold all of them."""
    dtype = np.dtype(dtype)
    needed = count * dtype.itemsize
    blame = header if header is not None else path
    try:
        actual = os.path.getsize(path)
    except OSError as exc:
        raise VolumeFileError(blame, f"cannot read data file {str(path)!r}: {exc.strerror}",
                              size_field) from exc
    start = data_start(path, blame, actual, needed, offset, allow_trailing, size_field)
    first, number = (0, count) if window is None else window
    check_memory(path, number * dtype.itemsize, size_field)
    out = np.empty(number, dtype=dtype)
    _read_into(path, start + first * dtype.itemsize, out.view(np.uint8), number * dtype.itemsize)
    return to_native(out, copy=False)


def data_start(path, blame, actual: int, needed: int, offset: int, allow_trailing: bool,
               field) -> int:
    """Where the voxels start in a data file of ``actual`` bytes that must hold ``needed`` bytes
    after ``offset`` header bytes (-1: the voxels end the file); a short file, or a longer one
    where trailing bytes are not allowed, raises a VolumeFileError on ``blame`` and ``field``."""
    where = f"data file {str(path)!r}" if str(blame) != str(path) else "file"
    if offset == -1:
        if actual < needed:
            raise VolumeFileError(blame, f"{where} is truncated: expected at least {needed} bytes, "
                                         f"found {actual}", field)
        return actual - needed
    if offset < 0:
        raise VolumeFileError(blame, f"header offset must be >= 0 or -1, got {offset}", field)
    expected = offset + needed
    head = f"{offset} header bytes + {needed} data bytes = {expected}" if offset else f"{needed}"
    if actual < expected:
        raise VolumeFileError(blame, f"{where} is truncated: expected {head} bytes, found {actual}",
                              field)
    if actual > expected and not allow_trailing:
        raise VolumeFileError(blame, f"{where} is larger than the header describes: expected "
                                     f"{head} bytes, found {actual}", field)
    return offset


def _read_into(path, start: int, target: np.ndarray, nbytes: int) -> None:
    """Fill ``target`` (a uint8 view) from ``path`` in chunks, with a progress bar for big reads."""
    view = memoryview(target)
    done = 0
    # The listener (the GUI) hears every read; the terminal bar shows only for big ones.
    with open(path, "rb") as fh, Steps(nbytes, f"reading {Path(path).name}",
                                        show=None if nbytes >= PROGRESS_THRESHOLD_BYTES else False,
                                        unit="B", unit_scale=True) as bar:
        fh.seek(start)
        while done < nbytes:
            got = fh.readinto(view[done:done + _CHUNK_BYTES])
            if not got:  # the file shrank between the size check and the read
                raise VolumeFileError(path, f"file ended after {done} of {nbytes} data bytes")
            done += got
            bar.update(got)


# --- numpy dtypes from header words --------------------------------------------------------------
def raw_dtype(name, endianness: str, file, field: str) -> np.dtype:
    """A numpy dtype from a name such as 'uint16' / 'float32' / '<u2' and 'little' | 'big'."""
    try:
        dtype = np.dtype(name)
    except (TypeError, ValueError, SyntaxError, KeyError):
        raise VolumeFileError(file, f"unknown data type {name!r}", field) from None
    if dtype.kind not in "uif" or dtype.itemsize > 8:
        raise VolumeFileError(file, f"unsupported data type {dtype} (need integer or float)", field)
    if endianness not in ("little", "big"):
        raise VolumeFileError(file, f"endianness must be 'little' or 'big', got {endianness!r}",
                              "endianness")
    return dtype.newbyteorder("<" if endianness == "little" else ">")


# --- the result ----------------------------------------------------------------------------------
def make_volume(data_zyx: np.ndarray, file, *, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0),
                declared_range=None, time_steps: int = 1, direction=IDENTITY,
                holds_labels: bool = False) -> Volume:
    """Wrap a loaded [z, y, x] array; warn about (but keep) NaN/Inf voxels. ``direction``, origin
    and spacing are in RAS (vgraph.io.orientation); ``holds_labels``: the header declares labels
    (vgraph.io.label_hints)."""
    data = np.ascontiguousarray(to_native(np.asarray(data_zyx)))
    nonfinite = 0
    if data.dtype.kind == "f":
        nonfinite = int(data.size - np.count_nonzero(np.isfinite(data)))
        if nonfinite:
            nan = int(np.count_nonzero(np.isnan(data)))
            pos_inf = int(np.count_nonzero(np.isposinf(data)))
            warnings.warn(NonFiniteVoxelsWarning(
                f"{file}: {nonfinite} of {data.size} voxels are not finite ({nan} NaN, {pos_inf} "
                f"+Inf, {nonfinite - nan - pos_inf} -Inf); they are excluded from the value range "
                f"and histogram and clamped in textures"), stacklevel=3)
    try:
        volume = Volume(data, spacing=spacing, origin=origin, declared_range=declared_range,
                        source=str(file), time_steps=time_steps, direction=direction,
                        holds_labels=holds_labels)
    except VolumeGeometryError as exc:  # the box the header's spacing and origin give (check_box)
        raise VolumeFileError(file, exc.reason, exc.field) from None
    except VGraphError as exc:  # e.g. an unsupported dtype the header check did not foresee
        raise VolumeFileError(file, str(exc)) from exc
    volume.__dict__["nonfinite_count"] = nonfinite  # prime the cached property: counted already
    return volume
