"""The per-level tables a frame's selection of bricks reads (vgraph.bricks.selection): the world
boxes of a level's bricks and their corners (kept per source where the level is small), the level
each brick asks for by its footprint, and its rectangle on the screen.

Conventions (docs/explanations/bricked-ray-casting.md):
- Level per brick: a level-0 voxel (its longest edge) projects to p pixels at the brick's
  nearest point; the brick wants the coarsest level L with cells.coarseness[L] <= -log2(p) +
  lod_bias (floor(-log2(p) + lod_bias) where every level halves every axis: voxels of about a
  pixel at lod_bias 0), clamped to the pyramid and to at least ``floor_level``; ``plan_frame``
  raises floor_level until the frame fits the budget.
- A tile of the picture (a camera with a ``window``, vgraph.distributed) asks for the levels the
  whole picture does (pixels_per_world).
"""

from __future__ import annotations

import math

import numpy as np

from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.cells import cells_of_bricks

KEPT_CELLS = 1 << 15  # levels of at most this many cells keep their boxes and corners (8 MB at most)


def kept_per_level(geometry: BrickGeometry, what: str, level: int, make):
    """``make()`` for ``level``, kept in the geometry (one per source) where the level is small:
    the boxes and corners of a level depend on nothing else, so a frame need not make them again."""
    key = (what, level)
    kept = geometry.per_level.get(key)
    if kept is not None:
        return kept
    if math.prod(int(n) for n in geometry.grids[level]) > KEPT_CELLS:
        return make()
    kept = geometry.per_level[key] = make()
    return kept


def kept_whole(geometry: BrickGeometry, what: str, make):
    """``make()``, kept in the geometry (what joins levels of KEPT_CELLS at most together)."""
    key = (what, None)
    kept = geometry.per_level.get(key)
    if kept is None:
        kept = geometry.per_level[key] = make()
    return kept


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
    """The 8 corners of every box of level_boxes, homogeneous: [4, 8, bz * by * bx] (coordinate,
    corner, box; screen_rects multiplies them by the view-projection in one product and reduces
    over the corners, whole rows of boxes at a time), read-only."""
    def make() -> np.ndarray:
        lo, hi = (box.reshape(-1, 3) for box in level_boxes(geometry, level))
        corners = np.ones((4, 8, len(lo)))
        for i in range(8):
            for a in range(3):
                corners[a, i] = (lo, hi)[i >> a & 1][:, a]
        corners.setflags(write=False)
        return corners
    return kept_per_level(geometry, "corner rows", level, make)


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
    return _desired_levels(geometry, camera, size, *level_boxes(geometry, level), lod_bias)


def _desired_levels(geometry: BrickGeometry, camera, size, lo, hi, lod_bias: float) -> np.ndarray:
    """desired_levels of the boxes ``lo``, ``hi`` ([..., 3]) of any levels' cells."""
    eye = np.asarray(camera.position, dtype=np.float64)
    distance = np.linalg.norm(np.maximum(np.maximum(lo - eye, eye - hi), 0.0), axis=-1)
    # The longest voxel edge: an anisotropic voxel is refined until its longest side is about a pixel.
    pixels = float(geometry.spacing0.max()) * pixels_per_world(camera, size, distance)
    allowed = -np.log2(np.maximum(pixels, 1e-30)) + lod_bias
    return np.searchsorted(geometry.coarseness[1:], allowed, side="right").astype(np.int64)


def screen_rects(geometry: BrickGeometry, view_projection, size, level: int) -> np.ndarray:
    """Pixel rectangles (x, y, w, h) covering each brick of ``level`` with one pixel of margin, int
    [bz, by, bx, 4]; w = 0 off screen; the whole viewport where a corner lies behind the eye."""
    grid = tuple(int(n) for n in geometry.grids[level][::-1])
    return _screen_rects(box_corners(geometry, level), view_projection, size).reshape(grid + (4,))


def _screen_rects(corners: np.ndarray, view_projection, size) -> np.ndarray:
    """screen_rects of the boxes whose corners (box_corners' rows) are ``corners`` [4, 8, n]: [n, 4]."""
    # one product for every corner ([4, 4] @ [4, 8n]), then the 8 corners reduced row against
    # row along the boxes (contiguous): a reduction over 8 contiguous values per box cost numpy
    # several times more (a frame's joined levels: thousands of boxes)
    count = corners.shape[-1]
    clip = (np.asarray(view_projection, dtype=np.float64) @ corners.reshape(4, -1)).reshape(4, 8, count)
    w = clip[3]
    behind = (w <= 1e-9).any(axis=0)
    w = np.where(w > 1e-9, w, 1.0)
    extent = np.asarray(size[:2], dtype=np.float64)
    pixel = (clip[:2] / w * 0.5 + 0.5) * extent[:, None, None]
    first = np.maximum(np.floor(pixel.min(axis=1)) - 1, 0)
    last = np.minimum(np.ceil(pixel.max(axis=1)) + 1, extent[:, None])
    rects = np.concatenate([first, np.maximum(last - first, 0)]).T
    if behind.any():
        rects[behind] = (0, 0, size[0], size[1])
    rects[(rects[:, 2] == 0) | (rects[:, 3] == 0)] = 0
    return rects.astype(np.int64)


def joined_levels(geometry: BrickGeometry) -> int:
    """The finest level from which up to the top the levels' cells are KEPT_CELLS at most together:
    a frame makes their rectangles and wanted levels in one go, as one level's (numpy's calls, not
    the cells, are the cost of such small levels)."""
    def make() -> int:
        total, first = 0, len(geometry.grids)
        for level in range(len(geometry.grids) - 1, -1, -1):
            total += math.prod(int(n) for n in geometry.grids[level])
            if total > KEPT_CELLS:
                break
            first = level
        return first
    return kept_whole(geometry, "joined from", make)


def joined_boxes(geometry: BrickGeometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The boxes (lo, hi [n, 3]) and corner rows ([4, 8, n]) of the cells of the levels from
    joined_levels up, the finest level's first, each level's in its [z, y, x] order, read-only."""
    def make():
        levels = range(joined_levels(geometry), len(geometry.grids))
        lo, hi = (np.concatenate([level_boxes(geometry, level)[i].reshape(-1, 3) for level in levels]) for i in (0, 1))
        corners = np.concatenate([box_corners(geometry, level) for level in levels], axis=-1)
        for array in (lo, hi, corners):
            array.setflags(write=False)
        return lo, hi, corners
    return kept_whole(geometry, "joined boxes", make)


class LevelTables:
    """Per-level rectangles, wanted levels and visibility of one frame, computed on first use (the
    rectangles and wanted levels of the levels from joined_levels up in one go)."""

    def __init__(self, geometry: BrickGeometry, camera, size, view_projection, visible, lod_bias: float):
        self.geometry, self.camera, self.size = geometry, camera, size
        self.view_projection, self.visible, self.lod_bias = view_projection, visible, lod_bias
        self._tables: dict = {}

    def __call__(self, level: int, what: str) -> np.ndarray:
        table = self._tables.get((level, what))
        if table is not None:
            return table
        geometry = self.geometry
        if what == "visible":
            table = self.visible(level)
            if not geometry.cells_are_bricks[level]:
                table = cells_of_bricks(geometry.source, level, table)
        elif level >= joined_levels(geometry):  # a view of the joined table
            joined = self.joined(what)
            grid = tuple(int(n) for n in geometry.grids[level][::-1])
            start = int(sum(math.prod(int(n) for n in geometry.grids[k]) for k in range(joined_levels(geometry), level)))
            table = joined[start:start + math.prod(grid)].reshape(grid + joined.shape[1:])
        elif what == "rects":
            table = screen_rects(geometry, self.view_projection, self.size, level)
        else:
            table = desired_levels(geometry, self.camera, self.size, level, self.lod_bias)
        self._tables[level, what] = table
        return table

    def joined(self, what: str) -> np.ndarray:
        """``what`` ("rects" or "wants") of every cell of the levels from joined_levels up, flat in
        joined_boxes' order, made in one go."""
        table = self._tables.get(("joined", what))
        if table is None:
            geometry = self.geometry
            lo, hi, corners = joined_boxes(geometry)
            if what == "rects":
                table = _screen_rects(corners, self.view_projection, self.size)
            else:
                table = _desired_levels(geometry, self.camera, self.size, lo, hi, self.lod_bias)
            self._tables["joined", what] = table
        return table
