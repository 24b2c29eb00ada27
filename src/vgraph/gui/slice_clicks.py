"""Clicks in a slice: the shared cursor of a multi-planar layout (MPR).

A left click (press and release without a drag) in a canvas that shows a SliceViewer's image
sets that viewer's ``cursor`` to the world point under the mouse, as one undo step. Viewers whose
cursors are linked to it follow through the network's property links, so a click in the axial
slice moves the coronal and sagittal planes there (networks/mpr_mri_head.json).

The GUI process holds no volume, so it cannot place a pixel in the world by itself: the render
process reports each SliceViewer's plane of its last image (``slice_planes``, sent with the view
cameras under 'id.slice_plane'), and the click's place in the displayed frame, as image
coordinates (u, v) (vgraph.slicing), gives the world point ``SlicePlane.world_at(u, v)``. A
coarse frame shows the same plane at fewer pixels, so (u, v) does not depend on the frame's
resolution. This module imports no Qt: the render process imports ``slice_planes`` from it.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from vgraph.errors import VGraphError
from vgraph.slicing import SlicePlane

PLANE_SUFFIX = ".slice_plane"
OUTSIDE = "click inside the slice to move the cursor"


def slice_planes(network) -> dict[str, SlicePlane]:
    """'id.slice_plane' -> the plane of the last image of every SliceViewer that drew one."""
    return {processor_id + PLANE_SUFFIX: processor.last_plane
            for processor_id, processor in network.processors.items()
            if isinstance(getattr(processor, "last_plane", None), SlicePlane)}


def slice_outlines(view_cameras: dict) -> dict[str, np.ndarray]:
    """Viewer id -> where its plane cuts the volume's box (SlicePlane.outline, (k, 3) world
    points), from the render result's ``view_cameras``: for an overlay that shows the slices'
    planes in a 3D canvas (project the corners with that canvas's camera, as its box edges)."""
    return {key[:-len(PLANE_SUFFIX)]: plane.outline() for key, plane in view_cameras.items()
            if key.endswith(PLANE_SUFFIX) and isinstance(plane, SlicePlane) and len(plane.outline())}


def slice_viewer_for(network, canvas_id: str) -> str | None:
    """The id of the SliceViewer whose image the canvas shows: the nearest upstream processor
    with a slice plane (image processors in between keep the image's geometry), or None."""
    from vgraph.processors.slice_viewer import SliceViewer
    if canvas_id not in network.graph:
        return None
    seen, queue = {canvas_id}, deque([canvas_id])
    while queue:
        processor_id = queue.popleft()
        if isinstance(network[processor_id], SliceViewer):
            return processor_id
        for source in network.graph.predecessors(processor_id):
            if source not in seen:
                seen.add(source)
                queue.append(source)
    return None


def image_coordinates(view, position) -> tuple[float, float] | None:
    """(u, v) of a widget position in the frame the view shows (u right, v up, both in [0, 1]),
    or None outside the frame or when no frame is shown."""
    if view.frame() is None:
        return None
    rect = view.image_rect()
    u = (position.x() - rect.left()) / rect.width()
    v = 1.0 - (position.y() - rect.top()) / rect.height()
    return (u, v) if 0.0 <= u <= 1.0 and 0.0 <= v <= 1.0 else None


def world_point(view, viewer_id: str, position) -> np.ndarray | None:
    """The world point under ``position`` on the viewer's last plane, or None (not drawn yet, or
    outside the frame)."""
    plane = view.view_cameras().get(viewer_id + PLANE_SUFFIX)
    uv = image_coordinates(view, position)
    if plane is None or uv is None:
        return None
    return plane.world_at(*uv)


def click(view, position) -> bool:
    """A left click at ``position`` (widget coordinates) in a CanvasView: move the cursor of the
    SliceViewer it shows there. True when the canvas shows a slice (the click was handled)."""
    from vgraph.gui.canvas_view import NO_CAMERA
    viewer_id = slice_viewer_for(view.workspace.network, view.canvas_id)
    if viewer_id is None:
        return False
    if view.message() == NO_CAMERA:
        view.set_message("")  # the press looked for a camera to rotate; a slice needs none
    point = world_point(view, viewer_id, position)
    if point is None:
        view.set_message(OUTSIDE)
        return True
    address = f"{viewer_id}.cursor"
    try:
        view.workspace.set_property(address, tuple(float(x) for x in point))
    except (VGraphError, ValueError) as error:
        view.set_message(f"{address}: {error}")
        return True
    if view.message() == OUTSIDE or view.message().startswith(address + ":"):
        view.set_message("")
    return True
