"""How far a ray of the single pass jumps or runs from a block of the brick atlas (issue #33;
bricks/paged_sampling.glsl, in_empty_block; vgraph.bricks.atlas_blocks holds the blocks' ranges).

Conventions:
- Distances per octant of ray directions (the signs of x, y, z): a ray only leaves a box through
  the faces ahead of it, so a box that reaches ahead from the block is all it needs (the
  anisotropic Chebyshev distances of Deakin and Knackstedt 2020). For the octant s, block b's value
  is k >= 1 where the block adds nothing this frame and so does every block of the box from b to
  b + s (k - 1) *in the volume*, at the block's own level (a ray jumps to where it leaves that box,
  across the faces of its cell); -k where every block of that box in b's slot may add something
  (one run spans it; the shader cuts runs at the run's level-0 cell, whose slot they read).
- Laid out as AtlasBlocks.laid_out, the octants side by side in 2 x 2 x 2: the octant whose ray
  goes down x (y, z) at the second half along x (y, z).
- A box reaches into a neighbouring cell only where that cell is drawn wholly from a brick of the
  same level whose blocks continue the same grid (every core of the level but the last along an
  axis is a whole number of blocks, and the cells lie in a box of at most ``BOX_CELLS`` times as
  many cells as are drawn; else each slot's boxes stay in its own cell), or, at level 0, where
  the plan leaves the cell out (it adds nothing: the leaf table says so, ``empty_cells``). Blocks
  of cells drawn otherwise (coarser, finer, missing) count as occupied.
- A slot not drawn wholly from its own brick this frame (a coarse brick that stands in for missing
  finer ones, a brick kept from an earlier frame) has no empty block: a jump there could cross
  cells drawn from finer bricks, or missing ones unasked. Nor has a block that reaches past its
  cell's core (a core that is no whole number of blocks), except at the volume's end.
- But in a frame whose every box ends at its level-0 cell (``stand_ins``: dvr's frames that ask,
  bricks/paged_sampling.glsl's cut) a jump never leaves the level-0 cell it starts in, which is
  drawn wholly from the slot the ray reads there: such a slot's empty blocks (its own data's
  ranges, what is drawn there) are jumped within its cell as a wholly drawn one's are.
"""

from __future__ import annotations

import itertools

import numpy as np

from vgraph.bricks.cache import BLOCK

BOX_CELLS = 8  # a level's boxes cross cells only while the box of its drawn cells is at most this many times as many
FARTHEST = 8   # the largest distance kept (a cell of 64^3 voxels): each one more costs a pass over the blocks
OCTANTS = list(itertools.product((1, -1), repeat=3))  # the signs of (z, y, x), z slowest


def block_radii(blocks, skip: np.ndarray, slots: dict, drawn, spans, empty_cells=None, rule=None,
                stand_ins: bool = False) -> np.ndarray:
    """float32 [2 z, 2 y, 2 x] laid out as the slots, per octant (module docstring). ``blocks``: the
    atlas's AtlasBlocks; ``skip`` bool [slot, bz, by, bx], the blocks that add nothing under the
    frame's rule (unknown ones False); ``slots`` brick key -> slot; ``drawn`` the keys drawn wholly
    from their own brick (the plan's resident ones); ``spans[level]`` per axis [z, y, x] the cores'
    (starts, stops) in the level's voxels (vgraph.bricks.cells); ``empty_cells`` (or None) bool
    [z, y, x] per level-0 cell, True where nothing is drawn and nothing is missing (the plan leaves
    it out: it adds nothing), whose blocks a box at level 0 may cross. ``rule`` (hashable, or None):
    what ``skip`` was made by from the slots' ranges (the mode and its TF or level); given, each
    wholly drawn slot's distances within its cell are kept with the slot (AtlasBlocks.of_slot) and
    made again only for slots whose brick, rule or grouping changed (_within_slots). ``stand_ins``:
    every box of the frame ends at its level-0 cell, so slots not drawn wholly skip their empty
    blocks within their own cell too (module docstring)."""
    whole = wholly_drawn(len(skip), slots, drawn)
    own = wholly_drawn(len(skip), slots, slots) if stand_ins else whole  # the slots whose empty blocks count
    jumpable = skip & own[:, None, None, None]
    per = np.asarray(skip.shape[1:])  # [z, y, x]
    groups = []  # (level, slots, coords): the slots of a level whose boxes cross cells together
    by_level: dict = {}
    for key, slot in slots.items():
        if key in drawn:
            by_level.setdefault(int(key[0]), []).append((np.asarray(key[1:], dtype=np.int64), slot))
    for level, cells in by_level.items():
        starts, stops = [np.asarray(s[0]) for s in spans[level]], [np.asarray(s[1]) for s in spans[level]]
        coords = np.stack([cell for cell, _ in cells])
        mine = np.asarray([slot for _, slot in cells])
        if _aligned(starts, stops, per) and _box_fits(coords):
            groups.append((level, mine, coords))
        else:
            jumpable[mine] &= _inside_cores(coords, starts, stops, per)
    grids = [(mine, coords, _volume_grid(jumpable[mine], coords, per, empty_cells if level == 0 else None))
             for level, mine, coords in groups]
    grouped = np.zeros(len(skip), dtype=bool)
    for mine, _, _ in grids:
        grouped[mine] = True
    values = _within_slots(blocks, jumpable, whole, own, grouped, slots, rule)
    for mine, coords, grid in grids:  # (radii - runs: whole numbers, exact in either order)
        for octant, signs in enumerate(OCTANTS):
            values[mine, octant] += _cells_of(forward_distances(grid, signs), coords, per)
    return _octants_laid_out(blocks, values)


def _within_slots(blocks, jumpable: np.ndarray, whole: np.ndarray, own: np.ndarray, grouped: np.ndarray,
                  slots: dict, rule):
    """float32 [slot, octant, bz, by, bx]: each slot's radii within its cell (0 in ``grouped``
    slots, whose boxes cross cells: block_radii adds them) less its runs. A slot not ``own`` has
    none jumpable and runs over all its blocks (the same for every such slot); an own one's
    depend only on its brick's blocks, the rule, whether it is grouped and whether it is drawn
    wholly (its jumpable blocks: ``skip`` under the rule, and in a level not grouped those inside
    its cell's core, fixed by the brick's cell; a stand-in's: all its ``skip``), so with a
    ``rule`` they are kept with the slot under those (one entry a slot: a new rule replaces the
    last one's; a stand-in's is never taken for the same brick drawn wholly) and only new ones
    made."""
    shape = jumpable.shape[1:]
    values = np.empty((len(jumpable), len(OCTANTS)) + shape, dtype=np.float32)
    occupied = np.ones((1,) + shape, dtype=bool)
    values[~own] = np.stack([-_within_cells(occupied, signs)[0] for signs in OCTANTS])
    todo, keys = [], []
    for key, slot in slots.items():
        if not own[slot]:
            continue
        memo_key = (key, rule, bool(grouped[slot]), not whole[slot])
        kept = blocks.of_slot(slot).get("block radii") if rule is not None else None
        if kept is not None and kept[0] == memo_key:
            values[slot] = kept[1]
        else:
            todo.append(slot)
            keys.append(memo_key)
    if todo:
        mine = np.asarray(todo)
        mask = jumpable[mine]
        alone = mask & ~grouped[mine, None, None, None]
        for octant, signs in enumerate(OCTANTS):
            values[mine, octant] = _within_cells(alone, signs) - _within_cells(~mask, signs)
        if rule is not None:
            for slot, memo_key in zip(todo, keys):
                blocks.of_slot(slot)["block radii"] = (memo_key, values[slot].copy())
    return values


def _octants_laid_out(blocks, values: np.ndarray) -> np.ndarray:
    """The per-slot octants [slot, octant, bz, by, bx] laid out as AtlasBlocks.laid_out, the octants
    side by side in 2 x 2 x 2 (OCTANTS: z slowest, +1 first), float32 [2 z, 2 y, 2 x]."""
    gx, gy, gz = blocks.slot_grid
    bz, by, bx = values.shape[2:]
    out = np.empty((2, gz, bz, 2, gy, by, 2, gx, bx), dtype=np.float32)
    octants = values.reshape(gz, gy, gx, 2, 2, 2, bz, by, bx)
    for oz, oy, ox in itertools.product(range(2), repeat=3):
        out[oz, :, :, oy, :, :, ox, :, :] = octants[:, :, :, oz, oy, ox].transpose(0, 3, 1, 4, 2, 5)
    return out.reshape(2 * gz * bz, 2 * gy * by, 2 * gx * bx)


def wholly_drawn(count: int, slots: dict, drawn) -> np.ndarray:
    """bool per slot: whether its brick is one of ``drawn``."""
    whole = np.zeros(count, dtype=bool)
    for key, slot in slots.items():
        whole[slot] = key in drawn
    return whole


def _aligned(starts, stops, per) -> bool:
    """Whether every core of the level but the last along each axis is ``per`` blocks, end to end."""
    for axis in range(3):
        width = int(per[axis]) * BLOCK
        expected = starts[axis][0] + width * np.arange(len(starts[axis]))
        if not (np.array_equal(starts[axis], expected) and np.all(stops[axis][:-1] - starts[axis][:-1] == width)):
            return False
    return True


def _box_fits(coords: np.ndarray) -> bool:
    box = coords.max(axis=0) - coords.min(axis=0) + 1
    return int(np.prod(box)) <= BOX_CELLS * len(coords)


def _volume_grid(mask: np.ndarray, coords: np.ndarray, per: np.ndarray, empty_cells=None) -> np.ndarray:
    """The blocks of cells ``coords`` [n, (z, y, x)] (``mask`` [n, bz, by, bx]) laid side by side as
    in the volume over the cells' box, cells not among them False but those of ``empty_cells``
    (bool [z, y, x] over the level's cells, or None) True, with a border of False."""
    low = coords.min(axis=0)
    cells = coords - low
    box = tuple(int(n) for n in cells.max(axis=0) + 1)
    tiles = np.zeros(box + mask.shape[1:], dtype=bool)
    if empty_cells is not None:
        tiles[empty_cells[tuple(slice(int(a), int(a) + n) for a, n in zip(low, box))]] = True
    tiles[tuple(cells.T)] = mask
    return np.pad(tiles.transpose(0, 3, 1, 4, 2, 5).reshape(tuple(np.asarray(box) * per)), 1)


def _cells_of(grid: np.ndarray, coords: np.ndarray, per: np.ndarray) -> np.ndarray:
    """The inverse of _volume_grid: the values [n, bz, by, bx] of the cells ``coords``."""
    cells = coords - coords.min(axis=0)
    inner = grid[1:-1, 1:-1, 1:-1]
    box = np.asarray(inner.shape) // per
    tiles = inner.reshape(box[0], per[0], box[1], per[1], box[2], per[2]).transpose(0, 2, 4, 1, 3, 5)
    return tiles[tuple(cells.T)]


def _within_cells(mask: np.ndarray, signs) -> np.ndarray:
    """The distances of each slot's blocks [n, bz, by, bx] within its own cell (each tile padded
    with False, the tiles stacked along z)."""
    padded = np.pad(mask, ((0, 0), (1, 1), (1, 1), (1, 1)))
    n, pz, py, px = padded.shape
    distance = forward_distances(padded.reshape(n * pz, py, px), signs).reshape(padded.shape)
    return distance[:, 1:-1, 1:-1, 1:-1]


def forward_distances(mask: np.ndarray, signs, farthest: int = FARTHEST) -> np.ndarray:
    """float32 per element of the bool [z, y, x] ``mask``: the largest k <= ``farthest`` such that the
    box from it to it + signs * (k - 1) is all True (0 where False; what lies past the array counts
    as False). The box of side k + 1 at b is the union of those of side k at b and b + signs along
    each axis, so k rounds of three shifted ANDs."""
    distance = np.zeros(mask.shape, dtype=np.uint8 if farthest < 256 else np.int32)
    box = mask.copy()
    for _ in range(farthest):
        if not box.any():
            break
        distance += box
        for axis, sign in enumerate(signs):
            box &= _shifted(box, axis, sign)
    return distance.astype(np.float32)


def _shifted(mask: np.ndarray, axis: int, sign: int) -> np.ndarray:
    """mask[b + sign along axis], False past the end."""
    out = np.zeros_like(mask)
    ahead = [slice(None)] * 3
    here = [slice(None)] * 3
    if sign > 0:
        here[axis], ahead[axis] = slice(0, -1), slice(1, None)
    else:
        here[axis], ahead[axis] = slice(1, None), slice(0, -1)
    out[tuple(here)] = mask[tuple(ahead)]
    return out


def _inside_cores(coords: np.ndarray, starts, stops, per: np.ndarray) -> np.ndarray:
    """bool [n, bz, by, bx]: the blocks that lie inside their cell's core, or past it only at the
    volume's end (a core of no whole number of blocks: a block reaching past it covers part of the
    next cell, which a jump must not cross)."""
    inside = np.ones((len(coords),) + tuple(int(p) for p in per), dtype=bool)
    for axis in range(3):
        core = stops[axis][coords[:, axis]] - starts[axis][coords[:, axis]]
        last = coords[:, axis] == len(starts[axis]) - 1
        ends = (np.arange(int(per[axis])) + 1) * BLOCK
        ok = (ends[None, :] <= core[:, None]) | last[:, None]
        shape = [len(coords), 1, 1, 1]
        shape[1 + axis] = int(per[axis])
        inside &= ok.reshape(shape)
    return inside
