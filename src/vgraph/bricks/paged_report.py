"""What a frame of the single pass (vgraph.bricks.paged_sampling) drew, for its ``last_frame``
(``drawn_report``) and the inspector's line (``summary``)."""

from __future__ import annotations

from vgraph.bricks.atlas import BrickAtlas
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.ray_requests import drawn_from
from vgraph.bricks.sampling import level_span
from vgraph.bricks.selection import FramePlan, brick_list
from vgraph.gl.raycasting.raycaster_base import Frame


def drawn_report(frame: Frame, geometry: BrickGeometry, plan: FramePlan, atlas: BrickAtlas, requested,
                 errors, every_resident: bool = False) -> dict:
    """What the frame drew of its plan: the planned cells rays could see (resident, or missing
    and reached) each from itself or its finest resident ancestor; ``complete`` when no ray
    reached a missing cell (the image is the planned frame's: cells no ray reached change no
    pixel), the levels drawn, the coarsest, and (dvr) the error bound of lod_error over those
    bricks (1 where a ray reached a cell with nothing resident above it). ``every_resident``: the
    atlas is known to hold every planned brick (PagedSampling.placed), so no key is looked up."""
    resident, reached = atlas.slots, {key for key, _ in requested}
    if reached or not (every_resident or all(map(resident.__contains__, plan.keys()))):
        sources = [(key if key in resident else drawn_from(geometry, key, resident), rect)
                   for key, rect in plan.bricks if key in resident or key in reached]
        levels = sorted({key[0] for key, _ in sources if key is not None})
    else:  # every planned brick drawn from itself (a complete frame of thousands: no loop in Python)
        # (dvr's bound: only the coarser bricks, as tuples; a level-0 brick moves no pixel, lod_error)
        coarse = plan.key_array[:, 0] > 0
        sources = brick_list(plan.key_array[coarse], plan.rect_array[coarse]) if errors is not None else []
        levels = plan.levels()
    if errors is None:
        bound = None
    elif any(key is None for key, _ in sources):
        bound = 1.0
    else:
        bound = errors.frame_bound(sources, frame.size)
    return {"complete": not requested, "levels": levels, "coarsest_level": levels[-1] if levels else None,
            "error_bound": bound}


def summary(frame: dict) -> str:
    """The frame ``frame`` (a ``last_frame``) in a line (the inspector's, Processor.frame_summary), as
    BrickSampling's: its levels and bricks, the atlas, and whether it is still refining."""
    if not frame:
        return ""
    line = f"single pass: level {level_span(frame['levels'])}, {frame['bricks']} bricks in an atlas of {frame['atlas_slots']} slots"
    if frame["missing"]:
        line += f", {frame['missing']} missing bricks reached (drawn coarser)"
    if frame["sample_stride"] > 1:
        line += f", a sample every {frame['sample_stride']} level-0 steps (dragging)"
    if frame["error_bound"] is not None:
        line += f"; error bound {frame['error_bound']:.3g} against the level-0 frame"
    if frame["complete"]:
        return line + "; complete"
    return line + f"; coarsest level {frame['coarsest_level']}; refining"
