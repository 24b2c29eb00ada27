"""NumPy volumes: .npy (one array) and .npz (an archive).

Arrays are indexed [z, y, x] (x fastest), the Volume order, so nothing is transposed. A 2D array
[y, x] is one slice. A 4D array is [t, z, y, x], time slowest as the axis order implies: one time
point is read (from a C-ordered array only its bytes; a Fortran-ordered one is read whole) and
the volume's time_steps counts them. A .npy file carries no geometry: spacing (1, 1, 1), origin
(0, 0, 0), identity direction.
A .npz archive holds either a single array (any key, e.g. ``arr_0``) or the keys written by
vgraph: ``data`` plus optional ``spacing`` (x, y, z), ``origin`` (x, y, z), ``direction`` (3 x 3,
rows of the matrix whose columns are the index axes' directions in RAS, as Volume.direction;
default identity) and ``value_range`` (lo, hi). Pickled (object) arrays are refused.
"""

from __future__ import annotations

import io
import math
import struct
import tokenize
import zipfile
import zlib
from pathlib import Path

import numpy as np

from vgraph.byte_order import to_native
from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_origin, check_spacing, check_time_step, make_volume, open_capped,
                               read_raw_array, regular_file)
from vgraph.io.orientation import file_direction
from vgraph.memory import check_memory
from vgraph.volume import IDENTITY, Volume

METADATA_KEYS = ("spacing", "origin", "direction", "value_range")
# What a damaged archive or member raises from zipfile, zlib and numpy's header parser.
_ARCHIVE_ERRORS = (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, OSError, EOFError,
                   ValueError, NotImplementedError, struct.error)
_READ_CHUNK = 16 * 2**20
# numpy refuses headers above 10000 bytes, but only after reading as many bytes as the header's
# length field says (up to 4 GiB, allocated up front): it gets this much at most, in memory.
_MAX_NPY_HEADER = 65536


def read_npy(path, time_step: int = 0) -> Volume:
    path = regular_file(path)
    try:
        with open(path, "rb") as fh:
            shape, fortran, dtype, data_offset = _npy_header(fh, path, "header")
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read the file: {exc.strerror}", "header") from exc
    _check_shape_dtype(path, "shape", shape, dtype)
    time_steps = shape[0] if len(shape) == 4 else 1
    time_step = check_time_step(path, time_step, time_steps)
    if fortran and time_steps > 1:  # time varies fastest on disk: read whole, then pick
        flat = read_raw_array(path, dtype, math.prod(shape), offset=data_offset, size_field="shape")
        array = _as_zyx(flat, shape, fortran)[time_step]
    else:
        count = math.prod(shape[-3:]) if time_steps > 1 else math.prod(shape)
        flat = read_raw_array(path, dtype, count * time_steps, offset=data_offset,
                              size_field="shape", window=(time_step * count, count))
        array = _as_zyx(flat, shape[-3:] if time_steps > 1 else shape, fortran)
    return make_volume(array, path, time_steps=time_steps)


def read_npz(path, time_step: int = 0) -> Volume:
    """The data member is read by streaming it out of the archive: its npy header says how many
    bytes to expect, the zip directory must agree, and nothing beyond them is inflated."""
    path = regular_file(path)
    try:
        with open_capped(path) as fh, zipfile.ZipFile(fh) as archive:
            key, others = _npz_data_key(archive, path)
            array, time_steps = _member_array(archive, key, path, time_step=time_step)
            meta = {name: _member_array(archive, name, path, metadata=True) for name in others}
    except _ARCHIVE_ERRORS as exc:
        raise VolumeFileError(path, f"not a readable .npz archive: {type(exc).__name__}: {exc}",
                              "archive") from exc
    spacing = check_spacing(meta["spacing"], path, "spacing") if "spacing" in meta else (1, 1, 1)
    origin = check_origin(meta["origin"], path, "origin") if "origin" in meta else (0, 0, 0)
    direction = file_direction(meta["direction"].reshape(3, 3), path, "direction") \
        if "direction" in meta else IDENTITY
    declared = None
    if "value_range" in meta:
        lo, hi = (float(v) for v in (list(meta["value_range"]) + [np.nan, np.nan])[:2])
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise VolumeFileError(path, f"need finite low < high, got {meta['value_range']}",
                                  "value_range")
        declared = (lo, hi)
    return make_volume(array, path, spacing=spacing, origin=origin, declared_range=declared,
                       time_steps=time_steps, direction=direction)


def write_npy(volume: Volume, fh) -> None:
    np.save(fh, np.ascontiguousarray(volume.data), allow_pickle=False)


def write_npz(volume: Volume, fh) -> None:
    extra = {} if volume.declared_range is None else {"value_range": np.array(volume.declared_range)}
    np.savez_compressed(fh, data=np.ascontiguousarray(volume.data),
                        spacing=np.array(volume.spacing), origin=np.array(volume.origin),
                        direction=np.array(volume.direction), **extra)


def _npz_data_key(archive: zipfile.ZipFile, path: Path) -> tuple[str, list[str]]:
    keys = [n[:-4] for n in archive.namelist() if n.endswith(".npy")]
    present_meta = [k for k in METADATA_KEYS if k in keys]
    arrays = [k for k in keys if k not in METADATA_KEYS]
    if "data" in arrays:
        return "data", present_meta
    if len(arrays) == 1:
        return arrays[0], present_meta
    raise VolumeFileError(path, f"expected one array or a 'data' key, found keys {keys[:20]}",
                          "keys")


def _member_array(archive: zipfile.ZipFile, key: str, path: Path, metadata: bool = False,
                  time_step: int = 0):
    """One .npy member: the data as a [z, y, x] array of time point ``time_step`` and the number
    of time points, or a metadata vector of a few numbers. Of a C-ordered 4D array only the bytes
    up to the end of that time point are inflated."""
    info = archive.getinfo(key + ".npy")
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        # zipfile inflates bzip2 and LZMA members without an output limit; numpy writes neither
        raise VolumeFileError(path, f"member compression method {info.compress_type} is not "
                                    f"supported (numpy writes stored or deflated members)", key)
    if info.flag_bits & 0x1:
        raise VolumeFileError(path, "the member is encrypted", key)
    with archive.open(info) as member:
        shape, fortran, dtype, header_size = _npy_header(member, path, key)
        member.seek(header_size)  # back to the data, after the bytes _npy_header took
        if metadata:
            _check_metadata(path, key, shape, dtype)
        else:
            _check_shape_dtype(path, key, shape, dtype)
        needed = math.prod(shape) * dtype.itemsize
        if info.file_size != header_size + needed:
            raise VolumeFileError(path, f"the member holds {info.file_size - header_size} data "
                                        f"bytes but its header declares {needed} (shape {shape} "
                                        f"{dtype})", key)
        time_steps = shape[0] if len(shape) == 4 and not metadata else 1
        time_step = check_time_step(path, time_step, time_steps)
        whole = time_steps == 1 or fortran  # Fortran order: time varies fastest, read it all
        count = math.prod(shape) if whole else math.prod(shape[1:])
        check_memory(path, count * dtype.itemsize, key)
        if not whole:
            _discard(member, time_step * count * dtype.itemsize, path, key)
        flat = np.empty(count, dtype=dtype)
        _fill_from(member, flat.view(np.uint8), path, key,
                   last=whole or time_step == time_steps - 1)
    flat = to_native(flat, copy=False)
    if metadata:
        return flat
    if whole:
        array = _as_zyx(flat, shape, fortran)
        return (array[time_step] if time_steps > 1 else array), time_steps
    return _as_zyx(flat, shape[1:], False), time_steps


def _discard(member, nbytes: int, path: Path, key: str) -> None:
    """Skip the earlier time points of a 4D member (zip members cannot seek cheaply)."""
    while nbytes > 0:
        chunk = member.read(min(_READ_CHUNK, nbytes))
        if not chunk:
            raise VolumeFileError(path, "the member ends before the time point asked for", key)
        nbytes -= len(chunk)


def _fill_from(member, target: np.ndarray, path: Path, key: str, last: bool = True) -> None:
    """Fill ``target`` from the member; unless more (later time points) follows, the member
    must end there."""
    view, done = memoryview(target), 0
    while done < len(view):
        chunk = member.read(min(_READ_CHUNK, len(view) - done))
        if not chunk:
            raise VolumeFileError(path, f"the member ends after {done} of {len(view)} data bytes",
                                  key)
        view[done:done + len(chunk)] = chunk
        done += len(chunk)
    if last and member.read(1):  # also where zipfile checks the member's CRC
        raise VolumeFileError(path, "the member holds more data than its header declares", key)


def _npy_header(fh, path: Path, field: str):
    """(shape, fortran order, dtype, header size) of an open .npy stream, parsed by numpy from
    its first bytes only."""
    try:
        start = io.BytesIO(fh.read(_MAX_NPY_HEADER))
        version = np.lib.format.read_magic(start)
        read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                       else np.lib.format.read_array_header_2_0)  # 2.0 and 3.0 share a layout
        shape, fortran, dtype = read_header(start)
        return tuple(int(s) for s in shape), bool(fortran), np.dtype(dtype), start.tell()
    except (ValueError, EOFError, TypeError, SyntaxError, tokenize.TokenError) as exc:
        # numpy parses the header dict with Python's tokenizer and literal_eval
        raise VolumeFileError(path, f"not a readable .npy header: {exc}", field) from exc


def _check_shape_dtype(path, field, shape, dtype) -> None:
    if dtype.kind not in "uif" or dtype.itemsize > 8:
        raise VolumeFileError(path, f"unsupported dtype {dtype} (need integer or float)", field)
    if len(shape) not in (2, 3, 4):
        raise VolumeFileError(path, f"expected a [z, y, x] (or [t, z, y, x]) array, got shape "
                                    f"{shape}", field)
    if min(shape) <= 0:
        raise VolumeFileError(path, f"every dimension must be at least 1, got shape (z, y, x) = "
                                    f"{shape}", field)


def _check_metadata(path, key, shape, dtype) -> None:
    if key == "direction":
        if dtype.kind not in "uif" or dtype.itemsize > 8 or tuple(shape) not in ((3, 3), (9,)):
            raise VolumeFileError(path, f"expected a 3 x 3 matrix of numbers, got shape {shape} "
                                        f"{dtype}", key)
    elif dtype.kind not in "uif" or dtype.itemsize > 8 or len(shape) != 1 or not 1 <= shape[0] <= 3:
        raise VolumeFileError(path, f"expected a vector of up to 3 numbers, got shape {shape} "
                                    f"{dtype}", key)


def _as_zyx(flat: np.ndarray, shape: tuple, fortran: bool) -> np.ndarray:
    array = flat.reshape(shape[::-1]).T if fortran else flat.reshape(shape)
    return array[np.newaxis] if array.ndim == 2 else array
