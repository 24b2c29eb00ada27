"""Ctrl + left drag in a canvas moves a clip plane along its normal (vgraph.clipping).

The plane is the first of the nearest upstream processor with clip planes (an EntryExitPoints;
breadth-first over predecessors in connection order, as canvas_view finds the camera). The plane
follows the cursor: the drag, in world units at the plane's depth (the camera of that processor,
as the last frame showed it), is projected on the normal's direction on the screen. A plane that
faces the viewer (its normal nearly along the view) moves by the vertical drag instead: up pushes
it away from the viewer. Like the camera gestures (canvas_mouse.py) each move is computed from the
planes at drag start plus the total offset, and a drag is one undo step (one merge key).
"""

from __future__ import annotations

import math

import numpy as np
from PySide6.QtCore import Qt

from vgraph.clipping import ClipPlanesProperty
from vgraph.live.upstream import nearest_upstream, property_of_type

NO_PLANE = "no clip plane upstream of this canvas (EntryExitPoints.clip_planes)"
MIN_SCREEN_NORMAL = 0.3  # below this length of the normal's screen projection: vertical drags


def wanted(event) -> bool:
    """Whether a mouse press starts a clip-plane drag: Ctrl + left button."""
    return event.button() == Qt.LeftButton and bool(event.modifiers() & Qt.ControlModifier)


def clip_planes_property_for(network, canvas_id: str) -> str | None:
    """'id.name' of the nearest upstream clip-planes property of ``canvas_id``, or None."""
    return nearest_upstream(network, canvas_id, property_of_type(ClipPlanesProperty))


def begin(view, event, key) -> dict:
    """The drag state for canvas_view (mode "clip"; "camera" holds the planes at drag start, which
    CanvasView._apply hands to the move). Without a plane the drag does nothing and says so."""
    network = view.workspace.network
    address = clip_planes_property_for(network, view.canvas_id)
    planes = network.get(address) if address is not None else ()
    drag = {"mode": "clip", "button": event.button(), "start": event.position(), "active": False,
            "key": key, "address": None, "camera": planes}
    if not planes:
        view.set_message(NO_PLANE)
        return drag
    processor_id = address.split(".")[0]
    camera_address = f"{processor_id}.camera"
    camera = view.view_cameras().get(camera_address) or network.get(camera_address)
    drag.update(address=address, view_camera=camera)
    return drag


def move(view, drag, event) -> None:
    """Move the first plane for the cursor's offset from the press point."""
    if drag["address"] is None:
        return
    offset = event.position() - drag["start"]
    distance = drag_distance(drag["view_camera"], drag["camera"][0], offset.x(), offset.y(),
                             view._view_height())
    view._apply(drag, lambda planes: (planes[0].moved(distance), *planes[1:]))


def drag_distance(camera, plane, dx: float, dy: float, height_pixels: float) -> float:
    """World units to move ``plane`` along its unit normal for a drag of (dx, dy) Qt pixels (y
    down) in a view ``height_pixels`` high (module docstring)."""
    right, up, forward = camera.basis()
    normal = plane.unit_normal()
    if camera.projection == "perspective":
        depth = max(float((np.asarray(plane.point) - np.asarray(camera.position)) @ forward), 1e-6)
        view_height = 2.0 * depth * math.tan(math.radians(camera.fov) / 2.0)
    else:
        view_height = 2.0 * camera.parallel_scale
    per_pixel = view_height / max(height_pixels, 1.0)
    on_screen = np.array([normal @ right, normal @ up])
    length = float(np.linalg.norm(on_screen))
    if length < MIN_SCREEN_NORMAL:
        away = 1.0 if normal @ forward >= 0.0 else -1.0
        return -dy * per_pixel * away
    drag = np.array([dx, -dy]) * per_pixel
    return float(drag @ on_screen) / (length * length)
