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
  brick's blocks. A coarser brick's blocks reach EDGE level-0 voxels past the faces of the cell it is
  drawn in, so a sample that rounding puts in the block across a cell face is still bounded (inside
  the cell the next block's range bounds the same samples: it covers half a voxel past them).
- mip's frames with missing bricks walk it too (``asking_grid``, PAGED_MIP_ASKS): a missing cell's
  blocks bound what its finest resident ancestor draws there (0 where nothing is drawn), and a
  second channel flags the blocks within EDGE of a missing cell, which the walk visits front to
  back to ask for them as the plain march would (compositing_mip.glsl). So do iso's (``skip_radii``
  with ``missing``, PAGED_WALK with PAGED_WALK_ASKS): skip radii from what each cell's finest
  resident ancestor draws there, the empty blocks within EDGE of a missing cell ASKING (march.glsl).
  dvr's grid is made only for frames whose planned bricks are all in the atlas: its refining frames'
  rays march (walked the same way, they ask for the same cells and 0.1-0.3 % more pixels than the
  march, whose coarse cells take only their lattice's samples (PAGED_STRIDE) and so hop over thin
  slices of cells without asking; and they were slower once level-0 bricks were resident, while
  the march now skips the stand-ins' empty blocks too: docs/explanations/bricked-ray-casting.md).
- Frame after frame (a refining frame's atlas changes each frame), which blocks of the grid a
  brick's blocks overlap within a cell it is drawn in, with their values, is found only for the
  (cell, brick) pairs new since the last frame: each pair's stays with the brick's atlas slot
  (AtlasBlocks.of_slot) until another brick is recorded there, and the frame's grid reduces those
  of all its pairs (the same values: the same grid to the bit, max and min in any order). The
  radii (a distance transform of the whole grid, 1-2 ms at 64^3) and the asking blocks are made
  again each frame.
"""

from __future__ import annotations

import math

import numpy as np

from vgraph.bricks.atlas_blocks import FINE
from vgraph.bricks.cache import BLOCK
from vgraph.bricks.cells import table_of
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.gl.raycasting.empty_space import MIN_EMPTY_FRACTION, WALK_BLOCK, occupied_blocks, radii_if_worthwhile
from vgraph.gl.raycasting.empty_space import skip_radii as empty_radii

MAX_TEXELS = 128 ** 3  # the grid's size at most (8 MiB of R32F): a coarser block beyond
MAX_AXIS = 2048        # texels along an axis at most: every GL 4 holds a 3D texture this wide
NOT_DRAWN = -1e6      # iso_grid's offset of a block whose cell is not drawn (never read: its samples are jumped)
EDGE = 1e-3            # level-0 voxels a coarser brick's blocks reach past their faces (module docstring)
ASKING = -1.0          # skip_radii's value of an empty block where rays ask for a missing cell (march.glsl)


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


def frame_grid(alpha, source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray, memo=None):
    """(grid or None, block, define): mip's block maxima (``alpha`` None; PAGED_MIP_WALK), else dvr's
    skip radii under the opacity per value ``alpha`` (PAGED_WALK; None where skipping would not pay).
    Every key drawn from its own brick (a complete frame); mip's frames with missing bricks:
    asking_grid, iso's: skip_radii with ``missing``. ``memo``: as _reduced_grid's."""
    if alpha is None:
        return (*walk_grid(source, geometry, keys, slot_of, ranges, memo=memo), "PAGED_MIP_WALK")
    occupied = lambda low, high: occupied_blocks(low, high, alpha)  # noqa: E731 (the RayCaster's rule)
    return (*skip_radii(source, geometry, keys, slot_of, ranges, occupied, memo=memo), "PAGED_WALK")


def walk_grid(source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray, bricks=None,
              memo=None) -> tuple[np.ndarray, int]:
    """(float32 [z, y, x] block maxima, block): the grid over the cells ``keys`` (level, z, y, x),
    each drawn from its own brick, or from ``bricks[i]`` (a resident ancestor; None: nothing drawn
    there, 0); ``slot_of(key)`` a brick's atlas slot, ``ranges`` the atlas's block ranges
    [slot, bz, by, bx, (min, max)] (AtlasBlocks.ranges); ``memo``: the AtlasBlocks of those ranges,
    which keep what each brick adds (_reduced_grid), or None (everything reduced again)."""
    maxima = np.nan_to_num(ranges[..., 1], nan=np.inf)  # unknown: never skipped
    return _reduced_grid(source, geometry, keys, slot_of, maxima, np.maximum, 0.0, bricks, memo, "high")


def asking_grid(source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray, bricks, missing,
                memo=None) -> tuple[np.ndarray, int]:
    """mip's grid for a frame with missing bricks (PAGED_MIP_WALK and PAGED_MIP_ASKS): (float32
    [z, y, x, 2], block), r = walk_grid's maxima over the cells ``keys`` each drawn from ``bricks[i]``
    (itself, its finest resident ancestor, None), g = 1 where the block lies within EDGE level-0
    voxels of one of the ``missing`` cells [n, 4] (the walk asks there: module docstring), else 0."""
    maxima, block = walk_grid(source, geometry, keys, slot_of, ranges, bricks, memo)
    return np.stack([maxima, _asking(geometry, maxima.shape, block, missing).astype(np.float32)], axis=-1), block


def _asking(geometry: BrickGeometry, shape, block: int, missing) -> np.ndarray:
    """bool [z, y, x] over a grid of ``shape``: the blocks within EDGE level-0 voxels of one of the
    ``missing`` cells [n, 4] (where rays ask for them: module docstring)."""
    flags = np.zeros(shape, dtype=bool)
    count = np.asarray(shape[::-1], dtype=np.int64)  # (x, y, z)
    dims0 = np.asarray(geometry.dims0, dtype=np.float64)
    for key in np.asarray(missing, dtype=np.int64).reshape(-1, 4):
        span = geometry.spans[int(key[0])].astype(np.float64)  # (x, y, z) level-0 voxels a cell
        cell = key[1:][::-1].astype(np.float64)
        lo, hi = cell * span - EDGE, np.minimum((cell + 1.0) * span, dims0) + EDGE
        first = np.maximum(np.floor(lo / block).astype(np.int64), 0)
        last = np.minimum(np.ceil(hi / block).astype(np.int64), count)
        flags[first[2]:last[2], first[1]:last[1], first[0]:last[0]] = True
    return flags


def skip_radii(source, geometry: BrickGeometry, keys, slot_of, ranges: np.ndarray, occupied, bricks=None,
               missing=(), lows: bool = True, memo=None) -> tuple[np.ndarray | None, int]:
    """dvr's grid (PAGED_WALK, march.glsl), iso's in refining frames: (float32 [z, y, x] skip radii as the
    RayCaster's (empty_space.skip_radii), block), over the same blocks as walk_grid; a block is
    occupied where ``occupied(low, high)`` (the RayCaster's rule on normalised ranges) holds for the
    range of the atlas blocks overlapping it; blocks no brick is drawn in are empty. None for the
    radii where skipping would not pay (empty_space.radii_if_worthwhile). A frame with ``missing``
    cells [n, 4] (PAGED_WALK with PAGED_WALK_ASKS, under PAGED_REQUESTS): each of the cells
    ``keys`` drawn from ``bricks[i]`` (itself, its finest resident ancestor, None) as walk_grid's,
    and the empty blocks within EDGE of a missing cell ASKING: no jump enters one, a ray that lands
    in one starts a run there (which asks for the missing cell, march.glsl) and moves past the
    block, so that it asks for every missing cell it has a sample in, as the front-to-back march
    does, before any sample in it. ``lows`` False: a rule on the maxima only (iso's; ``low`` is then
    0, not reduced, half the time). ``memo``: walk_grid's."""
    high, block = _reduced_grid(source, geometry, keys, slot_of, np.nan_to_num(ranges[..., 1], nan=np.inf),
                                np.maximum, -np.inf, bricks, memo, "high")  # unknown: always occupied
    if lows:
        low, _ = _reduced_grid(source, geometry, keys, slot_of, np.nan_to_num(ranges[..., 0], nan=-np.inf),
                               np.minimum, np.inf, bricks, memo, "low")
        drawn = low <= high  # the others: no brick's samples reach the block
    else:
        low, drawn = np.zeros_like(high), high > -np.inf
    occupied_blocks = drawn & occupied(np.where(drawn, low, 0.0), np.where(drawn, high, 0.0))
    if not len(missing):
        return radii_if_worthwhile(occupied_blocks), block
    # the empty blocks where rays ask: no jump enters them (their radii count them as occupied), a
    # ray landing in one asks there and leaves it (ASKING); worthwhile by the blocks that add nothing
    asking = _asking(geometry, occupied_blocks.shape, block, missing) & ~occupied_blocks
    if 1.0 - occupied_blocks.mean() < MIN_EMPTY_FRACTION:
        return None, block
    return np.where(asking, ASKING, empty_radii(occupied_blocks | asking)).astype(np.float32), block


def _reduced_grid(source, geometry: BrickGeometry, keys, slot_of, values: np.ndarray, reducer, fill: float,
                  bricks=None, memo=None, channel: str = "") -> tuple[np.ndarray, int]:
    """(float32 [z, y, x], block): ``reducer`` (np.maximum, np.minimum) over ``values`` [slot, bz, by,
    bx] of the atlas blocks overlapping each block of the grid, within the cell ``keys[i]`` each is
    drawn in, from its own brick or from ``bricks[i]`` (None: nothing drawn); ``fill`` where none
    is. Whole levels at a time in numpy (the 4096 bricks of 32^3 of a 512^3 volume: a loop over the
    bricks took 0.3 s). ``memo``: the atlas's AtlasBlocks, whose ``of_slot`` keeps, for each cell a
    brick is drawn in, the grid's blocks its blocks there overlap with their values (``channel``:
    which of its ranges ``values`` are) while the brick stays in its slot, so that a frame finds
    those of the (cell, brick) pairs new since the last frame only (a refining frame's few loaded
    bricks and the cells they now draw) and reduces them all: the same values, so the same grid
    to the bit (max and min in any order)."""
    block = walk_block(geometry)
    grid = np.full(_counts(geometry, block)[::-1], fill, dtype=np.float32)  # [z, y, x]
    cells = np.asarray(keys, dtype=np.int64).reshape(-1, 4)
    if bricks is None:
        keys = cells
    else:  # the cells drawn from some brick, with it
        drawn = [i for i, brick in enumerate(bricks) if brick is not None]
        cells = cells[drawn]
        keys = np.asarray([bricks[i] for i in drawn], dtype=np.int64).reshape(-1, 4)
    brick_keys = list(map(tuple, keys.tolist()))
    slots = np.fromiter(map(slot_of, brick_keys), dtype=np.int64, count=len(brick_keys))
    if memo is None:
        flat, picked, _ = _overlapping(source, geometry, cells, keys, slots, values, block, grid.shape)
        reducer.at(grid.reshape(-1), flat, picked)
        return grid, block
    kept = [memo.of_slot(slot) for slot in slots.tolist()]
    names = [(channel, block, cell, brick) for cell, brick in zip(map(tuple, cells.tolist()), brick_keys)]
    new = [i for i, (held, name) in enumerate(zip(kept, names)) if name not in held]
    if new:  # each new pair's blocks of the grid and values, kept as they are (the reduction: 0.8 ms for 600k)
        flat, picked, row = _overlapping(source, geometry, cells[new], keys[new], slots[new], values, block, grid.shape)
        order = np.argsort(row, kind="stable")  # (sorted already within each level's pairs)
        flat, picked = flat[order].astype(np.int32), picked[order]
        bounds = np.searchsorted(row[order], np.arange(len(new) + 1))
        for j, i in enumerate(new):  # (copies: a pair's slice would keep the whole frame's arrays)
            kept[i][names[i]] = (flat[bounds[j]:bounds[j + 1]].copy(), picked[bounds[j]:bounds[j + 1]].copy())
    if names:
        held = [kept[i][names[i]] for i in range(len(names))]
        reducer.at(grid.reshape(-1), np.concatenate([h[0] for h in held]), np.concatenate([h[1] for h in held]))
    return grid, block


def _overlapping(source, geometry: BrickGeometry, cells: np.ndarray, keys: np.ndarray, slots: np.ndarray,
                 values: np.ndarray, block: int, shape) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(flat, picked, row): for each pair of a cell ``cells[i]`` and the brick ``keys[i]`` (in slot
    ``slots[i]``) drawn there, the grid's blocks (flat indices into a grid of ``shape``) that each
    of the brick's blocks in the cell overlaps, with the block's value, and i (_reduced_grid)."""
    flats, pickeds, rows = [np.zeros(0, np.int64)], [np.zeros(0, values.dtype)], [np.zeros(0, np.int64)]
    for level, cell_level in np.unique(np.stack([keys[:, 0], cells[:, 0]], axis=-1), axis=0):
        mine = (keys[:, 0] == level) & (cells[:, 0] == cell_level)
        brick_values = values[slots[mine]]  # [brick, bz, by, bx]
        # [brick, m, c]: the grid's blocks that the brick's m blocks in its cell overlap, and which they are
        (gz, vz, kz), (gy, vy, ky), (gx, vx, kx) = [_overlaps(geometry, source, int(level), axis, keys[mine], block,
                                                              brick_values.shape[1 + axis], cells[mine])
                                                    for axis in range(3)]
        brick_values = brick_values[np.arange(len(brick_values))[:, None, None, None], kz[:, :, None, None],
                                    ky[:, None, :, None], kx[:, None, None, :]]  # the blocks in the cell
        shape7 = (len(brick_values), gz.shape[1], gz.shape[2], gy.shape[1], gy.shape[2], gx.shape[1], gx.shape[2])
        z, y, x = gz[:, :, :, None, None, None, None], gy[:, None, None, :, :, None, None], gx[:, None, None, None, None, :, :]
        valid = np.broadcast_to(vz[:, :, :, None, None, None, None] & vy[:, None, None, :, :, None, None]
                                & vx[:, None, None, None, None, :, :], shape7)
        pickeds.append(np.broadcast_to(brick_values[:, :, None, :, None, :, None], shape7)[valid])
        flats.append(np.ravel_multi_index(tuple(np.broadcast_to(g, shape7)[valid] for g in (z, y, x)), shape))
        rows.append(np.broadcast_to(np.flatnonzero(mine)[:, None, None, None, None, None, None], shape7)[valid])
    return np.concatenate(flats), np.concatenate(pickeds), np.concatenate(rows)


def _overlaps(geometry: BrickGeometry, source, level: int, axis: int, keys: np.ndarray, block: int, n: int,
              cells: np.ndarray):
    """Along ``axis`` ([z, y, x] numbering) of the bricks ``keys`` of ``level``: (g, valid, k), int,
    bool and int [brick, m, c] and [brick, m]: the grid's blocks whose samples those of each brick's
    block k overlap within the cell ``cells[brick]`` it is drawn in (its own, or a finer one of a
    single level), c of them at most (valid: one of them), for the m blocks k of the brick that
    overlap the cell (a coarser brick drawn in a finer cell: only those few, not all n)."""
    xyz = 2 - axis
    base, own = source.levels[0], source.levels[level]
    # the level's voxel coordinate u (centres at integers) -> level-0 coordinate t * dims0
    ratio = float(own.spacing[xyz]) / float(base.spacing[xyz])
    shift = (float(own.origin[xyz]) - float(base.origin[xyz])) / float(base.spacing[xyz]) + 0.5
    index = keys[:, 1 + axis]
    start = np.asarray(table_of(source).spans[level][axis][0], dtype=np.float64)[index]  # the cores' first voxels
    span = float(geometry.spans[int(cells[0, 0]) if len(cells) else level][xyz])
    cell = cells[:, 1 + axis]
    lo, hi = (cell * span)[:, None], np.minimum((cell + 1) * span, float(geometry.dims0[xyz]))[:, None]  # level-0 voxels
    a = (start[:, None] + BLOCK * np.arange(n) - 0.5) * ratio + shift  # the samples of block k: [a, b)
    b = a + BLOCK * ratio
    a, b = np.maximum(a, lo), np.minimum(b, hi)
    inside = a < b  # the blocks in the cell (a smaller brick's past its core: none)
    count = inside.sum(axis=1)
    m = max(int(count.max(initial=0)), 1)
    k = np.minimum(np.argmax(inside, axis=1)[:, None] + np.arange(m), n - 1)  # (contiguous)
    rows = np.arange(len(k))[:, None]
    a, b, inside = a[rows, k], b[rows, k], inside[rows, k] & (np.arange(m) < count[:, None])
    if level > 0:  # past the cell's faces only (inside it the next block bounds the same samples)
        a, b = np.where(a <= lo, a - EDGE, a), np.where(b >= hi, b + EDGE, b)
    first = np.maximum(np.floor(a / block).astype(np.int64), 0)
    last = np.minimum(np.ceil(b / block).astype(np.int64) - 1, -(-int(geometry.dims0[xyz]) // block) - 1)
    last = np.where(inside, last, first - 1)
    c = max(int((last - first).max(initial=0)) + 1, 1)
    g = first[:, :, None] + np.arange(c)
    return np.minimum(g, np.maximum(last[:, :, None], 0)), g <= last[:, :, None], k


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
