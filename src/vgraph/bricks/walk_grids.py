"""The grids the single-pass bricked ray caster's rays walk as the RayCaster's do (issue #33). For
mip, a grid of block maxima over the frame's bricks, which rays walk as the RayCaster walks its volume's blocks
(shaders/raycasting/compositing_mip.glsl: the stretch with the largest maximum first, then only
the stretches that can still change the result), looking the page table up only where they sample.
The same grid, of skip radii (``skip_radii``: the RayCaster's empty_space.skip_radii of the blocks
occupied under its rule), serves dvr, shaded or not (PAGED_WALK, shaders/raycasting/march.glsl). iso's
grid (``iso_grid``, PAGED_ISO_GRID, compositing_iso.glsl) is the RayCaster's own: blocks of 4
level-0 voxels from the slots' maxima per block of 4 (AtlasBlocks.fine_maxima), each texel also
holding where its cell's slot is, so that a sample's one fetch says whether to jump and where to
read (frames whose bricks are all of level 0; coarser bricks keep the slots' distances: at their
39-59 samples a pixel on the bonsai the runs, which read no grid per sample, were faster).

Conventions:
- The grid covers level 0's voxels in blocks of ``block`` level-0 voxels per axis (WALK_BLOCK, as
  the RayCaster's walk, doubled until the grid has at most MAX_TEXELS, and MAX_AXIS along an axis):
  block g holds the samples at t * dims0 in [block * g, block * (g + 1)), so its coordinate is
  q = t * dims0 / block (``uniforms``: the empty-space grid's block_scale, block_offset 0 and
  block_count). A stretch of a ray in a block may span several cells: its samples are read run by
  run (compositing_mip.glsl's take_stretch).
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

from vgraph.bricks.atlas_blocks import FINE
from vgraph.bricks.cache import BLOCK
from vgraph.bricks.cells import table_of
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.gl.raycasting.empty_space import WALK_BLOCK, occupied_blocks, radii_if_worthwhile

MAX_TEXELS = 128 ** 3  # the grid's size at most (8 MiB of R32F): a coarser block beyond
MAX_AXIS = 2048        # texels along an axis at most: every GL 4 holds a 3D texture this wide
NOT_DRAWN = -1e6      # iso_grid's offset of a block whose cell is not drawn (never read: its samples are jumped)
EDGE = 1e-3            # level-0 voxels a coarser brick's blocks reach past their faces (module docstring)


def walk_block(geometry: BrickGeometry) -> int:
    """Level-0 voxels per block of the grid along each axis (module docstring)."""
    return _fitting(geometry, WALK_BLOCK)


def _fitting(geometry: BrickGeometry, block: int) -> int:
    """``block`` doubled until the grid has at most MAX_TEXELS, and MAX_AXIS along an axis."""
    while math.prod(_counts(geometry, block)) > MAX_TEXELS or max(_counts(geometry, block)) > MAX_AXIS:
        block *= 2
    return block


def _counts(geometry: BrickGeometry, block: int) -> list[int]:
    return [-(-int(n) // block) for n in geometry.dims0]


def frame_grid(alpha, source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray):
    """(grid or None, block, define): mip's block maxima (``alpha`` None; PAGED_MIP_WALK), else dvr's
    skip radii under the opacity per value ``alpha`` (PAGED_WALK; None where skipping would not pay)."""
    if alpha is None:
        return (*walk_grid(source, geometry, keys, slot_of, ranges), "PAGED_MIP_WALK")
    occupied = lambda low, high: occupied_blocks(low, high, alpha)  # noqa: E731 (the RayCaster's rule)
    return (*skip_radii(source, geometry, keys, slot_of, ranges, occupied), "PAGED_WALK")


def walk_grid(source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray) -> tuple[np.ndarray, int]:
    """(float32 [z, y, x] block maxima, block): the grid over the bricks ``keys`` (level, z, y, x),
    each drawn in its own cell; ``slot_of(key)`` its atlas slot, ``ranges`` the atlas's block ranges
    [slot, bz, by, bx, (min, max)] (AtlasBlocks.ranges)."""
    maxima = np.nan_to_num(ranges[..., 1], nan=np.inf)  # unknown: never skipped
    return _reduced_grid(source, geometry, keys, slot_of, maxima, np.maximum, 0.0)


def skip_radii(source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray, occupied) -> tuple[np.ndarray | None, int]:
    """dvr's grid (PAGED_WALK, march.glsl): (float32 [z, y, x] skip radii as the
    RayCaster's (empty_space.skip_radii), block), over the same blocks as walk_grid; a block is
    occupied where ``occupied(low, high)`` (the RayCaster's rule on normalised ranges) holds for the
    range of the atlas blocks overlapping it; blocks no brick is drawn in are empty. None for the
    radii where skipping would not pay (empty_space.radii_if_worthwhile)."""
    low, block = _reduced_grid(source, geometry, keys, slot_of, np.nan_to_num(ranges[..., 0], nan=-np.inf),
                               np.minimum, np.inf)  # unknown: always occupied
    high, _ = _reduced_grid(source, geometry, keys, slot_of, np.nan_to_num(ranges[..., 1], nan=np.inf),
                            np.maximum, -np.inf)
    drawn = low <= high  # the others: no brick's samples reach the block
    occupied_blocks = drawn & occupied(np.where(drawn, low, 0.0), np.where(drawn, high, 0.0))
    return radii_if_worthwhile(occupied_blocks), block


def _reduced_grid(source, geometry: BrickGeometry, keys, slot_of, values: np.ndarray, reducer, fill: float) -> tuple[np.ndarray, int]:
    """(float32 [z, y, x], block): ``reducer`` (np.maximum, np.minimum) over ``values`` [slot, bz, by,
    bx] of the atlas blocks overlapping each block of the grid, within the cell each brick ``keys``
    is drawn in; ``fill`` where none does. Whole levels at a time in numpy (the 4096 bricks of 32^3
    of a 512^3 volume: a loop over the bricks took 0.3 s)."""
    block = walk_block(geometry)
    grid = np.full(_counts(geometry, block)[::-1], fill, dtype=np.float32)  # [z, y, x]
    keys = np.asarray(keys, dtype=np.int64).reshape(-1, 4)
    slots = np.fromiter((slot_of(tuple(int(v) for v in key)) for key in keys), dtype=np.int64, count=len(keys))
    for level in np.unique(keys[:, 0]):
        mine = keys[:, 0] == level
        brick_values = values[slots[mine]]  # [brick, bz, by, bx]
        (gz, vz), (gy, vy), (gx, vx) = [_overlaps(geometry, source, int(level), axis, keys[mine], block, brick_values.shape[1 + axis])
                                        for axis in range(3)]  # [brick, k, c]: the grid's blocks block k overlaps
        shape = (len(brick_values), gz.shape[1], gz.shape[2], gy.shape[1], gy.shape[2], gx.shape[1], gx.shape[2])
        z, y, x = gz[:, :, :, None, None, None, None], gy[:, None, None, :, :, None, None], gx[:, None, None, None, None, :, :]
        valid = np.broadcast_to(vz[:, :, :, None, None, None, None] & vy[:, None, None, :, :, None, None]
                                & vx[:, None, None, None, None, :, :], shape)
        picked = np.broadcast_to(brick_values[:, :, None, :, None, :, None], shape)[valid]
        reducer.at(grid, tuple(np.broadcast_to(g, shape)[valid] for g in (z, y, x)), picked)
    return grid, block


def _overlaps(geometry: BrickGeometry, source, level: int, axis: int, keys: np.ndarray, block: int, n: int):
    """Along ``axis`` ([z, y, x] numbering) of the bricks ``keys`` of ``level``: (g, valid), int and
    bool [brick, k, c], the grid's blocks whose samples those of each brick's block k overlap within
    the brick's cell, c of them at most (valid: one of them)."""
    xyz = 2 - axis
    base, own = source.levels[0], source.levels[level]
    # the level's voxel coordinate u (centres at integers) -> level-0 coordinate t * dims0
    ratio = float(own.spacing[xyz]) / float(base.spacing[xyz])
    shift = (float(own.origin[xyz]) - float(base.origin[xyz])) / float(base.spacing[xyz]) + 0.5
    index = keys[:, 1 + axis]
    start = np.asarray(table_of(source).spans[level][axis][0], dtype=np.float64)[index]  # the cores' first voxels
    span = float(geometry.spans[level][xyz])
    lo, hi = index * span, np.minimum((index + 1) * span, float(geometry.dims0[xyz]))  # the cells, level-0 voxels
    a = (start[:, None] + BLOCK * np.arange(n) - 0.5) * ratio + shift  # the samples of block k: [a, b)
    b = a + BLOCK * ratio
    edge = EDGE if level > 0 else 0.0
    a, b = np.maximum(a, lo[:, None]) - edge, np.minimum(b, hi[:, None]) + edge
    first = np.maximum(np.floor(a / block).astype(np.int64), 0)
    last = np.minimum(np.ceil(b / block).astype(np.int64) - 1, -(-int(geometry.dims0[xyz]) // block) - 1)
    last = np.where(a < b, last, first - 1)  # a block past the cell (a smaller brick's): none
    c = max(int((last - first).max(initial=0)) + 1, 1)
    g = first[:, :, None] + np.arange(c)
    return np.minimum(g, np.maximum(last[:, :, None], 0)), g <= last[:, :, None]


def uniforms(geometry: BrickGeometry, block: int, grid: np.ndarray) -> dict:
    """The empty-space grid's uniforms (empty_space.glsl) for the walk grid."""
    return {"block_scale": tuple(float(n) / block for n in geometry.dims0), "block_offset": (0.0, 0.0, 0.0),
            "block_count": tuple(int(n) for n in grid.shape[::-1])}


def iso_block(geometry: BrickGeometry) -> int:
    """Level-0 voxels per block of iso_grid: FINE, doubled until the grid has at most MAX_TEXELS
    (and MAX_AXIS along an axis), as walk_block."""
    return _fitting(geometry, FINE)


def iso_grid(source, geometry: BrickGeometry, keys, slot_of, blocks, table: np.ndarray, level: float,
             atlas_size) -> tuple[np.ndarray | None, int]:
    """iso's grid of a complete frame whose bricks are all of level 0 (PAGED_ISO_GRID,
    compositing_iso.glsl): (float32 [z, y, x, 4] or None, block) per block of ``block`` level-0
    voxels (iso_block: FINE = 4, the RayCaster's own blocks, up to 512^3 voxels): r = the
    RayCaster's skip radius (0 where the block may reach ``level``: its largest value, from
    AtlasBlocks.fine_maxima, is not below it; blocks of cells not drawn are empty), gba = where the
    block's cell is drawn, the normalised atlas coordinate that t * dims0 / atlas_size adds to read
    its slot (its leaf entry's texel offset, level 0's half-voxel shift, over the atlas's size),
    else NOT_DRAWN: a sample's one fetch of the grid gives both whether to jump and where to read.
    ``table``: the flat leaf table [cz, cy, cx, 4] (leaf_pages, directory level 0). None where it
    does not apply: a brick of another level, cells that are no whole number of blocks (the
    block's cell must be one), or under empty_space.MIN_EMPTY_FRACTION of the blocks empty."""
    keys = np.asarray(keys, dtype=np.int64).reshape(-1, 4)
    span = geometry.spans[0].astype(np.int64)  # (x, y, z)
    block = iso_block(geometry)
    counts = _counts(geometry, block)  # (x, y, z)
    if len(keys) == 0 or keys[:, 0].any() or (span % block).any():
        return None, block
    spans = table_of(source).spans[0]
    per = (span // block)[::-1]  # blocks per cell, [z, y, x]
    for axis in range(3):  # the cores start where the cells do (cells.py): block k of a brick is block per * cell + k
        starts = np.asarray(spans[axis][0], dtype=np.int64)
        if (starts != np.arange(len(starts)) * int(span[2 - axis])).any():
            return None, block
    shape = tuple(counts[::-1])
    occupied = np.zeros(shape, dtype=bool)  # blocks of cells not drawn: empty
    slots = [slot_of(tuple(int(v) for v in key)) for key in keys]
    # (the single pass's rule: a block below the level adds nothing; unknown blocks' maxima are the dtype's largest)
    maxima = blocks.fine_maxima[slots]
    for _ in range(block.bit_length() - FINE.bit_length()):  # blocks of 8, 16, ...: their halves' windows together
        for axis in (1, 2, 3):  # (empty_space.pairs_reduced, per slot)
            maxima = np.maximum.reduceat(maxima, np.arange(0, maxima.shape[axis], 2), axis=axis)
    reaching = ~(blocks.normalised(maxima) < level)
    fz, fy, fx = reaching.shape[1:]
    for key, reach in zip(keys, reaching):
        z, y, x = (int(v) * int(n) for v, n in zip(key[1:], per))
        nz, ny, nx = min(fz, shape[0] - z), min(fy, shape[1] - y), min(fx, shape[2] - x)
        occupied[z:z + nz, y:y + ny, x:x + nx] = reach[:nz, :ny, :nx]
    radii = radii_if_worthwhile(occupied)
    if radii is None:
        return None, block
    # each cell's offset, then the cells' blocks by broadcasting (a repeat of the blocks' array took 60 ms at 128^3)
    offset = (table[..., :3].astype(np.float64) - 0.5) / np.asarray(atlas_size, dtype=np.float64)
    offset = np.where(table[..., 3:4] > 0.0, offset, NOT_DRAWN).astype(np.float32)  # [cz, cy, cx, 3]
    (cz, cy, cx), (pz, py, px) = table.shape[:3], (int(n) for n in per)
    blocks_of_cells = np.empty((cz, pz, cy, py, cx, px, 4), dtype=np.float32)
    blocks_of_cells[..., 1:] = offset[:, None, :, None, :, None, :]
    grid = blocks_of_cells.reshape(cz * pz, cy * py, cx * px, 4)[:shape[0], :shape[1], :shape[2]]
    grid[..., 0] = radii
    return grid, block
