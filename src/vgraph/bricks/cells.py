"""The cells the bricked renderer walks: an octree over level 0 whose nodes at level L read their
voxels from level L, whatever factor lies between the levels (docs/explanations/bricked-ray-casting.md).

A pyramid need not halve every axis per level: ome-zarr-py keeps z and floors x and y
(60 -> 30 -> 15 -> 7 -> 3 voxels, scales 0.5, 1, 2, 4.29, 10), bioformats2raw halves x and y
only. So the octree's cells are laid on level 0, not on each level's voxels:

- Level L's cell spans ``brick * factor_L`` level-0 voxels per axis (x, y, z). ``factor_0`` is 1;
  ``factor_L`` is ``factor_{L-1}`` times the whole number nearest to the level's spacing over
  ``factor_{L-1}`` level-0 voxels (at least 1): 2 where an axis halves, 1 where it is kept, so a
  cell's children are 1 or 2 (or more) cells per axis of the level below and tile it exactly.
- A cell's *core* is the level-L voxels that cover its region: the level-0 voxel edges e of the
  region map to the level's edges u = e * s0 / sL + ((o0 - s0 / 2 - oL) / sL + 1/2) (spacing s,
  origin o = voxel 0's centre, as placed by the store's transformations). Where the level is the
  halving of level 0 along an axis (spacing factor * s0, origin moved by (factor - 1) / 2 voxels of
  level 0), the core is exactly voxels [i * brick, (i + 1) * brick) of the level, as vgraph's own
  stores and ArrayPyramid have always had it; elsewhere it is floor(u_lo) .. ceil(u_hi) (a voxel
  of 1e-6 tolerance against rounding), at least one voxel, clamped to the level. The renderer's
  samples are placed by the same spacing and origin (targets.brick_uniforms), so a level sits
  where its transformations put it.
- Level of detail: level L counts as fine enough for a pixel size when each of its voxel edges
  is at most that size or no coarser than level 0's along its axis (``coarseness``): an axis
  the pyramid never reduces does not hold the other axes at a finer level.

The tables depend only on the levels and the brick, and are kept per pair (a few KB each).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

ALIGNED = 1e-9   # relative tolerance of "this level is the halving of level 0 along this axis"
ROUNDING = 1e-6  # level voxels of tolerance when a cell's region is rounded out to whole voxels


class _Table:
    """Per level: factors (x, y, z), cell grid [z, y, x], per axis [z, y, x] the cores' starts and stops."""

    def __init__(self, levels, brick):
        base = levels[0]
        self.factors = _factors(levels)
        self.grids, self.spans = [], []
        for level, factor in zip(levels, self.factors):
            grid, spans = [], []
            for axis in (2, 1, 0):  # z, y, x
                n0, span = base.shape[2 - axis], brick[axis] * factor[axis]
                count = -(-n0 // span)
                spans.append(_axis_cores(base, level, axis, factor[axis], brick[axis], count))
                grid.append(count)
            self.grids.append(tuple(grid))
            self.spans.append(tuple(spans))


@lru_cache(maxsize=64)
def _table(levels: tuple, brick: tuple) -> _Table:
    return _Table(levels, brick)


def table_of(source) -> _Table:
    return _table(tuple(source.levels), tuple(int(b) for b in source.brick))


def _factors(levels) -> list[tuple[int, int, int]]:
    base = levels[0]
    factors = [(1, 1, 1)]
    for level in levels[1:]:
        previous = factors[-1]
        factors.append(tuple(f * max(1, round(s / (s0 * f)))
                             for f, s, s0 in zip(previous, level.spacing, base.spacing)))
    return factors


def _axis_cores(base, level, axis: int, factor: int, brick: int, count: int):
    """(starts, stops) of the cores of the ``count`` cells along ``axis`` (x, y, z numbering)."""
    n0, n = base.shape[2 - axis], level.shape[2 - axis]
    s0, o0, s, o = base.spacing[axis], base.origin[axis], level.spacing[axis], level.origin[axis]
    cells = np.arange(count, dtype=np.int64)
    if _is_halving(s0, o0, s, o, factor):
        starts = cells * brick
        stops = np.minimum(starts + brick, n)
    else:
        edges_lo = cells * (brick * factor)
        edges_hi = np.minimum(edges_lo + brick * factor, n0)
        shift = (o0 - 0.5 * s0 - o) / s + 0.5
        starts = np.floor(edges_lo * (s0 / s) + shift + ROUNDING).astype(np.int64)
        stops = np.ceil(edges_hi * (s0 / s) + shift - ROUNDING).astype(np.int64)
    starts = np.clip(starts, 0, n - 1)
    return starts, np.clip(stops, starts + 1, n)


def _is_halving(s0, o0, s, o, factor: int) -> bool:
    return (abs(s - factor * s0) <= ALIGNED * s
            and abs(o - (o0 + 0.5 * (factor - 1) * s0)) <= ALIGNED * s)


# --- what the renderer asks -------------------------------------------------------------------------
def cell_factors(source) -> list[tuple[int, int, int]]:
    """Level-0 voxels per cell voxel of every level, (x, y, z)."""
    return table_of(source).factors


def cell_grid(source, level: int) -> tuple[int, int, int]:
    """Cells of ``level`` per axis, [z, y, x]."""
    return table_of(source).grids[level]


def cell_extent(source, key) -> tuple[np.ndarray, np.ndarray]:
    """Voxels [start, stop) ([z, y, x]) of the level that form the core of cell ``key`` =
    (level, cz, cy, cx)."""
    spans = table_of(source).spans[key[0]]
    start = np.array([int(spans[a][0][key[1 + a]]) for a in range(3)])
    stop = np.array([int(spans[a][1][key[1 + a]]) for a in range(3)])
    return start, stop


def cells_of_bricks(source, level: int, per_brick: np.ndarray) -> np.ndarray:
    """A bool per brick of the level's own grid ([z, y, x], brick_grid) -> a bool per cell: true
    where any brick the cell's core touches is (the same array where cells are the bricks)."""
    out = np.asarray(per_brick, dtype=bool)
    for axis, (first, last) in enumerate(_bricks_of_cells(source, level)):
        if not _one_to_one(first, last, out.shape[axis]):
            out = np.stack([np.take(out, range(a, b), axis=axis).any(axis=axis)
                            for a, b in zip(first, last)], axis=axis)
    return out


def cells_are_bricks(source, level: int) -> bool:
    """Whether each cell of ``level`` is one brick of it, cell i brick i (cells_of_bricks is the
    identity there)."""
    grid = [-(-int(n) // int(b)) for n, b in zip(source.levels[level].shape, tuple(source.brick)[::-1])]  # [z, y, x]
    return all(_one_to_one(first, last, n) for (first, last), n in zip(_bricks_of_cells(source, level), grid))


def _bricks_of_cells(source, level: int):
    """Per axis [z, y, x]: the first and past-the-last brick of the level each cell's core touches."""
    brick = tuple(int(b) for b in source.brick)[::-1]  # [z, y, x]
    return [(starts // brick[axis], (stops - 1) // brick[axis] + 1)
            for axis, (starts, stops) in enumerate(table_of(source).spans[level])]


def _one_to_one(first, last, bricks: int) -> bool:
    return len(first) == bricks and np.array_equal(first, np.arange(len(first))) and np.array_equal(last, first + 1)


def coarseness(source) -> np.ndarray:
    """Per level, log2 of its longest voxel edge among the axes coarser than level 0's, over level
    0's longest edge (level 0: 0; a halving pyramid: L exactly; -inf where no axis is coarser).
    Level L is fine enough where a level-0 voxel's longest edge projects to p pixels and
    coarseness[L] <= -log2(p) + lod_bias; it never decreases from level to level."""
    levels = source.levels
    longest0 = max(levels[0].spacing)
    values = [0.0]
    for level in levels[1:]:
        coarser = [s for s, s0 in zip(level.spacing, levels[0].spacing) if s > s0 * (1 + ALIGNED)]
        values.append(math.log2(max(coarser) / longest0) if coarser else -math.inf)
    return np.asarray(values)
