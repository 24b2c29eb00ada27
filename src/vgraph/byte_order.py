"""Voxels in the machine's byte order: files may store them big-endian; GL textures and numpy's
ufuncs want native order. Used by the file readers (vgraph.io) and the brick stores (vgraph.bricks).
"""

from __future__ import annotations

import numpy as np


def to_native(array: np.ndarray, copy: bool = True) -> np.ndarray:
    """The same values in native byte order. ``copy=False`` swaps a buffer the reader owns in
    place, so a big-endian file does not need twice the memory."""
    if array.dtype.byteorder in ("=", "|") or array.dtype.isnative:
        return array
    swapped = array.byteswap(inplace=not copy)
    return swapped.view(array.dtype.newbyteorder("="))
