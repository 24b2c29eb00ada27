"""The sample step of a single-pass frame drawn while the user drags (issue #33): the step of the
finest level the frame's plan draws, not level 0's.

A drag's frame (``FrameContext.interactive``: the GUI's coarse frames, drawn at a quarter of the
canvas) plans coarse bricks — a 64^3 level of a 1024^3 store at 64 x 64 pixels — but the single
pass marched level 0's lattice through them: about 1000 samples a ray where the level has 64
voxels. As VTK's ``AutoAdjustSampleDistances`` lengthens the step while interacting and Voreen's
ray casters have an interaction coarseness, such a frame steps ``stride`` level-0 steps at a time,
``stride`` = BrickGeometry.strides of the finest level in its plan (2^L where every axis halves):
one sample per voxel of that level at sampling rate 1, as the pass per brick samples a coarse
brick ("Coarse levels sample their own lattice", docs/explanations/bricked-ray-casting.md). The
samples keep their places on level 0's lattice (every stride-th of them, from the entry point),
and dvr's opacity is corrected for the longer step (FrontToBack's exponent times ``stride``), so
the picture stays the same medium, sampled more coarsely. The frame says so
(``Frame.sample_stride``): Sampling's ``step_length`` and FrontToBack's ``opacity_exponent`` and
define OPACITY_CORRECTION follow it, as every part reads what the frame decides; the march, its
jumps and the depth output follow ``step_length`` already.

A frame that is not interactive (the refined frame after the release, scripts, ``vgraph run``)
has a stride of 1: it is drawn exactly as before, bit for bit. Since a still dvr frame steps each
coarse level's lattice itself (PAGED_STRIDE, vgraph.bricks.paged_strides, which counts a level's
stride in the frame's steps), the drag's stride saves dvr little; mip and iso still frames take
every level-0 sample, and there a drag's frame takes about a quarter of them at level 2.
"""

from __future__ import annotations

from dataclasses import replace

from vgraph.gl.raycasting.raycaster_base import Frame


def sample_stride(geometry, plan_keys, interactive: bool) -> int:
    """Level-0 steps per sample: 1, or for an interactive frame the stride of the finest level its
    plan draws (a plan of no bricks: 1)."""
    levels = [key[0] for key in plan_keys]
    if not interactive or not levels:
        return 1
    return int(geometry.strides[min(levels)])


def strided(frame: Frame, stride: int) -> Frame:
    """``frame`` sampled every ``stride`` level-0 steps (its parts bind the longer step)."""
    return frame if stride == 1 else replace(frame, sample_stride=stride)
