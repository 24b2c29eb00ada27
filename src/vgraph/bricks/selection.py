"""Which bricks a frame of the bricked ray caster draws, at which level, in which order.

Conventions (docs/explanations/bricked-ray-casting.md):
- The pyramid is an octree of cells (vgraph.bricks.cells): cell b of level L covers level-0 voxels
  [b * B * f_L, (b + 1) * B * f_L) per axis (B the brick size, f_L the level's factor: 2^L where
  every level halves every axis, 1 along an axis the pyramid keeps), exactly its children at level
  L - 1, and reads the level-L voxels that cover that region. The selection walks it from the
  coarsest level down, so the chosen cells ("bricks") tile the volume whatever their levels.
- A brick *owns* the samples whose level-0 texture coordinate t lies in [j_lo / n, j_hi / n) per
  axis (j the level-0 voxel bounds above, n the level-0 voxels): half-open, so each sample of the
  global lattice lies in exactly one brick; the volume's outer faces are pushed to +-OUTSIDE so
  samples on (or a rounding beyond) the box still have an owner.
- Level per brick: a level-0 voxel (its longest edge) projects to p pixels at the brick's
  nearest point; the brick wants the coarsest level L with cells.coarseness[L] <= -log2(p) +
  lod_bias (floor(-log2(p) + lod_bias) where every level halves every axis: voxels of about a
  pixel at lod_bias 0), clamped to the pyramid and to at least ``floor_level``; ``plan_frame``
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
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from vgraph import derived
from vgraph.bricks.cache import LoadLimit, bricks_bytes, usable_range
from vgraph.bricks.cells import cell_factors, cell_grid, cells_of_bricks, coarseness
from vgraph.bricks.pyramid import BrickSource
from vgraph.bricks.walk_order import children, top_cells
from vgraph.gl.raycasting.empty_space import occupied_blocks

OUTSIDE = 1e6  # texture coordinate of the volume's outer faces in the ownership test


@dataclass
class FramePlan:
    bricks: list = field(default_factory=list)  # (key, (x, y, w, h) scissor rect), front to back
    floor_level: int = 0                        # the finest level the budget allowed
    bytes: int = 0                              # the frame's bricks with halo
    # floor level -> (the bricks at that floor, their bytes) (the same walk, its tables reused): coarser plans
    select: Callable[[int], tuple[list, int]] | None = field(default=None, repr=False, compare=False)
    _keys: list | None = field(default=None, init=False, repr=False, compare=False)

    def at_floor(self, floor_level: int, source: BrickSource) -> FramePlan:
        """This frame's plan with ``floor_level`` as the finest level allowed."""
        bricks, nbytes = self.select(floor_level)
        return FramePlan(bricks, floor_level, nbytes, self.select)

    def keys(self) -> list:
        """The bricks' keys, front to back (made once: a frame asks several times; do not change it)."""
        if self._keys is None:
            self._keys = [key for key, _ in self.bricks]
        return self._keys


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


class BrickGeometry:
    """Where a source's bricks are: level-0 voxel bounds, world boxes and ownership bounds.
    ``BrickGeometry.of(source)``: the one kept per source (vgraph.derived), which holds the source
    weakly (a kept value must not keep its source alive)."""

    def __init__(self, source: BrickSource, weak: bool = False):
        base = source.levels[0]
        self._source = weakref.ref(source) if weak else (lambda: source)
        self.dims0 = np.asarray(base.shape[::-1], dtype=np.float64)      # (x, y, z)
        self.spacing0 = np.asarray(base.spacing, dtype=np.float64)
        self.origin0 = np.asarray(base.origin, dtype=np.float64)
        self.brick = np.asarray(source.brick, dtype=np.float64)          # (x, y, z)
        factors = [np.asarray(f, dtype=np.int64) for f in cell_factors(source)]
        self.spans = [self.brick * f for f in factors]                   # level-0 voxels per cell
        self.ratios = [None] + [b // a for a, b in zip(factors, factors[1:])]  # children per axis
        self.grids = [np.asarray(cell_grid(source, k)[::-1]) for k in range(len(source.levels))]
        self.coarseness = coarseness(source)
        # Level-0 samples per sample of each level (brick_span.glsl): the level's smallest cell
        # edge over level 0's smallest voxel edge, whole (2^L where every axis halves).
        finest = float(self.spacing0.min())
        self.strides = [max(1, int(math.floor(float((f * self.spacing0).min()) / finest + 1e-9))) for f in factors]
        self.per_brick: dict = {}  # key -> the brick's uniforms (targets.brick_uniforms), made once
        self.per_level: dict = {}  # (what, level) -> a level's boxes and corners (kept_per_level)

    @staticmethod
    def of(source: BrickSource) -> BrickGeometry:
        """The geometry of ``source``, made once per source (vgraph.derived)."""
        return derived.value(source, "brick geometry", lambda: BrickGeometry(source, weak=True))

    @property
    def source(self) -> BrickSource:
        return self._source()

    def voxel_bounds(self, key) -> tuple[np.ndarray, np.ndarray]:
        """Level-0 voxel bounds [lo, hi) (x, y, z) of a brick, hi clipped to the volume."""
        level, index = key[0], np.asarray(key[1:][::-1], dtype=np.float64)
        span = self.spans[level]
        return index * span, np.minimum((index + 1) * span, self.dims0)

    def owner_bounds(self, key) -> tuple[np.ndarray, np.ndarray]:
        """Texture-space bounds [lo, hi) of the samples the brick owns (see the module docstring)."""
        lo, hi = self.voxel_bounds(key)
        index = np.asarray(key[1:][::-1])
        t_lo = np.where(index == 0, -OUTSIDE, lo / self.dims0)
        t_hi = np.where(index == self.grids[key[0]] - 1, OUTSIDE, hi / self.dims0)
        return t_lo, t_hi

    def eye_in_bricks(self, eye, level: int) -> np.ndarray:
        """The eye's position in brick units of ``level`` (x, y, z)."""
        return ((np.asarray(eye) - self.origin0) / self.spacing0 + 0.5) / self.spans[level]


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


# --- per-level tables: boxes, level of detail, screen rectangles -----------------------------------
KEPT_CELLS = 1 << 15  # levels of at most this many cells keep their boxes and corners (8 MB at most)


def kept_per_level(geometry: BrickGeometry, what: str, level: int, make):
    """``make()`` for ``level``, kept in the geometry (one per source) where the level is small:
    the boxes and corners of a level depend on nothing else, so a frame need not make them again."""
    if math.prod(int(n) for n in geometry.grids[level]) > KEPT_CELLS:
        return make()
    key = (what, level)
    if key not in geometry.per_level:
        geometry.per_level[key] = make()
    return geometry.per_level[key]


def level_boxes(geometry: BrickGeometry, level: int) -> tuple[np.ndarray, np.ndarray]:
    """World boxes of the owned regions (inside the box of the voxel centres) of every brick of
    ``level``: arrays [bz, by, bx, 3] (x, y, z), read-only."""
    return kept_per_level(geometry, "boxes", level, lambda: _level_boxes(geometry, level))


def _level_boxes(geometry: BrickGeometry, level: int) -> tuple[np.ndarray, np.ndarray]:
    grid = geometry.grids[level]
    index = np.stack(np.meshgrid(*[np.arange(n) for n in grid[::-1]], indexing="ij"), axis=-1)[..., ::-1]
    span = geometry.spans[level]
    top = geometry.dims0 - 1.0
    lo = np.clip(index * span - 0.5, 0.0, top)
    hi = np.clip(np.minimum((index + 1) * span, geometry.dims0) - 0.5, 0.0, top)
    boxes = geometry.origin0 + lo * geometry.spacing0, geometry.origin0 + hi * geometry.spacing0
    for box in boxes:
        box.setflags(write=False)
    return boxes


def box_corners(geometry: BrickGeometry, level: int) -> np.ndarray:
    """The 8 corners of every box of level_boxes, homogeneous: [bz, by, bx, 8, 4], read-only."""
    def make() -> np.ndarray:
        lo, hi = level_boxes(geometry, level)
        corners = np.ones(lo.shape[:-1] + (8, 4))
        for i in range(8):
            for a in range(3):
                corners[..., i, a] = (lo, hi)[i >> a & 1][..., a]
        corners.setflags(write=False)
        return corners
    return kept_per_level(geometry, "corners", level, make)


def pixels_per_world(camera, size, distance):
    """Pixels per world unit at ``distance`` from the eye, in the full picture: a tile of it (a
    camera with a ``window``, vgraph.distributed) draws its bricks at the levels the picture does."""
    height = float(size[1])
    if camera.window is not None:
        _, _, bottom, top = camera.window
        height *= 2.0 / (top - bottom)  # the window spans top - bottom of the full view's 2 in NDC
    if camera.projection == "orthographic":
        return np.full(np.shape(distance), height / (2.0 * camera.parallel_scale))
    return height / (2.0 * np.maximum(distance, 1e-12) * math.tan(math.radians(camera.fov) / 2.0))


def desired_levels(geometry: BrickGeometry, camera, size, level: int, lod_bias: float) -> np.ndarray:
    """The level each brick of ``level`` asks for (module docstring), int [bz, by, bx]."""
    lo, hi = level_boxes(geometry, level)
    eye = np.asarray(camera.position, dtype=np.float64)
    distance = np.linalg.norm(np.maximum(np.maximum(lo - eye, eye - hi), 0.0), axis=-1)
    # The longest voxel edge: an anisotropic voxel is refined until its longest side is about a pixel.
    pixels = float(geometry.spacing0.max()) * pixels_per_world(camera, size, distance)
    allowed = -np.log2(np.maximum(pixels, 1e-30)) + lod_bias
    return np.searchsorted(geometry.coarseness[1:], allowed, side="right").astype(np.int64)


def screen_rects(geometry: BrickGeometry, view_projection, size, level: int) -> np.ndarray:
    """Pixel rectangles (x, y, w, h) covering each brick of ``level`` with one pixel of margin, int
    [bz, by, bx, 4]; w = 0 off screen; the whole viewport where a corner lies behind the eye."""
    clip = box_corners(geometry, level) @ np.asarray(view_projection, dtype=np.float64).T  # [..., 8, 4]
    w = clip[..., 3]
    behind = (w <= 1e-9).any(axis=-1)
    w = np.where(w > 1e-9, w, 1.0)
    rects = []
    for axis in range(2):  # each axis's corners contiguous: the min and max over 8 are the cost here
        pixel = (clip[..., axis] / w * 0.5 + 0.5) * float(size[axis])
        first = np.maximum(np.floor(pixel.min(axis=-1)) - 1, 0)
        last = np.minimum(np.ceil(pixel.max(axis=-1)) + 1, float(size[axis]))
        rects.append((first, np.maximum(last - first, 0)))
    rects = np.stack([rects[0][0], rects[1][0], rects[0][1], rects[1][1]], axis=-1)
    rects[behind] = (0, 0, size[0], size[1])
    rects[(rects[..., 2] == 0) | (rects[..., 3] == 0)] = 0
    return rects.astype(np.int64)


# --- the walk ----------------------------------------------------------------------------------------
class LevelTables:
    """Per-level rectangles, wanted levels and visibility of one frame, computed on first use."""

    def __init__(self, geometry: BrickGeometry, camera, size, view_projection, visible, lod_bias: float):
        self.geometry, self.camera, self.size = geometry, camera, size
        self.view_projection, self.visible, self.lod_bias = view_projection, visible, lod_bias
        self._tables: dict = {}

    def __call__(self, level: int, what: str) -> np.ndarray:
        if (level, what) not in self._tables:
            self._tables[level, what] = {
                "rects": lambda: screen_rects(self.geometry, self.view_projection, self.size, level),
                "wants": lambda: desired_levels(self.geometry, self.camera, self.size, level, self.lod_bias),
                "visible": lambda: cells_of_bricks(self.geometry.source, level, self.visible(level)),
            }[what]()
        return self._tables[level, what]


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
    top = len(source.levels) - 1
    perspective = camera.projection == "perspective"
    forward = camera.basis()[2]
    z, y, x, order = top_cells(geometry, camera, forward, perspective)
    kept_keys, kept_rects, kept_order = [], [], []
    for level in range(top, -1, -1):
        if len(z) == 0:
            break
        rects = tables(level, "rects")[z, y, x]
        on_screen = rects[:, 2] != 0
        wants = tables(level, "wants")[z, y, x]
        refined = on_screen & (level > np.minimum(np.maximum(np.maximum(wants, floor_level), 0), top))
        rest = on_screen & ~refined
        if too_coarse is not None and level > floor_level and rest.any():
            refined |= rest & too_coarse(level)[z, y, x]
            rest &= ~refined
        if rest.any():
            rest &= tables(level, "visible")[z, y, x]
            # Zeros for the levels below: the order number as if the cell were walked down to level 0.
            below = math.prod(int(np.prod(geometry.ratios[k])) for k in range(1, level + 1))
            kept_keys.append(np.stack([np.full(int(rest.sum()), level), z[rest], y[rest], x[rest]], axis=1))
            kept_rects.append(rects[rest])
            kept_order.append(order[rest] * below)
        if level > 0:
            z, y, x, order = children(geometry, camera, forward, perspective, level, z[refined], y[refined],
                                      x[refined], order[refined])
    if not kept_keys:
        return np.zeros((0, 4), dtype=np.int64), np.zeros((0, 4), dtype=np.int64)
    front_first = np.argsort(np.concatenate(kept_order), kind="stable")
    return (np.concatenate(kept_keys).astype(np.int64)[front_first],
            np.concatenate(kept_rects).astype(np.int64)[front_first])


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

    def select(floor_level: int) -> tuple[list, int]:
        if errors is None or max_error >= 1.0:
            keys, rects = select_at(floor_level, None)
            return brick_list(keys, rects), bricks_bytes(source, keys)
        for share in (max_error, max_error / 8.0, 0.0):
            keys, rects = select_at(floor_level, share)
            bricks = brick_list(keys, rects)
            if errors.frame_bound(bricks, size) <= max_error:
                break
        return bricks, bricks_bytes(source, keys)

    for floor_level in range(min(finest_level, len(source.levels) - 1), len(source.levels)):
        bricks, total = select(floor_level)
        if total <= budget_bytes:
            return FramePlan(bricks, floor_level, total, select)
    raise ValueError(f"the {len(bricks)} bricks of the coarsest level need {total / 2**20:.2f} MB "
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
    if candidate is plan or set(candidate.keys()) == set(plan.keys()):
        return plan
    pinned = set(candidate.keys()) | (set(plan.keys()) & resident)
    return candidate if bricks_bytes(source, pinned) <= budget_bytes else plan
