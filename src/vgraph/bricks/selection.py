"""Which bricks a frame of the bricked ray caster draws, at which level, in which order.

Conventions (docs/explanations/bricked-ray-casting.md):
- The bricks are cells of the pyramid's octree, each owning a half-open box of the samples
  (vgraph.bricks.brick_geometry); the selection walks the octree from the coarsest level down, so
  the chosen cells ("bricks") tile the volume whatever their levels. Each brick's level is the one
  its footprint asks for (vgraph.bricks.level_tables), at least ``floor_level``; ``plan_frame``
  raises floor_level until the frame fits the budget.
- Empty bricks: the per-brick ranges of the brick's level (``brick_ranges``), widened to the 3^3
  neighbouring bricks (a sample inside a brick filters voxels up to one voxel outside it),
  normalised by the value range (a cell is empty when every brick its core touches is): dvr
  drops bricks whose whole range has no LUT opacity
  (empty_space.occupied_blocks, the RayCaster's skipping rule), iso those whose maximum is below the
  level, mip those whose maximum is <= 0.
- Order: front to back, the grid's sweep order (tetrahedra.cells.axis_order, reversed) at the top
  and for each brick's children, valid for orthographic and perspective cameras; the walk goes a
  whole level at a time on arrays and sorts the cells it keeps by their place in that recursive
  order (vgraph.bricks.walk_order). Brick bytes, geometry and normalised ranges are made once per
  source (vgraph.derived), not per frame.
- Coarse first (a ``LoadLimit``, the GUI's): when the plan's bricks not yet in the cache cannot be
  read within the limit, ``coarse_first`` draws the plan of the finest coarser floor level whose
  missing bricks can (the budget fallback's walk, one floor level up at a time); the plan's own
  bricks are read ahead for the next frames.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from vgraph import derived
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.cache import LoadLimit, bricks_bytes, usable_range
from vgraph.bricks.level_tables import LevelTables, joined_levels
from vgraph.bricks.pyramid import BrickSource
from vgraph.bricks.walk_order import children, joined_cells, top_cells
from vgraph.gl.raycasting.empty_space import occupied_blocks


class KeyArray:
    """Keys int64 [n, 4] as a value that compares by content (==, hash): what a frame keeps
    from the last (vgraph.bricks.kept_frame) asks whether the plan's bricks are the same in one
    array comparison, not a tuple or set of thousands of keys made a frame."""

    __slots__ = ("array", "_hash")

    def __init__(self, array: np.ndarray):
        self.array = array
        self.array.setflags(write=False)
        self._hash = None

    def __eq__(self, other) -> bool:
        return isinstance(other, KeyArray) and np.array_equal(self.array, other.array)

    def __hash__(self) -> int:
        if self._hash is None:
            self._hash = hash(self.array.tobytes())
        return self._hash


_KEY_BITS = 19  # bits per brick index in a packed key (levels need fewer); wider grids: rows sorted


def key_set(keys) -> KeyArray:
    """The set of ``keys`` (int64 [n, 4], or an iterable of key tuples) as a sorted array (one int64
    per key where every index fits _KEY_BITS bits, else the rows in lexicographic order): equal for
    the same bricks in any order."""
    keys = keys if isinstance(keys, np.ndarray) else np.asarray(list(keys), dtype=np.int64).reshape(-1, 4)
    if len(keys) == 0 or int(keys.max()) < 1 << _KEY_BITS:
        packed = ((keys[:, 0] << _KEY_BITS | keys[:, 1]) << _KEY_BITS | keys[:, 2]) << _KEY_BITS | keys[:, 3]
        return KeyArray(np.sort(packed))
    return KeyArray(keys[np.lexsort(keys.T[::-1])])


class FramePlan:
    """A frame's bricks, front to back: their keys (level, z, y, x) and scissor rectangles (x, y, w,
    h), as int64 arrays [n, 4] (``key_array``, ``rect_array``) and, made on first use, as Python
    tuples (``bricks``: [(key, rect)], ``keys()``): a frame of thousands of bricks that only
    compares its bricks with the last frame's (key_set, key_sequence) or reads their levels makes
    no tuple per brick. ``floor_level``: the finest level the budget allowed; ``bytes``: the
    bricks' with halo; ``select(floor level)``: ((keys, rects) arrays, bytes) of the same walk at
    a coarser floor (its tables reused). Do not change what it returns."""

    def __init__(self, bricks=(), floor_level: int = 0, nbytes: int = 0, select: Callable | None = None,
                 arrays: tuple[np.ndarray, np.ndarray] | None = None):
        if arrays is None:
            bricks = list(bricks)
            arrays = tuple(np.asarray([brick[i] for brick in bricks], dtype=np.int64).reshape(-1, 4) for i in (0, 1))
            self._bricks = bricks
        else:
            self._bricks = None
        self.key_array, self.rect_array = arrays
        self.floor_level, self.bytes, self.select = floor_level, nbytes, select
        self._keys = self._set = self._sequence = None

    def __len__(self) -> int:
        return len(self.key_array)

    def __repr__(self) -> str:
        return f"FramePlan({len(self)} bricks, floor_level={self.floor_level}, bytes={self.bytes})"

    @property
    def bricks(self) -> list:
        """[(key, rect)] as Python ints, front to back."""
        if self._bricks is None:
            self._bricks = brick_list(self.key_array, self.rect_array)
        return self._bricks

    def keys(self) -> list:
        """The bricks' keys as tuples, front to back."""
        if self._keys is None:
            self._keys = ([key for key, _ in self._bricks] if self._bricks is not None
                          else list(zip(*self.key_array.T.tolist())) if len(self) else [])
        return self._keys

    def key_set(self) -> KeyArray:
        """The set of the bricks' keys, comparable with another plan's (any order)."""
        if self._set is None:
            self._set = key_set(self.key_array)
        return self._set

    def key_sequence(self) -> KeyArray:
        """The bricks' keys in their order, comparable with another plan's."""
        if self._sequence is None:
            self._sequence = KeyArray(self.key_array)
        return self._sequence

    def levels(self) -> list:
        """The levels the plan's bricks are at, ascending."""
        return np.unique(self.key_array[:, 0]).tolist()

    def at_floor(self, floor_level: int, source: BrickSource) -> FramePlan:
        """This frame's plan with ``floor_level`` as the finest level allowed."""
        arrays, nbytes = self.select(floor_level)
        return FramePlan((), floor_level, nbytes, self.select, arrays)


@dataclass
class LeafPass:
    """One task of the leaves split (vgraph.distributed.leaves) in a BrickedRayCaster frame, given
    as the frame context's ``leaf`` (vgraph.frame_context; None: the whole frame, as always).
    In: ``bricks`` (key, rect), front to back, drawn instead of the plan's ([]: none, only plan),
    or ``accumulated``, the (sum, first) accumulation of all the frame's bricks, composited on the
    workers, resolved instead of drawing any. Out: ``plan`` (the frame's FramePlan) and
    ``partial``, the (sum, first) accumulation of ``bricks`` before the resolve pass: float32
    [H, W, 4] arrays, row 0 at the bottom (GL's order; only composited per pixel)."""

    bricks: list | None = None
    accumulated: tuple | None = None
    plan: FramePlan | None = field(default=None, repr=False)
    partial: tuple | None = field(default=None, repr=False)



# --- emptiness ------------------------------------------------------------------------------------
def normalised_ranges(source: BrickSource, level: int, value_range=None) -> tuple[np.ndarray, np.ndarray]:
    """Per-brick [z, y, x] min and max of normalised intensity over each brick and its neighbours;
    a brick without finite voxels counts as 0 (non-finite voxels are uploaded clamped); one whose
    range is unknown (-inf, +inf: a level too large to read for its ranges) as everything. Made
    once per source, range and level (vgraph.derived; a source's brick ranges do not change), read-only."""
    lo, hi = usable_range(value_range if value_range is not None else source.value_range)
    per_level = derived.value(source, "normalised brick ranges", dict, params=(lo, hi))
    if level not in per_level:
        per_level[level] = _normalised_ranges(source, level, lo, hi)
    return per_level[level]


def _normalised_ranges(source: BrickSource, level: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    low, high = source.brick_ranges(level)
    low = np.where(np.isfinite(low), (low - lo) / (hi - lo), 0.0)
    high = np.where(np.isnan(high), 0.0, (high - lo) / (hi - lo))  # +inf: clipped where used
    ranges = (ndimage.minimum_filter(low, size=3, mode="nearest"), ndimage.maximum_filter(high, size=3, mode="nearest"))
    for values in ranges:
        values.setflags(write=False)
    return ranges


def visible_bricks(source: BrickSource, level: int, mode: str, alpha=None, iso_level: float = 0.5,
                   value_range=None) -> np.ndarray:
    """Bool per brick [z, y, x] of ``level``: whether it can contribute in ``mode``."""
    low, high = normalised_ranges(source, level, value_range)
    if mode == "dvr":
        return occupied_blocks(low, high, alpha)
    if mode == "iso":
        return high >= iso_level
    return high > 0.0  # mip: intensities are clamped to [0, 1]; 0 adds nothing to the maximum


# --- the walk ----------------------------------------------------------------------------------------
def select_bricks(source: BrickSource, camera, size, view_projection, visible, lod_bias: float,
                  floor_level: int = 0, geometry: BrickGeometry | None = None,
                  tables: LevelTables | None = None, too_coarse: Callable[[int], np.ndarray] | None = None) -> list:
    """(key, rect) of the bricks to draw, front to back (see the module docstring). ``visible(level)``
    is the bool [z, y, x] array of bricks that can contribute at that level; ``too_coarse(level)``,
    where given, the bool [z, y, x] array of cells of that level to refine whatever their footprint
    (their error bound is over the frame's share, plan_frame), down to ``floor_level``."""
    keys, rects = selected_arrays(source, camera, size, view_projection, visible, lod_bias, floor_level, geometry,
                                  tables, too_coarse)
    return brick_list(keys, rects)


def brick_list(keys: np.ndarray, rects: np.ndarray) -> list:
    """[(key, rect)] of the arrays of selected_arrays, as Python ints."""
    return list(zip(zip(*keys.T.tolist()), zip(*rects.T.tolist())))  # columns: no list per brick


def selected_arrays(source: BrickSource, camera, size, view_projection, visible, lod_bias: float,
                    floor_level: int = 0, geometry: BrickGeometry | None = None,
                    tables: LevelTables | None = None,
                    too_coarse: Callable[[int], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """select_bricks as arrays: keys int64 [n, 4] (level, z, y, x) and rects int64 [n, 4], front to
    back. The walk goes down the octree a whole level at a time: the cells of a level that are
    refined give their children, those that stay are kept with their place in the order. The place
    is the walk's: the rank of the top cell in the grid's front-to-back order, then at each level
    the rank of the cell among its parent's children (front_to_back of that block, axis_ranks per
    axis, z before y before x), digits of one mixed-radix number; a cell kept at a coarser level
    has zeros below (no kept cell is another's ancestor, so no two numbers tie) and one argsort of
    the numbers is the order of the recursive walk."""
    geometry = geometry or BrickGeometry.of(source)
    tables = tables or LevelTables(geometry, camera, size, view_projection, visible, lod_bias)
    perspective = camera.projection == "perspective"
    forward = camera.basis()[2]
    kept_keys, kept_rects, kept_order = [], [], []
    # the small levels at the top whole (walk_order.JoinedCells), then level by level on the cells reached
    z, y, x, order, start = _joined_walk(geometry, tables, camera, forward, perspective, floor_level, too_coarse,
                                         (kept_keys, kept_rects, kept_order))
    for level in range(start, -1, -1):
        if len(z) == 0:
            break
        rects = tables(level, "rects")[z, y, x]
        on_screen = rects[:, 2] != 0
        wants = tables(level, "wants")[z, y, x]
        # level > min(max(wants, floor_level, 0), top), level <= top: in fewer of numpy's calls
        refined = on_screen & (wants < level) if level > max(floor_level, 0) else np.zeros(len(z), dtype=bool)
        rest = on_screen & ~refined
        if too_coarse is not None and level > floor_level and rest.any():
            refined |= rest & too_coarse(level)[z, y, x]
            rest &= ~refined
        if rest.any():
            rest &= tables(level, "visible")[z, y, x]
            _keep(geometry, level, (z[rest], y[rest], x[rest]), rects[rest], order[rest],
                  (kept_keys, kept_rects, kept_order))
        if level > 0:
            z, y, x, order = children(geometry, camera, forward, perspective, level, z[refined], y[refined],
                                      x[refined], order[refined])
    if not kept_keys:
        return np.zeros((0, 4), dtype=np.int64), np.zeros((0, 4), dtype=np.int64)
    front_first = np.argsort(np.concatenate(kept_order), kind="stable")
    return (np.concatenate(kept_keys).astype(np.int64)[front_first],
            np.concatenate(kept_rects).astype(np.int64)[front_first])


def _keep(geometry: BrickGeometry, level: int, cells, rects, order, kept) -> None:
    """Append the kept cells (z, y, x) of ``level``, their rectangles and order numbers to ``kept``
    (keys, rects, numbers); the numbers padded with zeros for the levels below, as if the cells were
    walked down to level 0."""
    below = math.prod(int(np.prod(geometry.ratios[k])) for k in range(1, level + 1))
    kept[0].append(np.stack([np.full(len(cells[0]), level), *cells], axis=1))
    kept[1].append(rects)
    kept[2].append(order * below)


def _joined_walk(geometry: BrickGeometry, tables: LevelTables, camera, forward, perspective: bool, floor_level: int,
                 too_coarse, kept):
    """selected_arrays' walk over the levels from joined_levels up, each level whole: a cell is
    reached where every ancestor was refined. Keeps (``kept``) what it chooses there; returns the
    cells (z, y, x), order numbers and level the walk goes on with (the children of the finest
    joined level's refined cells; none: level -1)."""
    top = len(geometry.grids) - 1
    if joined_levels(geometry) > top:  # not even the top level is small: the top cells, level by level
        return (*top_cells(geometry, camera, forward, perspective), top)
    joined = joined_cells(geometry)
    digits = joined.digits(geometry, camera, forward, perspective)
    rects_all, wants_all = tables.joined("rects"), tables.joined("wants")
    reached = order = None
    for level in range(top, joined.first_level - 1, -1):
        cells = joined.cells(level)
        parent = joined.parent[cells]
        order = digits[cells] if order is None else order[parent] * joined.radix[level - joined.first_level] + digits[cells]
        rects = rects_all[cells]
        here = rects[:, 2] != 0
        if reached is not None:
            here &= reached[parent]
        refined = here & (wants_all[cells] < level) if level > max(floor_level, 0) else np.zeros(len(here), dtype=bool)
        rest = here & ~refined
        if too_coarse is not None and level > floor_level and rest.any():
            refined |= rest & too_coarse(level).ravel()
            rest &= ~refined
        if rest.any():
            rest &= tables(level, "visible").ravel()
            _keep(geometry, level, (joined.z[cells][rest], joined.y[cells][rest], joined.x[cells][rest]), rects[rest],
                  order[rest], kept)
        if not refined.any():
            return None, None, None, None, -1
        reached = refined
    level = joined.first_level
    if level == 0:
        return None, None, None, None, -1
    cells = joined.cells(level)
    z, y, x = (axis[cells][reached] for axis in (joined.z, joined.y, joined.x))
    return (*children(geometry, camera, forward, perspective, level, z, y, x, order[reached]), level - 1)


def plan_frame(source: BrickSource, camera, size, view_projection, visible, lod_bias: float,
               budget_bytes: int, errors=None, max_error: float = 1.0, finest_level: int = 0) -> FramePlan:
    """The frame's bricks at the finest levels, none finer than ``finest_level`` (clamped to the
    coarsest), whose bricks fit ``budget_bytes`` together; raises ValueError when not even the
    coarsest level fits. With ``errors`` (a lod_error.LodErrors) and
    ``max_error`` < 1, a cell is also refined where its error bound is over a share of
    ``max_error``: the share starts at max_error and is divided by 8, then 0, until the frame's bound is
    within max_error (at share 0 every cell that can move a pixel is refined down to the floor)."""
    geometry = BrickGeometry.of(source)
    tables = LevelTables(geometry, camera, size, view_projection, visible, lod_bias)

    def select_at(floor_level: int, share: float | None) -> tuple[np.ndarray, np.ndarray]:
        over: dict = {}  # level -> cells whose bound is over the share

        def too_coarse(level: int) -> np.ndarray:
            if level not in over:
                over[level] = errors(level) > share
            return over[level]

        return selected_arrays(source, camera, size, view_projection, visible, lod_bias, floor_level, geometry,
                               tables, None if share is None else too_coarse)

    def select(floor_level: int) -> tuple[tuple[np.ndarray, np.ndarray], int]:
        if errors is None or max_error >= 1.0:
            keys, rects = select_at(floor_level, None)
            return (keys, rects), bricks_bytes(source, keys)
        for share in (max_error, max_error / 8.0, 0.0):
            keys, rects = select_at(floor_level, share)
            if errors.frame_bound(brick_list(keys, rects), size) <= max_error:
                break
        return (keys, rects), bricks_bytes(source, keys)

    for floor_level in range(min(finest_level, len(source.levels) - 1), len(source.levels)):
        arrays, total = select(floor_level)
        if total <= budget_bytes:
            return FramePlan((), floor_level, total, select, arrays)
    raise ValueError(f"the {len(arrays[0])} bricks of the coarsest level need {total / 2**20:.2f} MB "
                     f"but the budget is {budget_bytes / 2**20:.2f} MB")


def coarse_first(source: BrickSource, plan: FramePlan, resident: set, limit: LoadLimit,
                 seconds_per_byte: float | None, budget_bytes: int) -> FramePlan:
    """The plan to draw now under a load limit: ``plan`` if its bricks not in ``resident`` can be
    read within ``limit``, else the plan of the finest coarser floor level whose missing bricks can
    (the coarsest if none can: a frame needs some bricks). The coarser frame's bricks and the
    plan's resident ones are pinned together while it is drawn (so drawing never evicts what
    was read ahead); when they do not fit ``budget_bytes`` together, ``plan`` is drawn whole."""
    for floor_level in range(plan.floor_level, len(source.levels)):
        candidate = plan if floor_level == plan.floor_level else plan.at_floor(floor_level, source)
        missing = [key for key in candidate.keys() if key not in resident]
        if limit.allows(len(missing), bricks_bytes(source, missing), seconds_per_byte):
            break
    if candidate is plan or candidate.key_set() == plan.key_set():
        return plan
    pinned = set(candidate.keys()) | (set(plan.keys()) & resident)
    return candidate if bricks_bytes(source, pinned) <= budget_bytes else plan
