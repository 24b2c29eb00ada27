"""Shared pieces of the volume readers: header-value parsing, the memory check, exact-size raw
reading with progress, and turning a [z, y, x] array into a checked ``Volume``.

Conventions kept by every reader (docs/volumes.md says the same for users):
- arrays come back indexed [z, y, x] in native byte order, x fastest (the file's order);
- spacing and origin are (x, y, z);
- a reader either returns a complete Volume or raises ``VolumeFileError``; nothing half-loaded;
- float volumes with NaN/Inf voxels load, but a ``NonFiniteVoxelsWarning`` names the file and
  the counts.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vgraph.errors import VGraphError, VolumeFileError
from vgraph.volume import Volume

# Reads above this size show a tqdm bar (which tqdm itself hides when stderr is not a terminal).
PROGRESS_THRESHOLD_BYTES = 64 * 2**20
_CHUNK_BYTES = 16 * 2**20


class NonFiniteVoxelsWarning(UserWarning):
    """A float volume holds NaN or +-Inf voxels. It was loaded; value ranges, histograms and
    textures skip or clamp those voxels."""


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


# --- memory --------------------------------------------------------------------------------------
def available_memory() -> int | None:
    """Bytes of memory a new allocation can use: MemAvailable from /proc/meminfo, else the free
    physical pages, else None (unknown: the check is skipped)."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def format_bytes(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n} bytes"  # unreachable


def check_memory(file, needed_bytes: int, field: str | None = None) -> None:
    """Refuse a load that cannot fit before any byte of it is read."""
    available = available_memory()
    if available is not None and needed_bytes > available:
        raise VolumeFileError(file, f"too large for memory: loading needs {format_bytes(needed_bytes)} "
                                    f"({needed_bytes} bytes) but only {format_bytes(available)} "
                                    f"is available", field)


# --- raw bytes -----------------------------------------------------------------------------------
def existing_file(path, referenced_by, field: str) -> Path:
    """A data file named in a header; a missing one is reported against the header's field."""
    path = Path(path)
    if not path.is_file():
        raise VolumeFileError(referenced_by, f"data file {str(path)!r} does not exist", field)
    return path


def read_raw_array(path, dtype: np.dtype, count: int, *, offset: int = 0,
                   allow_trailing: bool = False, size_field: str | None = None,
                   header=None) -> np.ndarray:
    """``count`` elements of ``dtype`` (any byte order) from ``path``, returned in native order.

    The data start ``offset`` bytes into the file (-1: they are the last bytes of the file, as
    with NRRD byte skip -1 or MetaImage HeaderSize -1). The file must end exactly where the data
    end unless ``allow_trailing`` (an explicit header size was given). ``header`` is the file to
    blame in messages (the .dat/.nhdr/.mhd), if it is not the data file itself."""
    dtype = np.dtype(dtype)
    needed = count * dtype.itemsize
    blame = header if header is not None else path
    try:
        actual = os.path.getsize(path)
    except OSError as exc:
        raise VolumeFileError(blame, f"cannot read data file {str(path)!r}: {exc.strerror}",
                              size_field) from exc
    start = _data_start(path, blame, actual, needed, offset, allow_trailing, size_field)
    check_memory(path, needed, size_field)
    out = np.empty(count, dtype=dtype)
    _read_into(path, start, out.view(np.uint8), needed)
    return to_native(out)


def _data_start(path, blame, actual: int, needed: int, offset: int, allow_trailing: bool,
                field) -> int:
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
    with open(path, "rb") as fh, tqdm(total=nbytes, unit="B", unit_scale=True,
                                       desc=f"reading {Path(path).name}", leave=False,
                                       disable=None if nbytes >= PROGRESS_THRESHOLD_BYTES else True) as bar:
        fh.seek(start)
        while done < nbytes:
            got = fh.readinto(view[done:done + _CHUNK_BYTES])
            if not got:  # the file shrank between the size check and the read
                raise VolumeFileError(path, f"file ended after {done} of {nbytes} data bytes")
            done += got
            bar.update(got)


def to_native(array: np.ndarray) -> np.ndarray:
    """The same values in native byte order (textures and numpy ufuncs expect it)."""
    if array.dtype.byteorder in ("=", "|") or array.dtype.isnative:
        return array
    return array.byteswap().view(array.dtype.newbyteorder("="))


# --- numpy dtypes from header words --------------------------------------------------------------
def raw_dtype(name, endianness: str, file, field: str) -> np.dtype:
    """A numpy dtype from a name such as 'uint16' / 'float32' / '<u2' and 'little' | 'big'."""
    try:
        dtype = np.dtype(name)
    except TypeError:
        raise VolumeFileError(file, f"unknown data type {name!r}", field) from None
    if dtype.kind not in "uif" or dtype.itemsize > 8:
        raise VolumeFileError(file, f"unsupported data type {dtype} (need integer or float)", field)
    if endianness not in ("little", "big"):
        raise VolumeFileError(file, f"endianness must be 'little' or 'big', got {endianness!r}",
                              "endianness")
    return dtype.newbyteorder("<" if endianness == "little" else ">")


# --- the result ----------------------------------------------------------------------------------
def make_volume(data_zyx: np.ndarray, file, *, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0),
                declared_range=None) -> Volume:
    """Wrap a loaded [z, y, x] array; warn about (but keep) NaN/Inf voxels."""
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
                        source=str(file))
    except VGraphError as exc:  # e.g. an unsupported dtype the header check did not foresee
        raise VolumeFileError(file, str(exc)) from exc
    volume.__dict__["nonfinite_count"] = nonfinite  # prime the cached property: counted already
    return volume
