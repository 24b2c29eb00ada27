"""RZSweep out of core over the leaves of a store (Retondaro 2008 ch. 4: each octree leaf swept on
its own, loaded once on demand, in visibility order; docs/explanations/sweep-plane.md).

- Leaves: the bricks (octree cells, vgraph.bricks.cells) of one pyramid level of a BrickSource (a
  BrickedVolume's store; level 0 is full resolution). Leaf b sweeps the cells whose lowest vertex
  lies in its core [start, stop) and so reads the vertices [start, stop + 1) (one voxel of
  overlap into the next leaf, clipped to the level): every cell of the level lies in exactly one
  leaf, and the faces on a seam are projected by both leaves, as the exit of one and the entry of
  the other, which are the entries the whole grid's lists hold there. A leaf with fewer than two
  vertices along an axis has no cells (the one before it sweeps them).
- Reading: through a BrickCache (its bricks carry a halo of 2 voxels, so the overlap comes with
  the leaf), within the RAM budget of the BrickedVolume; the leaf being swept is pinned. A leaf
  larger than the budget is refused by name.
- Order: front to back, the grid's sweep order (walk_order.front_to_back) over the leaves' grid,
  whose separating planes are the seams (vertex indices start), valid for both projections.
- Skipped without reading: a leaf the threshold empties (the per-brick min/max of the store over
  the leaf's brick and the bricks its overlap reaches does not meet [low, high]: then no cell's
  range does), and a leaf whose box projects wholly outside the image (a tile of the cluster's
  tiles split reads only the leaves it sees).
- Compositing: the leaves are swept into one Frame in order, each continuing the per-pixel
  compositing of those in front (render.sweep_into), so the picture is the in-memory sweep's.
  The cluster's leaves split sweeps runs of leaves into separate partials (``partial``) and
  composites them in order (``composite``), as the front-to-back sweep would.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from vgraph.bricks.cache import HALO, MB, BrickCache, brick_bytes, brick_extent, usable_range
from vgraph.bricks.cells import cell_grid
from vgraph.bricks.walk_order import front_to_back
from vgraph.errors import VGraphError
from vgraph.memory import format_bytes
from vgraph.sweep.grid import grid_of
from vgraph.sweep.render import Frame, pixel_coordinates, sweep_into


@dataclass(frozen=True)
class Leaf:
    key: tuple  # (level, bz, by, bx), the cache's brick key
    start: tuple  # [z, y, x] first vertex of the level it reads
    stop: tuple  # [z, y, x] one past the last (the core's end + 1, within the level)


def leaves(source, level: int) -> list[Leaf]:
    """The leaves of ``level`` that have cells, in [z, y, x] brick order."""
    shape = np.asarray(source.levels[level].shape)
    found = []
    for bz, by, bx in np.ndindex(*cell_grid(source, level)):
        key = (level, bz, by, bx)
        start, stop = brick_extent(source, key)
        stop = np.minimum(stop + 1, shape)
        if (stop - start >= 2).all():
            found.append(Leaf(key, tuple(int(v) for v in start), tuple(int(v) for v in stop)))
    return found


def level_grid(volume, level: int):
    """The grid of a pyramid level as grid_of places it: spacing, origin, direction (x, y, z)."""
    lv = volume.bricks.levels[level]
    return SimpleNamespace(spacing=np.asarray(lv.spacing, dtype=np.float64),
                           origin=np.asarray(lv.origin, dtype=np.float64),
                           direction=np.asarray(volume.direction, dtype=np.float64))


def planned(volume, frame: Frame, level: int) -> list[Leaf]:
    """The leaves of ``level`` a frame sweeps, front to back: the empty and unseen left out."""
    source = volume.bricks
    if not 0 <= level < len(source.levels):
        raise VGraphError(f"{frame.owner}.leaf_level: {level} is not a level of the store "
                          f"{volume.source or ''} (it has levels 0-{len(source.levels) - 1})")
    candidates = {leaf.key[1:]: leaf for leaf in leaves(source, level)}
    empty = _emptied_by_threshold(volume, level, frame.threshold)
    grid = level_grid(volume, level)
    ordered = []
    for x, y, z in _order(volume, frame, level, grid):
        leaf = candidates.get((z, y, x))
        if leaf is not None and not empty[z, y, x] and _seen(leaf, grid, frame):
            ordered.append(leaf)
    return ordered


def sweep_leaves(frame: Frame, volume, cache: BrickCache, chosen: list[Leaf]) -> dict:
    """Sweep ``chosen`` (front to back) into ``frame``, reading them through ``cache``. Returns
    the cache's bytes read and the most bytes it held."""
    source = volume.bricks
    cache.set_budgets(volume.memory_budget_mb, 0.0)
    cache.use_source(source, volume.value_range)
    before, most = cache.stats["bytes_read"], cache.resident_bytes()[0]
    for leaf in chosen:
        need = brick_bytes(source, leaf.key)
        if need > cache.ram_budget:
            raise VGraphError(f"{frame.owner}: a leaf of the store {volume.source or ''} needs "
                              f"{format_bytes(need)} with its halo, over the volume's memory budget of "
                              f"{format_bytes(volume.memory_budget_mb * MB)}; raise the budget or "
                              "sweep a coarser leaf_level")
        cache.begin_frame([leaf.key])
        values = _normalised(cache, cache.brick(leaf.key), leaf)
        most = max(most, cache.resident_bytes()[0])
        where = level_grid(volume, leaf.key[0])
        where.origin = where.origin + where.direction @ (np.asarray(leaf.start[::-1]) * where.spacing)
        sweep_into(frame, grid_of(values, where, frame.camera, frame.threshold), values.shape[::-1])
    cache.begin_frame([])
    return {"bytes_read": cache.stats["bytes_read"] - before, "peak_cache_bytes": most,
            "leaves_swept": len(chosen)}


# --- partial pictures (the cluster's leaves split) ----------------------------------------------------
def partial(frame: Frame) -> tuple:
    """What a run of leaves composited: (colour, log transparency, first t, segments)."""
    return frame.colour, frame.log_transparency, frame.first_t, frame.segments


def composite(front: tuple, back: tuple, early_termination: float = 1.0) -> tuple:
    """Two partials of adjacent runs of leaves (``front`` nearer the eye) -> the partial of both,
    as one sweep over both runs composites it. A pixel whose front is opaque to
    ``early_termination`` keeps the front alone (one sweep stops there). Each run stopped its rays
    at its own opacity, never before one sweep would: the extra segments lie behind the point one
    sweep stops at, so the picture differs from one sweep's by at most 1 - early_termination
    (docs/explanations/sweep-plane.md "On a cluster")."""
    colour_f, log_f, first_f, segments_f = front
    colour_b, log_b, first_b, segments_b = back
    opaque = -np.expm1(log_f) >= early_termination  # the kernel's test before each segment
    return (np.where(opaque[:, None], colour_f, colour_f + np.exp(log_f)[:, None] * colour_b),
            np.where(opaque, log_f, log_f + log_b), np.where(np.isnan(first_f), first_b, first_f),
            np.where(opaque, segments_f, segments_f + segments_b))


def restore(frame: Frame, accumulated: tuple) -> None:
    """Put a composited partial into ``frame`` (to be finished: render.finish)."""
    frame.colour, frame.log_transparency, frame.first_t, frame.segments = (np.array(a) for a in accumulated)


# --- helpers ------------------------------------------------------------------------------------------
def _normalised(cache: BrickCache, brick: np.ndarray, leaf: Leaf) -> np.ndarray:
    """The leaf's vertices (core and overlap) in normalised intensity, float64 [z, y, x], from the
    cached brick in texture values (cache.texture_format's scale and offset)."""
    size = np.asarray(leaf.stop) - np.asarray(leaf.start)
    block = brick[HALO:HALO + size[0], HALO:HALO + size[1], HALO:HALO + size[2]].astype(np.float64)
    fmt = cache.format
    full = 65535.0 if fmt.gl_dtype == "nu2" else 1.0  # a normalised texture holds value * 65535
    return block / full * fmt.scale + fmt.offset


def _emptied_by_threshold(volume, level: int, threshold) -> np.ndarray:
    """Bool per brick [z, y, x]: the leaf's vertices (its brick and the next along each axis,
    which its overlap reaches) all lie outside the threshold, so none of its cells is kept."""
    grid = cell_grid(volume.bricks, level)
    if threshold is None:
        return np.zeros(grid, dtype=bool)
    low, high = (np.asarray(a, dtype=np.float64) for a in volume.bricks.brick_ranges(level))
    lo, hi = usable_range(volume.value_range)
    low = np.where(np.isfinite(low), (low - lo) / (hi - lo), -np.inf)  # unknown: anything
    high = np.where(np.isfinite(high), (high - lo) / (hi - lo), np.inf)
    for axis in range(3):  # widen to the next brick along each axis (the overlap voxel)
        low = np.minimum(low, _next_along(low, axis))
        high = np.maximum(high, _next_along(high, axis))
    return (high < threshold[0]) | (low > threshold[1])


def _next_along(a: np.ndarray, axis: int) -> np.ndarray:
    shifted = np.take(a, range(1, a.shape[axis]), axis=axis)
    return np.concatenate([shifted, np.take(a, [-1], axis=axis)], axis=axis)


def _order(volume, frame: Frame, level: int, grid) -> list[tuple[int, int, int]]:
    """(x, y, z) brick indices front to back: front_to_back on the leaves' grid in units of the
    brick (the seams at vertex indices b * brick)."""
    counts = cell_grid(volume.bricks, level)[::-1]
    brick = np.array([brick_extent(volume.bricks, (level, 0, 0, 0))[1][::-1]], dtype=np.float64)[0]
    linear = grid.direction.T / grid.spacing[:, None]  # world -> continuous index (x, y, z)
    eye = linear @ (np.asarray(frame.camera.position, dtype=np.float64) - grid.origin) / brick
    forward = grid.direction.T @ frame.camera.basis()[2]
    return front_to_back(counts, eye, forward, frame.camera.projection == "perspective")


def _seen(leaf: Leaf, grid, frame: Frame) -> bool:
    """Whether the leaf's box can cover a pixel of the frame (a corner behind the eye: it can)."""
    corners = np.array([[(leaf.start, leaf.stop)[i >> a & 1][2 - a] - (i >> a & 1) for a in range(3)]
                        for i in range(8)], dtype=np.float64)
    points = (corners * grid.spacing) @ grid.direction.T + grid.origin
    clip = np.concatenate([points, np.ones((8, 1))], axis=1) @ frame.view_projection.T
    if (clip[:, 3] <= 1e-9).any():
        return True
    x, y = pixel_coordinates(points, frame.view_projection, frame.width, frame.height)
    return x.max() >= -1.0 and x.min() <= frame.width and y.max() >= -1.0 and y.min() <= frame.height
