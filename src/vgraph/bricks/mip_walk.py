"""The single-pass bricked ray caster's mip in the RayCaster's order (issue #33): a grid of block
maxima over the frame's bricks, which rays walk as the RayCaster walks its volume's blocks
(shaders/raycasting/compositing_mip.glsl: the stretch with the largest maximum first, then only
the stretches that can still change the result), looking the page table up only where they sample.

Conventions:
- The grid covers level 0's voxels in blocks of ``block`` level-0 voxels per axis (WALK_BLOCK, as
  the RayCaster's walk, doubled until the grid has at most MAX_TEXELS): block g holds the samples at
  t * dims0 in [block * g, block * (g + 1)), so its coordinate is q = t * dims0 / block
  (``uniforms``: the empty-space grid's block_scale, block_offset 0 and block_count).
- Its value bounds every sample a ray takes in it: the largest maximum of the blocks of the atlas's
  bricks (vgraph.bricks.atlas_blocks, whose ranges cover what their samples filter, half a voxel
  past them) that overlap it, within the cell each brick is drawn in; 0 (adds nothing) where no
  brick is drawn. At level 0, in bricks of a multiple of 8 voxels, a block of the grid is one of a
  brick's blocks. A coarser brick's blocks reach EDGE level-0 voxels past their faces, so a sample
  that rounding puts in the block across a cell face is still bounded.
- Only frames whose planned bricks are all in the atlas walk the grid: a missing brick's rays must
  look its cell up to ask for it (vgraph.bricks.ray_requests), which the front-to-back march does.
"""

from __future__ import annotations

import math

import numpy as np

from vgraph.bricks.cache import BLOCK
from vgraph.bricks.cells import table_of
from vgraph.bricks.selection import BrickGeometry
from vgraph.gl.raycasting.empty_space import WALK_BLOCK

MAX_TEXELS = 128 ** 3  # the grid's size at most (8 MiB of R32F): a coarser block beyond
EDGE = 1e-3            # level-0 voxels a coarser brick's blocks reach past their faces (module docstring)


def walk_block(geometry: BrickGeometry) -> int:
    """Level-0 voxels per block of the grid along each axis (module docstring)."""
    block = WALK_BLOCK
    while math.prod(-(-int(n) // block) for n in geometry.dims0) > MAX_TEXELS:
        block *= 2
    return block


def walk_grid(source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray) -> tuple[np.ndarray, int]:
    """(float32 [z, y, x] block maxima, block): the grid over the bricks ``keys`` (level, z, y, x),
    each drawn in its own cell; ``slot_of(key)`` its atlas slot, ``ranges`` the atlas's block ranges
    [slot, bz, by, bx, (min, max)] (AtlasBlocks.ranges)."""
    block = walk_block(geometry)
    count = [-(-int(n) // block) for n in geometry.dims0]  # (x, y, z)
    grid = np.zeros(count[::-1], dtype=np.float32)
    spans = table_of(source).spans  # per level, per axis [z, y, x]: the cores' (starts, stops)
    for key in keys:
        maxima = np.nan_to_num(ranges[slot_of(key), ..., 1], nan=np.inf)  # unknown: never skipped
        lo, hi = geometry.voxel_bounds(key)  # the cell's level-0 voxels (x, y, z)
        axes = [_overlaps(geometry, source, key, axis, spans, lo[2 - axis], hi[2 - axis], block, maxima.shape[axis])
                for axis in range(3)]  # [z, y, x]: (the brick's blocks, the grid's blocks) they overlap
        (kz, gz), (ky, gy), (kx, gx) = axes
        values = maxima[kz[:, None, None], ky[None, :, None], kx[None, None, :]]
        np.maximum.at(grid, (gz[:, None, None], gy[None, :, None], gx[None, None, :]), values)
    return grid, block


def _overlaps(geometry: BrickGeometry, source, key, axis: int, spans, lo: float, hi: float, block: int, n: int):
    """Along ``axis`` ([z, y, x] numbering) of brick ``key``: the pairs (its block k, the grid's block
    g) whose samples overlap within the cell [lo, hi) (level-0 voxels), as two int arrays."""
    level = int(key[0])
    xyz = 2 - axis
    base, own = source.levels[0], source.levels[level]
    # the level's voxel coordinate u (centres at integers) -> level-0 coordinate t * dims0
    ratio = float(own.spacing[xyz]) / float(base.spacing[xyz])
    shift = (float(own.origin[xyz]) - float(base.origin[xyz])) / float(base.spacing[xyz]) + 0.5
    start = float(spans[level][axis][0][int(key[1 + axis])])
    k = np.arange(n)
    a = (start + BLOCK * k - 0.5) * ratio + shift  # the samples of block k: [a, b) in t * dims0
    b = a + BLOCK * ratio
    edge = EDGE if level > 0 else 0.0
    a, b = np.maximum(a - edge, lo - edge), np.minimum(b + edge, hi + edge)
    first = np.floor(a / block).astype(np.int64)
    last = np.ceil(b / block).astype(np.int64) - 1
    last = np.minimum(last, -(-int(geometry.dims0[xyz]) // block) - 1)
    first = np.maximum(first, 0)
    pairs = [(kk, g) for kk, f, l, ok in zip(k, first, last, a < b) if ok for g in range(f, l + 1)]
    if not pairs:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return np.asarray(pairs, dtype=np.int64).T


def uniforms(geometry: BrickGeometry, block: int, grid: np.ndarray) -> dict:
    """The empty-space grid's uniforms (empty_space.glsl) for the walk grid."""
    return {"block_scale": tuple(float(n) / block for n in geometry.dims0), "block_offset": (0.0, 0.0, 0.0),
            "block_count": tuple(int(n) for n in grid.shape[::-1])}
