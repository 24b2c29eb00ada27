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

With each plane the render process reports the volume the viewer slices ('id.slice_volume', a
``SliceVolume``: spacing and value range), which the wheel and the window drag need
(slice_gestures.py), and ``slice_overlays`` gives a 3D canvas the outlines to draw (overlays.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.errors import VGraphError
from vgraph.live.upstream import NO_CAMERA, nearest_upstream
from vgraph.processors.slice_viewer import SliceViewer
from vgraph.slicing import SlicePlane
from vgraph.volume import Volume

PLANE_SUFFIX = ".slice_plane"
VOLUME_SUFFIX = ".slice_volume"
OUTSIDE = "click inside the slice to move the cursor"


@dataclass(frozen=True)
class SliceVolume:
    """What the GUI needs of the volume a SliceViewer slices (it holds no volume itself)."""
    spacing: tuple[float, float, float]     # world units per voxel along x, y, z
    value_range: tuple[float, float]        # data values mapped to intensities 0 and 1


def slice_planes(network) -> dict:
    """'id.slice_plane' -> the plane of the last image of every SliceViewer that drew one, and
    'id.slice_volume' -> the SliceVolume of the volume it sliced."""
    planes = {}
    for processor_id, processor in network.processors.items():
        if not isinstance(getattr(processor, "last_plane", None), SlicePlane):
            continue
        planes[processor_id + PLANE_SUFFIX] = processor.last_plane
        volume = _sliced_volume(network, processor_id)
        if volume is not None:
            planes[processor_id + VOLUME_SUFFIX] = SliceVolume(
                tuple(float(s) for s in volume.spacing), tuple(float(v) for v in volume.value_range))
    return planes


def _sliced_volume(network, processor_id: str):
    for connection in network.inputs_of(processor_id, "volume"):
        data = network[connection.source].outputs.get(connection.outport)
        if isinstance(data, Volume):
            return data
    return None


def slice_outlines(view_cameras: dict) -> dict[str, np.ndarray]:
    """Viewer id -> where its plane cuts the volume's box (SlicePlane.outline, (k, 3) world
    points), from the render result's ``view_cameras``: for an overlay that shows the slices'
    planes in a 3D canvas (project the corners with that canvas's camera, as its box edges)."""
    return {key[:-len(PLANE_SUFFIX)]: plane.outline() for key, plane in view_cameras.items()
            if key.endswith(PLANE_SUFFIX) and isinstance(plane, SlicePlane) and len(plane.outline())}


def slice_overlays(network, view_cameras: dict) -> list[tuple[str, np.ndarray]]:
    """(orientation, outline) of every SliceViewer still in ``network`` whose plane the last
    frame reported: what a 3D canvas draws with its "Slices" overlay."""
    return [(network.get(f"{viewer_id}.orientation"), outline)
            for viewer_id, outline in slice_outlines(view_cameras).items()
            if viewer_id in network.processors and "orientation" in network[viewer_id].properties]


def slice_viewer_for(network, canvas_id: str) -> str | None:
    """The id of the SliceViewer whose image the canvas shows: the nearest upstream processor
    with a slice plane (image processors in between keep the image's geometry), or None."""
    def pick(processor, processor_id):
        return processor_id if isinstance(processor, SliceViewer) else None
    return nearest_upstream(network, canvas_id, pick, include_start=True)


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
