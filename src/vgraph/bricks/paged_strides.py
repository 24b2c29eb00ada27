"""dvr in the single pass on each level's own lattice (define PAGED_STRIDE, shaders/bricks/paged_stride.glsl):
a run through a cell drawn at a coarse level takes every level_stride-th sample of level 0's lattice
(BrickGeometry.strides), each with the opacity of the level-0 steps it stands for, as a pass per
brick does (vgraph.bricks.sampling). A frame that draws only strides of 1 compiles without it: its
shader is exactly the one before (level 0 keeps its speed)."""

from __future__ import annotations

import math

import numpy as np

from vgraph.bricks.ray_requests import drawn_bricks
from vgraph.gl.raycasting.raycaster_base import Binding


def stride_binding(mode: str, geometry, plan, missing, resident, frame_stride: int) -> Binding | None:
    """The binding of PAGED_STRIDE for a frame of ``mode`` drawing ``plan`` (a FramePlan) with
    ``missing`` planned keys the atlas misses (``resident``: the atlas's keys), sampled every
    ``frame_stride`` level-0 steps (a drag's frame, vgraph.bricks.coarse_step: a level's stride
    counts the frame's steps); None where no cell it draws has a stride above 1. ``level_strides``:
    each level's stride, negative where the level is not whole (partial_levels);
    ``PAGED_STRIDE_WHOLE`` where every level is (the look-ups at partial cells' borders compiled out).
    A complete frame reads only the plan's levels (no tuple per brick)."""
    if mode != "dvr":
        return None
    strides = np.maximum(np.asarray(geometry.strides, dtype=np.int64) // max(int(frame_stride), 1), 1)
    if len(missing):  # cells drawn from resident ancestors
        keys = plan.keys()
        sources = drawn_bricks(geometry, keys, resident)
        levels = {key[0] for key in sources if key is not None}
    else:  # every planned brick drawn from itself: every level whole
        levels = plan.levels()
    if all(strides[level] == 1 for level in levels):
        return None
    partial = list(partial_levels(geometry, keys, sources)) if len(missing) else []
    signs = np.ones(len(strides), dtype=np.int64)
    signs[partial] = -1
    return Binding({"PAGED_STRIDE": True, "PAGED_STRIDE_WHOLE": not partial},
                   uniforms={"level_strides": (strides * signs).astype(np.int32)})


def partial_levels(geometry, keys, sources) -> set:
    """The levels of the bricks in ``sources`` (the brick each planned key of ``keys`` is drawn from,
    or None) not drawn in every level-0 cell of theirs: an ancestor drawn in place of missing bricks
    whose cell also holds cells drawn finer, or not drawn (empty, off screen, nothing resident). A
    planned brick drawn from itself is whole (the plan's cells do not overlap)."""
    cells = {}  # an ancestor -> the level-0 cells drawn from it
    for key, source in zip(keys, sources):
        if source is not None and source != key:
            cells[source] = cells.get(source, 0) + level_0_cells(geometry, key)
    return {source[0] for source, count in cells.items() if count < level_0_cells(geometry, source)}


def level_0_cells(geometry, key) -> int:
    """How many level-0 cells the cell ``key`` holds (its last ones cut at the volume's faces)."""
    level, index = key[0], key[1:]
    grid0 = geometry.grids[0][::-1]  # [z, y, x]
    per = [int(a) // int(b) for a, b in zip(geometry.spans[level][::-1], geometry.spans[0][::-1])]
    return math.prod(max(0, min((int(i) + 1) * p, int(g)) - int(i) * p) for i, p, g in zip(index, per, grid0))
