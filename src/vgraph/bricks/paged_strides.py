"""dvr in the single pass on each level's own lattice (define PAGED_STRIDE, shaders/bricks/paged_stride.glsl):
a run through a cell drawn at a coarse level takes every level_stride-th sample of level 0's lattice
(BrickGeometry.strides), each with the opacity of the level-0 steps it stands for, as a pass per
brick does (vgraph.bricks.sampling). A frame that draws only strides of 1 compiles without it: its
shader is exactly the one before (level 0 keeps its speed)."""

from __future__ import annotations

import numpy as np

from vgraph.gl.raycasting.raycaster_base import Binding


def stride_binding(mode: str, geometry, plan_keys, missing: int, frame_stride: int) -> Binding | None:
    """The binding of PAGED_STRIDE for a frame of ``mode`` drawing ``plan_keys`` (keys (level, ...))
    with ``missing`` planned bricks the atlas misses, sampled every ``frame_stride`` level-0 steps
    (a drag's frame, vgraph.bricks.coarse_step: a level's stride counts the frame's steps); None
    where no cell it may draw has a stride above 1. ``PAGED_STRIDE_BRICKS``: every planned brick is
    in the atlas, so a brick's span is its whole cell (else its level-0 cell's: a missing cell drawn
    from an ancestor may border a finer one inside the ancestor's cell)."""
    if mode != "dvr":
        return None
    strides = np.maximum(np.asarray(geometry.strides, dtype=np.int32) // max(int(frame_stride), 1), 1)
    # with missing bricks, cells are drawn from resident ancestors of any level
    levels = range(len(strides)) if missing else {key[0] for key in plan_keys}
    if all(strides[level] == 1 for level in levels):
        return None
    return Binding({"PAGED_STRIDE": True, "PAGED_STRIDE_BRICKS": not missing},
                   uniforms={"level_strides": strides.astype(np.int32)})
