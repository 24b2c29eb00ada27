"""NumPy volumes: .npy (one array) and .npz (an archive).

Arrays are indexed [z, y, x] (x fastest), the Volume order, so nothing is transposed. A 2D array
[y, x] is one slice. A .npy file carries no geometry: spacing (1, 1, 1), origin (0, 0, 0).
A .npz archive holds either a single array (any key, e.g. ``arr_0``) or the keys written by
vgraph: ``data`` plus optional ``spacing`` (x, y, z), ``origin`` (x, y, z) and ``value_range``
(lo, hi). Pickled (object) arrays are refused.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import check_memory, check_origin, check_spacing, make_volume
from vgraph.volume import Volume

METADATA_KEYS = ("spacing", "origin", "value_range")


def read_npy(path) -> Volume:
    path = Path(path)
    shape, dtype, data_offset = _npy_header(path, path)
    _check_shape_dtype(path, "shape", shape, dtype)
    needed = int(np.prod(shape)) * dtype.itemsize
    actual = path.stat().st_size - data_offset
    if actual != needed:
        problem = "truncated" if actual < needed else "larger than its header describes"
        raise VolumeFileError(path, f"file is {problem}: shape {shape} {dtype} needs {needed} data "
                                    f"bytes, found {actual}", "shape")
    check_memory(path, needed, "shape")
    array = _load(path, lambda: np.load(path, allow_pickle=False))
    return make_volume(_as_zyx(array, path, "shape"), path)


def read_npz(path) -> Volume:
    path = Path(path)
    key, others = _npz_data_key(path)
    with zipfile.ZipFile(path) as archive, archive.open(key + ".npy") as member:
        shape, dtype, _ = _npy_header(member, path)
    _check_shape_dtype(path, key, shape, dtype)
    check_memory(path, int(np.prod(shape)) * dtype.itemsize, key)
    with np.load(path, allow_pickle=False) as archive:
        array = _load(path, lambda: archive[key], key)
        meta = {name: _load(path, lambda: archive[name], name) for name in others}
    spacing = check_spacing(meta["spacing"], path, "spacing") if "spacing" in meta else (1, 1, 1)
    origin = check_origin(meta["origin"], path, "origin") if "origin" in meta else (0, 0, 0)
    declared = None
    if "value_range" in meta:
        lo, hi = (float(v) for v in np.ravel(meta["value_range"])[:2])
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise VolumeFileError(path, f"need finite low < high, got {meta['value_range']}",
                                  "value_range")
        declared = (lo, hi)
    return make_volume(_as_zyx(array, path, key), path, spacing=spacing, origin=origin,
                       declared_range=declared)


def write_npy(volume: Volume, fh) -> None:
    np.save(fh, np.ascontiguousarray(volume.data), allow_pickle=False)


def write_npz(volume: Volume, fh) -> None:
    extra = {} if volume.declared_range is None else {"value_range": np.array(volume.declared_range)}
    np.savez_compressed(fh, data=np.ascontiguousarray(volume.data),
                        spacing=np.array(volume.spacing), origin=np.array(volume.origin), **extra)


def _npz_data_key(path: Path) -> tuple[str, list[str]]:
    try:
        with zipfile.ZipFile(path) as archive:
            keys = [n[:-4] for n in archive.namelist() if n.endswith(".npy")]
    except (zipfile.BadZipFile, OSError) as exc:
        raise VolumeFileError(path, f"not a readable .npz archive: {exc}", "archive") from exc
    present_meta = [k for k in METADATA_KEYS if k in keys]
    arrays = [k for k in keys if k not in METADATA_KEYS]
    if "data" in arrays:
        return "data", present_meta
    if len(arrays) == 1:
        return arrays[0], present_meta
    raise VolumeFileError(path, f"expected one array or a 'data' key, found keys {keys}", "keys")


def _npy_header(fh_or_path, path: Path):
    try:
        opened = fh_or_path if hasattr(fh_or_path, "read") else open(fh_or_path, "rb")
        try:
            version = np.lib.format.read_magic(opened)
            read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                           else np.lib.format.read_array_header_2_0)  # 2.0 and 3.0 share a layout
            shape, _fortran, dtype = read_header(opened)
            offset = opened.tell()
        finally:
            if opened is not fh_or_path:
                opened.close()
    except (ValueError, OSError, EOFError) as exc:
        raise VolumeFileError(path, f"not a readable .npy header: {exc}", "header") from exc
    return tuple(int(s) for s in shape), np.dtype(dtype), offset


def _check_shape_dtype(path, field, shape, dtype) -> None:
    if dtype.kind not in "uif" or dtype.itemsize > 8:
        raise VolumeFileError(path, f"unsupported dtype {dtype} (need integer or float)", field)
    if len(shape) not in (2, 3):
        raise VolumeFileError(path, f"expected a [z, y, x] array, got shape {shape}", field)
    if 0 in shape:
        raise VolumeFileError(path, f"zero-size dimension in shape (z, y, x) = {shape}", field)


def _load(path, loader, field=None):
    try:
        return loader()
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise VolumeFileError(path, f"cannot read the array: {exc}", field) from exc


def _as_zyx(array: np.ndarray, path, field) -> np.ndarray:
    return array[np.newaxis] if array.ndim == 2 else array
