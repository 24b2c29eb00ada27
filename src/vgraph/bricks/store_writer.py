"""Writing vgraph's OME-Zarr stores (the layout BrickStore reads; docs/guide/large-data.md).

Layout of a store (zarr v3, OME-NGFF 0.5):
  zarr.json               group attributes: "ome" (NGFF multiscales: axes z, y, x of type space,
                          one dataset per level with its scale and translation) and "vgraph"
                          (format version, brick (x, y, z), value_range, declared_range,
                          data_range, nonfinite voxel count, levels, and "direction" when the
                          volume's axes are turned: the rows of Volume.direction, a rotation,
                          which NGFF 0.4/0.5 cannot hold; other tools see the store unrotated);
                          "ome" has "image-label" when the voxels are labels (the label flag)
  0, 1, ... N-1           one array per pyramid level, [z, y, x], chunks = the brick, Blosc zstd
  vgraph/min/<k>          per-brick min and max of level k's finite voxels, float64 arrays of
  vgraph/max/<k>          the brick grid [bz, by, bx] (NaN: no finite voxel in that brick)
The per-brick ranges are arrays, not attributes: a 8192^3 volume in 64^3 bricks has two million
bricks, too many numbers for a JSON attribute that every open parses.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import zarr
from zarr.codecs import BloscCodec

from vgraph.bricks.pyramid import Level, block_ranges, brick_grid
from vgraph.volume_grid import IDENTITY, is_identity

FORMAT_VERSION = 1
NGFF_VERSION = "0.5"
# zstd with bit shuffling: volume data (smooth, few significant bits per voxel) compress 2-4x at
# speeds well above disk bandwidth; level 3 is zstd's own default trade-off.
COMPRESSOR = BloscCodec(cname="zstd", clevel=3, shuffle="bitshuffle")
_RANGE_ROWS = 64  # brick rows (along z) per chunk of the per-brick range arrays


def multiscales(levels: list[Level], unit: str | None = None, name: str = "",
                holds_labels: bool = False) -> list[dict]:
    """The NGFF "multiscales" list of one image: axes z, y, x and per level the transformation
    array index -> world (scale, then translation; both [z, y, x] as the axes), and how the
    levels were reduced (the mean, or the mode of labels)."""
    axes = [{"name": a, "type": "space", **({"unit": unit} if unit else {})} for a in "zyx"]
    datasets = [{"path": str(k), "coordinateTransformations": [
        {"type": "scale", "scale": list(level.spacing[::-1])},
        {"type": "translation", "translation": list(level.origin[::-1])}]}
        for k, level in enumerate(levels)]
    # NGFF 0.5 keeps the version in "ome" only (0.4 had it here)
    reduction = _LABEL_REDUCTION if holds_labels else _MEAN_REDUCTION
    return [{"name": name, "axes": axes, "datasets": datasets, **reduction}]


_MEAN_REDUCTION = {"type": "mean", "metadata": {"method": "vgraph.bricks.pyramid.halve",
                                                "description": "mean of 2x2x2 voxels, ceil(n/2)"}}
_LABEL_REDUCTION = {"type": "mode", "metadata": {
    "method": "vgraph.bricks.pyramid.halve_labels",
    "description": "most frequent label of 2x2x2 voxels (ties: the smallest), ceil(n/2)"}}


class StoreWriter:
    """Creates the arrays of a store in ``folder`` and takes the levels slab by slab: a slab is a
    run of whole brick rows along z (the last may be shorter), so every chunk is written once.
    ``holds_labels``: the voxels are labels; the levels' writer halves them by their mode
    (pyramid.halver), and ``finish`` marks the store as NGFF's "image-label" (what BrickStore
    reads as the label flag, as in another tool's labels/ images)."""

    def __init__(self, folder: Path, levels: list[Level], dtype, brick, holds_labels: bool = False):
        self.folder = Path(folder)
        self.levels = levels
        self.brick = tuple(int(b) for b in brick)
        self.holds_labels = bool(holds_labels)
        self.dtype = np.dtype(dtype).newbyteorder("=")
        self.group = zarr.create_group(str(self.folder), zarr_format=3)
        self.arrays = [self._level_array(k, level) for k, level in enumerate(levels)]
        ranges = self.group.create_group("vgraph")
        self.low = ranges.create_group("min")
        self.high = ranges.create_group("max")
        self.range_arrays = [(self._range_array(self.low, k, level), self._range_array(self.high, k, level))
                             for k, level in enumerate(levels)]

    def _level_array(self, k: int, level: Level):
        # chunks = the brick even where a level is smaller: the brick is read back from them
        chunks = self.brick[::-1]
        return self.group.create_array(str(k), shape=level.shape, chunks=chunks, dtype=self.dtype,
                                       compressors=COMPRESSOR, fill_value=0,
                                       dimension_names=["z", "y", "x"])

    def _range_array(self, group, k: int, level: Level):
        grid = brick_grid(level.shape, self.brick)
        return group.create_array(str(k), shape=grid, chunks=(min(_RANGE_ROWS, grid[0]), *grid[1:]),
                                  dtype="float64", compressors=COMPRESSOR, fill_value=math.nan)

    def write_slab(self, k: int, z0: int, slab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Voxels [z0, z0 + len(slab)) of level k (z0 a multiple of the brick's z size) and the
        ranges of the bricks they make up."""
        by = self.brick[1]
        for y0 in range(0, slab.shape[1], by):  # a band of chunks at a time: zarr copies what
            # one assignment covers into chunk buffers, so a whole slab would be held twice
            self.arrays[k][z0:z0 + slab.shape[0], y0:y0 + by] = slab[:, y0:y0 + by]
        low, high = block_ranges(slab, self.brick)
        row = z0 // self.brick[2]
        low_array, high_array = self.range_arrays[k]
        low_array[row:row + low.shape[0]] = low
        high_array[row:row + high.shape[0]] = high
        return low, high

    def finish(self, value_range, declared_range, data_range, nonfinite: int,
               unit: str | None = None, name: str = "", direction=IDENTITY) -> None:
        """The group attributes, written last: a store without them is not a finished store."""
        ours = {"format": FORMAT_VERSION, "brick": list(self.brick),
                "value_range": _floats(value_range),
                "declared_range": _floats(declared_range) if declared_range else None,
                "data_range": _floats(data_range) if data_range else None,
                "nonfinite": int(nonfinite), "levels": len(self.levels),
                "ranges": "vgraph/min/<level>, vgraph/max/<level>"}
        if not is_identity(direction):  # stores of unturned volumes stay as they were
            ours["direction"] = [_floats(row) for row in direction]
        ome = {"version": NGFF_VERSION,
               "multiscales": multiscales(self.levels, unit, name, self.holds_labels)}
        if self.holds_labels:
            ome["image-label"] = {}  # every field of NGFF 0.5's image-label is optional
        self.group.attrs.update({"ome": ome, "vgraph": ours})


def _floats(pair) -> list[float]:
    return [float(v) for v in pair]
