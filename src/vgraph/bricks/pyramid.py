"""A volume as a multiresolution pyramid of bricks (Retondaro 2008 ch. 3: the octree's levels and
leaves), the interface the out-of-core store and the bricked ray caster share.

Conventions (docs/guide/large-data.md has the long form):
- Level 0 is the full resolution; level k + 1 halves every axis of level k (``ceil(n / 2)`` voxels):
  voxel i of level k + 1 is the mean of voxels 2i and 2i + 1 of level k along each axis (the last
  voxel of an odd axis averages the one voxel it has). So a level's spacing is twice the previous
  one and its first voxel centre lies half a (previous) voxel further: ``origin_{k+1} = origin_k +
  spacing_k / 2``. Integer data are rounded to the nearest value of their type. A label volume
  (``holds_labels``) halves by ``halve_labels`` instead: each voxel of level k + 1 is the most
  frequent label of its 2 x 2 x 2 group, ties to the smallest label, so a coarse level holds only
  labels of level 0 (a mean of labels 1 and 3 would be label 2). (That is how
  ArrayPyramid and vgraph convert build levels; another tool's store may keep an axis or reduce
  it by another factor, with any translation: the renderer places each level by its own spacing
  and origin, cells.py.)
- Shapes are [z, y, x] as arrays; spacing and origin are (x, y, z) world units, as in Volume.
- A brick is a block of ``brick`` voxels (x, y, z) of one level; brick (bx, by, bz) covers voxels
  [bz * brick_z, (bz + 1) * brick_z) ... clamped to the level. ``brick_ranges(level)`` gives the
  min and max of every brick's finite voxels (data units), so bricks that a transfer function
  leaves transparent are known without reading them.
- ``read(level, start, stop)`` returns the voxels [start, stop) ([z, y, x]) of a level, clamped to
  it: a caller asking for a brick with a halo gets what exists and pads itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Level:
    shape: tuple[int, int, int]  # [z, y, x] voxels
    spacing: Vec3                # (x, y, z) world units
    origin: Vec3                 # (x, y, z) world position of voxel (0, 0, 0)'s centre


class BrickSource(Protocol):
    """What a bricked renderer needs of a pyramid (ArrayPyramid in memory, the OME-Zarr store on
    disk)."""

    levels: list[Level]
    brick: tuple[int, int, int]  # (x, y, z) voxels per brick
    dtype: np.dtype
    value_range: tuple[float, float]
    source: str

    def read(self, level: int, start, stop) -> np.ndarray: ...

    def brick_ranges(self, level: int) -> tuple[np.ndarray, np.ndarray]: ...


def level_count(shape, brick) -> int:
    """Levels until the coarsest fits in one brick (at least 1)."""
    count = 1
    shape = tuple(shape)
    while any(n > b for n, b in zip(shape, tuple(brick)[::-1])):
        shape = tuple(math.ceil(n / 2) for n in shape)
        count += 1
    return count


def next_level(level: Level) -> Level:
    return Level(tuple(math.ceil(n / 2) for n in level.shape),
                 tuple(2.0 * s for s in level.spacing),
                 tuple(o + 0.5 * s for o, s in zip(level.origin, level.spacing)))


def halve(data: np.ndarray) -> np.ndarray:
    """One pyramid step of a [z, y, x] block: the mean of each 2 x 2 x 2 group (an odd axis's last
    voxel averages what it has), in float64, rounded back for integer types."""
    out = data.astype(np.float64, copy=False)
    for axis in range(3):
        n = out.shape[axis]
        if n % 2:
            out = np.concatenate([out, np.take(out, [n - 1], axis=axis)], axis=axis)
        shape = list(out.shape)
        shape[axis:axis + 1] = [shape[axis] // 2, 2]
        out = out.reshape(shape).mean(axis=axis + 1)
    if data.dtype.kind in "ui":
        info = np.iinfo(data.dtype)
        return np.clip(np.rint(out), info.min, info.max).astype(data.dtype)
    return out.astype(data.dtype)


def halve_labels(data: np.ndarray) -> np.ndarray:
    """One pyramid step of a [z, y, x] label block: the most frequent label of each 2 x 2 x 2
    group, ties to the smallest (NGFF's image-label asks for nearest or mode downsampling). An odd
    axis's last voxel repeats itself as ``halve`` does, which scales every count of its group
    alike, so the mode is that of the voxels it has. NaN equals nothing, so it wins only a group
    of NaN."""
    groups = _groups_of_eight(data)                  # [n, 8]
    groups.sort(axis=1)
    counts = np.empty(groups.shape, dtype=np.uint8)
    for j in range(8):  # 8 columns, not voxels: each counts its label's copies in every group
        counts[:, j] = np.count_nonzero(groups == groups[:, j:j + 1], axis=1)
    first_most = np.argmax(counts, axis=1)           # sorted: the first maximum is the smallest label
    shape = tuple((n + 1) // 2 for n in data.shape)
    return groups[np.arange(len(groups)), first_most].reshape(shape)


def _groups_of_eight(data: np.ndarray) -> np.ndarray:
    """The 2 x 2 x 2 groups of ``data`` as rows of 8 voxels, in output order (an odd axis's last
    voxel repeated)."""
    pad = [(0, n % 2) for n in data.shape]
    if any(p for _, p in pad):
        data = np.pad(data, pad, mode="edge")
    z, y, x = (n // 2 for n in data.shape)
    blocks = data.reshape(z, 2, y, 2, x, 2).transpose(0, 2, 4, 1, 3, 5)
    return blocks.reshape(z * y * x, 8).copy()


def halver(holds_labels: bool):
    """The pyramid step of a volume: ``halve_labels`` for labels, else ``halve``."""
    return halve_labels if holds_labels else halve


def brick_grid(shape, brick) -> tuple[int, int, int]:
    """Bricks per axis, [z, y, x], of a level of ``shape`` ([z, y, x])."""
    return tuple(math.ceil(n / b) for n, b in zip(shape, tuple(brick)[::-1]))


def block_ranges(data: np.ndarray, brick) -> tuple[np.ndarray, np.ndarray]:
    """Min and max of the finite voxels of every brick of ``data`` (arrays [bz, by, bx], float64;
    NaN where a brick has no finite voxel)."""
    grid = brick_grid(data.shape, brick)
    low = np.full(grid, np.nan)
    high = np.full(grid, np.nan)
    bx, by, bz = brick
    for k, j, i in np.ndindex(*grid):
        block = data[k * bz:(k + 1) * bz, j * by:(j + 1) * by, i * bx:(i + 1) * bx]
        if block.dtype.kind == "f":
            block = block[np.isfinite(block)]
        if block.size:
            low[k, j, i], high[k, j, i] = block.min(), block.max()
    return low, high


SAMPLE_BLOCKS = 64  # reads of a sample (each a block of whole bricks)


def sample_blocks(source: BrickSource, level: int, max_voxels: int, max_bricks: int):
    """Blocks of ``level`` with at most ``max_voxels`` voxels in at most ``max_bricks`` bricks in
    all: the whole level in slabs along z when it is that small, else up to SAMPLE_BLOCKS blocks of
    whole bricks spread evenly over it (of a brick larger than the sample, a block at the level's
    centre). Statistics of a level too large to read (a value range, percentiles) come from this
    bounded sample; a brick is a chunk of the store, and each costs a read however small it is."""
    shape = source.levels[level].shape
    brick = tuple(min(b, n) for b, n in zip(tuple(source.brick)[::-1], shape))  # [z, y, x]
    if math.prod(shape) <= max_voxels and math.prod(brick_grid(shape, source.brick)) <= max_bricks:
        step = max(1, max_voxels // (shape[1] * shape[2]))
        for z in range(0, shape[0], step):
            yield source.read(level, (z, 0, 0), (z + step, shape[1], shape[2]))
        return
    if math.prod(brick) > max_voxels // SAMPLE_BLOCKS:
        side = [min(n, max(1, int(max_voxels ** (1 / 3)))) for n in shape]
        start = [(n - s) // 2 for n, s in zip(shape, side)]
        yield source.read(level, start, [a + s for a, s in zip(start, side)])
        return
    per_block = min(max(1, max_bricks // SAMPLE_BLOCKS), max_voxels // SAMPLE_BLOCKS // math.prod(brick))
    block = [min(n, b * max(1, int(per_block ** (1 / 3)))) for b, n in zip(brick, shape)]
    grid = [-(-n // b) for n, b in zip(shape, block)]
    total = math.prod(grid)
    count = min(SAMPLE_BLOCKS, total)
    for flat in sorted({(2 * i + 1) * total // (2 * count) for i in range(count)}):
        start = [int(i) * b for i, b in zip(np.unravel_index(flat, grid), block)]
        yield source.read(level, start, [a + b for a, b in zip(start, block)])

class ArrayPyramid:
    """A BrickSource over an in-memory [z, y, x] array: the levels are computed up front with
    ``halve`` (``halve_labels`` where ``holds_labels``). For tests, for volumes already in memory
    that are too large for one GL texture, and as the reference the on-disk store must equal."""

    def __init__(self, data: np.ndarray, spacing: Vec3 = (1.0, 1.0, 1.0), origin: Vec3 = (0.0, 0.0, 0.0),
                 brick=(64, 64, 64), levels: int | None = None, value_range=None, source: str = "",
                 holds_labels: bool = False):
        self.brick = tuple(int(b) for b in brick)
        self.dtype = np.dtype(data.dtype)
        self.source = source
        count = levels or level_count(data.shape, self.brick)
        self.levels = [Level(tuple(data.shape), tuple(map(float, spacing)), tuple(map(float, origin)))]
        self._data = [data]
        step = halver(holds_labels)
        for _ in range(count - 1):
            self._data.append(step(self._data[-1]))
            self.levels.append(next_level(self.levels[-1]))
        self._ranges: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        if value_range is None:
            low, high = self.brick_ranges(0)
            value_range = (float(np.nanmin(low)), float(np.nanmax(high))) if np.isfinite(low).any() else (0.0, 1.0)
        self.value_range = tuple(map(float, value_range))

    @classmethod
    def from_volume(cls, volume, brick=(64, 64, 64), levels: int | None = None) -> "ArrayPyramid":
        return cls(volume.data, volume.spacing, volume.origin, brick, levels, volume.value_range,
                   volume.source, holds_labels=bool(getattr(volume, "holds_labels", False)))

    def read(self, level: int, start, stop) -> np.ndarray:
        data = self._data[level]
        lo = [max(0, int(a)) for a in start]
        hi = [min(n, int(b)) for n, b in zip(data.shape, stop)]
        return data[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]

    def brick_ranges(self, level: int) -> tuple[np.ndarray, np.ndarray]:
        if level not in self._ranges:
            self._ranges[level] = block_ranges(self._data[level], self.brick)
        return self._ranges[level]
