"""The mouse on a slice canvas (one that shows a SliceViewer and has no camera).

- Left drag: the cursor follows the mouse (the world point under it on the plane shown at the
  press, held to the image's edges), so the linked slices follow; a left click is slice_clicks.py.

- Wheel: pages through the volume. Each notch moves the viewer's ``cursor`` along the plane's
  normal by one voxel step, ``SHIFT_STEPS`` steps with Shift; forward (away from the user) moves
  the plane towards the viewer (the normal points at the viewer: for the axial slice, seen from
  below, that is down). The step is one voxel along the normal: the distance whose displacement,
  counted in voxels, is 1 long, 1 / |normal in index units| (normal turned into the index axes,
  divided by the spacing; for an axial, coronal or sagittal slice of an axis-aligned volume the
  spacing along its axis).
  The plane stops at the first and last voxel centre along the normal (the corners of the box of
  voxel centres, oriented as the volume). A cursor that was None (the volume's centre) starts
  from the plane's centre, which is then the box centre.
- Middle drag or Shift + left drag: pans (``pan``: the image follows the mouse); Ctrl + wheel
  zooms (``zoom``, 1.1 per notch). Linked between the viewers, as networks/mpr_mri_head.json
  links them, every slice view zooms and pans with the one under the mouse.
- Right drag: window/level, as medical viewers do it: horizontal changes the width (right =
  wider, less contrast), vertical the centre (up = higher); a drag over the frame's height
  changes either by the volume's value range. Only with ``mapping = window`` (a TF-mapped
  slice says so); a right click without movement still opens the context menu.

Linked viewers follow through the network's property links (the cursor and window of
networks/mpr_mri_head.json are linked). Like the camera gestures (canvas_mouse.py), each value is
computed from the one at the gesture's start plus the total offset, and a wheel burst or a drag is
one undo step (one merge key, CanvasView._apply). The GUI holds no volume: the render process
reports each viewer's plane and SliceVolume with the view cameras (slice_clicks.py).
"""

from __future__ import annotations

import numpy as np

from vgraph.live.slice_clicks import PLANE_SUFFIX, VOLUME_SUFFIX, slice_viewer_for
from vgraph.slicing import voxel_step
from vgraph.volume_grid import IDENTITY

ZOOM_RANGE = (0.01, 1000.0)  # SliceViewer.zoom's limits
SHIFT_STEPS = 10          # voxel steps per wheel notch with Shift
MIN_WIDTH_FRACTION = 1e-3  # the window never gets narrower than this part of the value range
NOT_DRAWN = "the slice is not drawn yet"
NOT_WINDOW = "window/level works with mapping = window (this slice uses its transfer function)"


def _reported(view, viewer_id: str):
    """(plane, SliceVolume) the render process reported for the viewer, or None (with a message)."""
    cameras = view.view_cameras()
    plane, volume = cameras.get(viewer_id + PLANE_SUFFIX), cameras.get(viewer_id + VOLUME_SUFFIX)
    if plane is None or volume is None:
        view.set_message(NOT_DRAWN)
        return None
    return plane, volume


def page_step(normal, spacing, direction=IDENTITY) -> float:
    """World distance along the unit ``normal`` that spans one voxel of a grid with that spacing
    and direction (module docstring)."""
    return voxel_step(normal, spacing, direction)


def begin_page(view, key) -> dict | None:
    """A wheel burst's state on a slice canvas, or None when the canvas shows no slice. A slice
    not drawn yet gives a gesture that does nothing (and says so)."""
    network = view.workspace.network
    viewer_id = slice_viewer_for(network, view.canvas_id)
    if viewer_id is None:
        return None
    gesture = {"mode": "page", "address": None, "key": key, "active": False, "steps": 0.0}
    reported = _reported(view, viewer_id)
    if reported is None:
        return gesture
    plane, volume = reported
    cursor = network.get(f"{viewer_id}.cursor")
    start = np.asarray(plane.centre if cursor is None else cursor, dtype=np.float64)
    normal = np.asarray(plane.normal, float)
    step = page_step(normal, volume.spacing, plane.box.direction)
    # the voxel centres' box projected on the normal: how far the plane may go either way
    ends = plane.box.corners(cells=False) @ normal
    here = float(start @ normal)
    gesture.update(address=f"{viewer_id}.cursor", camera=start, normal=normal, step=step,
                   limits=((ends.min() - here) / step, (ends.max() - here) / step))
    return gesture


def page(view, gesture: dict, notches: float, shift: bool) -> None:
    """Add a wheel event's notches to the burst and move the cursor for the total."""
    if gesture["address"] is None:
        return
    low, high = gesture["limits"]
    steps = gesture["steps"] + notches * (SHIFT_STEPS if shift else 1)
    gesture["steps"] = float(np.clip(steps, min(low, 0.0), max(high, 0.0)))
    offset = gesture["steps"] * gesture["step"] * gesture["normal"]
    view._apply(gesture, lambda start: tuple(float(x) for x in start + offset))


def begin_window(view, event, key) -> dict | None:
    """A right drag's state on a slice canvas (mode "window"), or None when it shows no slice."""
    network = view.workspace.network
    viewer_id = slice_viewer_for(network, view.canvas_id)
    if viewer_id is None:
        return None
    gesture = {"mode": "window", "button": event.button(), "start": event.position(),
               "active": False, "key": key, "address": None, "camera": None}
    if network.get(f"{viewer_id}.mapping") != "window":
        gesture["refusal"] = NOT_WINDOW
        return gesture
    reported = _reported(view, viewer_id)
    if reported is None:
        gesture["refusal"] = NOT_DRAWN
        return gesture
    lo, hi = reported[1].value_range
    window = network.get(f"{viewer_id}.window")
    gesture.update(address=f"{viewer_id}.window", span=float(hi - lo),
                   camera=((lo + hi) / 2.0, hi - lo) if window is None else tuple(window))
    return gesture


def move_window(view, gesture: dict, dx: float, dy: float) -> None:
    """Set the window for a drag of (dx, dy) Qt pixels (y down) from the press point."""
    if gesture["address"] is None:
        view.set_message(gesture["refusal"])
        return
    per_pixel = gesture["span"] / view._view_height()
    narrowest = MIN_WIDTH_FRACTION * gesture["span"]
    view._apply(gesture, lambda start: (float(start[0] - dy * per_pixel),
                                        float(max(start[1] + dx * per_pixel, narrowest))))


def begin_cursor(view, event, key) -> dict | None:
    """A left drag's state on a slice canvas (mode "cursor"), or None when it shows no slice.
    The drag maps the mouse through the plane shown at the press, so the cursor follows the
    mouse even while the frames that follow it come in."""
    network = view.workspace.network
    viewer_id = slice_viewer_for(network, view.canvas_id)
    if viewer_id is None:
        return None
    return {"mode": "cursor", "button": event.button(), "start": event.position(), "active": False,
            "key": key, "address": f"{viewer_id}.cursor", "camera": None,
            "plane": view.view_cameras().get(viewer_id + PLANE_SUFFIX)}


def move_cursor(view, gesture: dict, position) -> None:
    """Put the cursor at the world point under ``position`` (widget pixels), held to the image's
    edges when the mouse leaves it."""
    plane = gesture["plane"]
    if plane is None or view.frame() is None:
        view.set_message(NOT_DRAWN)
        return
    rect = view.image_rect()
    u = float(np.clip((position.x() - rect.left()) / rect.width(), 0.0, 1.0))
    v = float(np.clip(1.0 - (position.y() - rect.top()) / rect.height(), 0.0, 1.0))
    point = plane.world_at(u, v)
    view._apply(gesture, lambda _: tuple(float(x) for x in point))


def begin_pan(view, event, key) -> dict | None:
    """A middle (or Shift + left) drag's state on a slice canvas (mode "slice_pan"), or None when
    it shows no slice: the viewer's ``pan`` moves so the image follows the mouse."""
    network = view.workspace.network
    viewer_id = slice_viewer_for(network, view.canvas_id)
    if viewer_id is None:
        return None
    return {"mode": "slice_pan", "button": event.button(), "start": event.position(),
            "active": False, "key": key, "address": f"{viewer_id}.pan",
            "camera": np.asarray(network.get(f"{viewer_id}.pan"), dtype=np.float64),
            "plane": view.view_cameras().get(viewer_id + PLANE_SUFFIX)}


def move_pan(view, gesture: dict, dx: float, dy: float) -> None:
    """Pan for a drag of (dx, dy) Qt pixels (y down) from the press point: the image's centre
    moves against the mouse by the world size of those pixels in the plane shown at the press."""
    plane = gesture["plane"]
    if plane is None:
        view.set_message(NOT_DRAWN)
        return
    rect = view.image_rect()
    offset = (-dx / rect.width() * np.asarray(plane.right, dtype=np.float64)
              + dy / rect.height() * np.asarray(plane.up, dtype=np.float64))
    view._apply(gesture, lambda start: tuple(float(x) for x in start + offset))


def begin_zoom(view, key) -> dict | None:
    """A Ctrl + wheel burst's state on a slice canvas (mode "slice_zoom"), or None."""
    network = view.workspace.network
    viewer_id = slice_viewer_for(network, view.canvas_id)
    if viewer_id is None:
        return None
    return {"mode": "slice_zoom", "address": f"{viewer_id}.zoom", "key": key, "active": False,
            "camera": float(network.get(f"{viewer_id}.zoom")), "notches": 0.0}


def zoom(view, gesture: dict, notches: float, factor: float) -> None:
    """Magnify by ``factor`` per notch of the burst (forward zooms in), within the zoom's range."""
    gesture["notches"] += notches
    exponent = float(np.clip(gesture["notches"] * np.log(factor), -50.0, 50.0))
    view._apply(gesture, lambda start: float(np.clip(start * np.exp(exponent), *ZOOM_RANGE)))
