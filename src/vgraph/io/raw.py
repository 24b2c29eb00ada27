"""Headerless raw volumes described by the caller (or by the file name).

A description is a dict with the keys
  dims        (x, y, z) voxel counts                                   required
  dtype       numpy name: 'uint8', 'int16', 'uint16', 'float32', ...   required
  endianness  'little' (default) or 'big'
  spacing     (x, y, z), default (1, 1, 1)
  origin      (x, y, z), default (0, 0, 0)
  offset      header bytes to skip. Without it the file must hold exactly the data; with it,
              trailing bytes are allowed too. -1 means the data are the last bytes of the file.
The bytes are read with x fastest, so the array comes back [z, y, x].

Without a description, a name of the common form ``<name>_<X>x<Y>x<Z>_<dtype>.raw`` (e.g.
``neghip_66x66x66_uint8.raw``) is enough; anything else asks for ``raw={...}``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_dims, check_origin, check_spacing, make_volume, raw_dtype,
                               read_raw_array, regular_file)
from vgraph.volume import Volume

_KEYS = {"dims", "dtype", "endianness", "spacing", "origin", "offset"}
_NAME_PATTERN = re.compile(r"_(\d+)x(\d+)x(\d+)_(u?int(?:8|16|32|64)|float(?:32|64))$", re.I)


def read_raw(path, description: dict | None = None) -> Volume:
    path = Path(path)
    if description is None:
        description = description_from_name(path)
    dims, dtype, spacing, origin, offset = checked_raw_description(description, path)
    regular_file(path)
    count = dims[0] * dims[1] * dims[2]
    flat = read_raw_array(path, dtype, count, offset=0 if offset is None else offset,
                          allow_trailing=offset is not None, size_field="dims")
    return make_volume(flat.reshape(dims[::-1]), path, spacing=spacing, origin=origin)


def description_from_name(path: Path) -> dict:
    """dims and dtype from a name like ``bonsai_256x256x256_uint8.raw``."""
    match = _NAME_PATTERN.search(path.stem)
    if match is None:
        raise VolumeFileError(path, "a headerless raw file needs a description: call "
                                    "read_volume(path, raw={'dims': (x, y, z), 'dtype': 'uint8', ...}) "
                                    "or name it <name>_<X>x<Y>x<Z>_<dtype>.raw", "raw")
    x, y, z, dtype = match.groups()
    return {"dims": (int(x), int(y), int(z)), "dtype": dtype.lower()}


def checked_raw_description(description: dict, path: Path):
    """(dims, dtype, spacing, origin, offset) of a raw description (read_volume's ``raw``), each
    checked, with errors naming ``path`` and the key."""
    if not isinstance(description, dict):
        raise VolumeFileError(path, f"raw description must be a dict, got {type(description).__name__}",
                              "raw")
    unknown = set(description) - _KEYS
    if unknown:
        raise VolumeFileError(path, f"unknown key(s) {sorted(unknown)} in the raw description; "
                                    f"allowed: {sorted(_KEYS)}", "raw")
    for key in ("dims", "dtype"):
        if key not in description:
            raise VolumeFileError(path, f"the raw description needs {key!r}", key)
    try:
        dims = check_dims([int(d) for d in description["dims"]], path, "dims")
        spacing = check_spacing(description.get("spacing", (1, 1, 1)), path, "spacing")
        origin = check_origin(description.get("origin", (0, 0, 0)), path, "origin")
    except (TypeError, ValueError, OverflowError) as exc:
        raise VolumeFileError(path, f"dims, spacing and origin must be 3 numbers each ({exc})",
                              "raw") from None
    dtype = raw_dtype(description["dtype"], description.get("endianness", "little"), path, "dtype")
    offset = description.get("offset")
    if offset is not None and (not isinstance(offset, (int, np.integer)) or offset < -1):
        raise VolumeFileError(path, f"offset must be an integer >= -1, got {offset!r}", "offset")
    return dims, dtype, spacing, origin, None if offset is None else int(offset)
