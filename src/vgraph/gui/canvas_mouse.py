"""The mouse on a canvas view: turns drags and the wheel into camera (or slice, or clip-plane)
edits. ``CanvasMouse`` is the input half of ``CanvasView`` (canvas_view.py, the display half).

Interaction (on the camera returned by ``camera_property_for``, i.e. the nearest upstream one):

- left drag: trackball rotate, ``Camera.rotate(pi * dx / h, -pi * dy / h)``;
- right drag: zoom, ``Camera.zoom(exp(-ZOOM_PER_PIXEL * dy))`` (drag up zooms in; 100 px = e^1);
  a right click without movement opens the context menu instead ("Save Image...");
- wheel: zoom by ``WHEEL_ZOOM = 1.1`` per 120-unit notch, forward zooms in;
- middle drag or shift + left drag: pan, ``Camera.pan(dx / h, -dy / h)``, so the scene follows the
  cursor.
- ctrl + left drag: moves the first clip plane upstream along its normal (clip_drag.py).
- markups (markup_placing.py, ``placer``): a left press near a drawn markup point drags it; while
  placing (``set_placing``, the toolbar's Place) a left click places a point.
- a canvas that shows a slice and has no camera (slice_gestures.py): a left click or drag moves
  the shared cursor (slice_clicks.py; the cursor follows the mouse), the wheel pages through the
  volume, a right drag sets window/level, a middle (Shift + left) drag pans and Ctrl + wheel zooms.
- a camera that fits the data (``Camera.fit_to_data``) keeps fitting while it rotates; zoom and pan
  start from the camera of the last frame (``view_cameras``, from the render process) and store it,
  so the view does not jump. The context menu's View entries (and the toolbar, canvas_toolbar.py)
  set a named view or fit to the data.

``dx, dy`` are Qt pixels (x right, y DOWN, hence the negated dy: the camera wants y up) measured from
the press point; ``h`` is the height of the displayed frame (the visible height of the camera maps
onto it), or of the widget while no frame is shown. Each move is computed from the camera at drag
start plus the total offset (not by accumulating per-event increments): no drift from rounding, a
rejected intermediate value cannot leave the drag in a stale state, and a drag back to the press
point restores the start camera exactly.

Undo: every camera edit goes through ``workspace.set_property(address, camera, merge=key)`` with one
key per drag (and one per wheel burst), so each gesture is a single undo step. ``interacting``
emits True just before a gesture's first camera edit and False when it ends (button release, or
``WHEEL_IDLE_MS`` after the last wheel event), so the renderer can draw coarse frames meanwhile.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from PySide6.QtCore import Qt, QTimer

from vgraph.errors import VGraphError
from vgraph.gui import clip_drag
from vgraph.gui import slice_gestures
from vgraph.live import slice_clicks
from vgraph.live.upstream import NO_CAMERA, nearest_upstream, property_of_type
from vgraph.properties import CameraProperty

ZOOM_PER_PIXEL = 0.01      # right drag: factor exp(-k * dy_pixels)
WHEEL_ZOOM = 1.1           # per 120 units of angleDelta (one notch of a common wheel)
WHEEL_IDLE_MS = 250        # a wheel burst ends after this long without wheel events
CLICK_SLOP = 3             # a right press/release closer than this (pixels) is a click (menu)
_MAX_EXPONENT = 50.0       # keeps exp() and powers finite on absurd drags


def camera_property_for(network, canvas_id: str) -> str | None:
    """'id.name' of the nearest upstream camera property of ``canvas_id`` (breadth-first over
    predecessors, in connection order), or None."""
    return nearest_upstream(network, canvas_id, property_of_type(CameraProperty))


class CanvasMouse:
    """Mouse handlers of a CanvasView (a mix-in before QWidget: the view brings ``workspace``,
    ``canvas_id``, ``view_cameras``, ``interacting``, ``set_message``, ``image_rect`` and
    ``context_menu``)."""

    _keys = itertools.count(1)  # merge keys, unique across all views

    def _init_mouse(self) -> None:
        self._drag = None   # dict(mode, button, start, address, camera, key, active) while dragging
        self._wheel = None  # dict(address, camera, key, delta) during a wheel burst
        self._wheel_timer = QTimer(self)
        self._wheel_timer.setSingleShot(True)
        self._wheel_timer.setInterval(WHEEL_IDLE_MS)
        self._wheel_timer.timeout.connect(self._end_wheel)
        # Right drags zoom, so the menu opens on a right click without movement (mouseReleaseEvent).
        self.setContextMenuPolicy(Qt.PreventContextMenu)
        self.placer = None    # the window's MarkupPlacer (markup_placing.py), set by canvases.py
        self.placing = False  # left clicks place markup points

    def set_placing(self, on: bool) -> None:
        self.placing = bool(on)
        if self.placer is not None:
            self.placer.restart()  # a new placing starts a new markup
        self.setCursor(Qt.CrossCursor if self.placing else Qt.ArrowCursor)

    # --- camera edits ---------------------------------------------------------------------------
    def _begin_gesture(self) -> tuple[str, object] | None:
        """(camera address, its current value), or None after telling the user there is none."""
        address = camera_property_for(self.workspace.network, self.canvas_id)
        if address is None:
            self.set_message(NO_CAMERA)
            return None
        return address, self._start_camera(address, "zoom")

    def _start_camera(self, address: str, mode: str):
        """The camera a gesture starts from: a fitting camera rotates as it is (it keeps fitting),
        but zooms and pans from what the last frame showed, as a stored camera."""
        camera = self.workspace.network.get(address)
        shown = self.view_cameras().get(address)
        if mode == "rotate" or not camera.fit_to_data or shown is None:
            return camera
        return shown.model_copy(update={"near": camera.near, "far": camera.far})

    def _apply(self, gesture: dict, make_camera) -> None:
        """Set the camera ``make_camera(start camera)`` under the gesture's merge key; errors are
        shown, never raised (a mouse handler must not throw)."""
        if not gesture["active"]:
            gesture["active"] = True
            self.interacting.emit(True)
        try:
            camera = make_camera(gesture["camera"])
            self.workspace.set_property(gesture["address"], camera, merge=gesture["key"])
        except (VGraphError, ValueError, ArithmeticError) as error:
            self.set_message(f"{gesture['address']}: {error}")
            return
        if self._message.startswith(gesture["address"] + ":") or self._message == NO_CAMERA:
            self.set_message("")  # a good value replaces the previous complaint

    def _view_height(self) -> float:
        return max(self.image_rect().height(), 1.0)

    # --- mouse ----------------------------------------------------------------------------------
    def mousePressEvent(self, event) -> None:
        if self._drag is not None:
            return  # a second button during a drag does not change the gesture
        if self.placer is not None:
            self._drag = self.placer.begin(self, event)
            if self._drag is not None:
                event.accept()
                return
        if clip_drag.wanted(event):  # Ctrl + left drag moves a clip plane (clip_drag.py)
            self._drag = clip_drag.begin(self, event, ("canvas", next(self._keys)))
            event.accept()
            return
        button = event.button()
        if button == Qt.LeftButton:
            mode = "pan" if event.modifiers() & Qt.ShiftModifier else "rotate"
        elif button == Qt.MiddleButton:
            mode = "pan"
        elif button == Qt.RightButton:
            mode = "zoom"
        else:
            return
        address = camera_property_for(self.workspace.network, self.canvas_id)
        if address is None and mode == "zoom":  # a right drag on a slice: window/level
            self._drag = slice_gestures.begin_window(self, event, ("canvas", next(self._keys)))
            if self._drag is not None:
                event.accept()
                return
        if address is None and mode in ("rotate", "pan"):  # on a slice: the cursor, or pan
            begin = slice_gestures.begin_cursor if mode == "rotate" else slice_gestures.begin_pan
            self._drag = begin(self, event, ("canvas", next(self._keys)))
            if self._drag is not None:
                event.accept()
                return
        if address is None and mode != "zoom":  # a right click may still be for the menu
            self.set_message(NO_CAMERA)
        self._drag = {"mode": mode, "button": button, "start": event.position(), "active": False,
                      "address": address, "key": ("canvas", next(self._keys)),
                      "camera": None if address is None else self._start_camera(address, mode)}
        event.accept()

    def mouseMoveEvent(self, event) -> None:
        drag = self._drag
        if drag is None:
            return
        if drag["mode"] == "clip":
            clip_drag.move(self, drag, event)
            event.accept()
            return
        if drag["mode"].startswith("markup"):
            self.placer.move(self, drag, event)
            event.accept()
            return
        offset = event.position() - drag["start"]
        dx, dy = offset.x(), offset.y()
        if drag["mode"] == "window":
            if drag["active"] or math.hypot(dx, dy) >= CLICK_SLOP:
                slice_gestures.move_window(self, drag, dx, dy)
            event.accept()
            return
        if drag["mode"] == "slice_pan":
            slice_gestures.move_pan(self, drag, dx, dy)
            event.accept()
            return
        if drag["mode"] == "cursor":
            if drag["active"] or math.hypot(dx, dy) >= CLICK_SLOP:
                slice_gestures.move_cursor(self, drag, event.position())
            event.accept()
            return
        if drag["address"] is None:
            if math.hypot(dx, dy) >= CLICK_SLOP:
                self.set_message(NO_CAMERA)
            return
        h = self._view_height()
        if drag["mode"] == "rotate":
            self._apply(drag, lambda c: c.rotate(math.pi * dx / h, -math.pi * dy / h))
        elif drag["mode"] == "pan":
            self._apply(drag, lambda c: c.pan(dx / h, -dy / h))
        else:
            exponent = float(np.clip(-ZOOM_PER_PIXEL * dy, -_MAX_EXPONENT, _MAX_EXPONENT))
            self._apply(drag, lambda c: c.zoom(math.exp(exponent)))
        event.accept()

    def mouseReleaseEvent(self, event) -> None:
        drag = self._drag
        if drag is None or event.button() != drag["button"]:
            return
        self._drag = None
        if drag["mode"].startswith("markup"):
            self.placer.end(self, drag, event)
        elif drag["active"]:
            self.interacting.emit(False)
        elif drag["mode"] in ("zoom", "window") and (event.position() - drag["start"]).manhattanLength() < CLICK_SLOP:
            self.context_menu().exec(event.globalPosition().toPoint())
        elif drag["mode"] == "cursor" and (event.position() - drag["start"]).manhattanLength() < CLICK_SLOP:
            slice_clicks.click(self, event.position())  # a left click in a slice moves its cursor
        event.accept()

    def wheelEvent(self, event) -> None:
        shift = bool(event.modifiers() & Qt.ShiftModifier)
        delta = event.angleDelta()  # some platforms turn Shift + wheel into a horizontal one
        notches = (delta.y() or (delta.x() if shift else 0)) / 120.0
        if notches == 0.0:
            return
        if self._wheel is None:
            self._wheel = self._start_wheel(bool(event.modifiers() & Qt.ControlModifier))
            if self._wheel is None:
                return
        wheel = self._wheel
        self._wheel_timer.start()
        event.accept()
        if wheel["mode"] == "page":
            slice_gestures.page(self, wheel, notches, shift)
            return
        if wheel["mode"] == "slice_zoom":
            slice_gestures.zoom(self, wheel, notches, WHEEL_ZOOM)
            return
        wheel["notches"] += notches
        exponent = float(np.clip(wheel["notches"] * math.log(WHEEL_ZOOM), -_MAX_EXPONENT, _MAX_EXPONENT))
        self._apply(wheel, lambda c: c.zoom(math.exp(exponent)))

    def _start_wheel(self, ctrl: bool = False) -> dict | None:
        """A wheel burst's state: paging (Ctrl: zooming) on a slice canvas without a camera, else
        camera zoom."""
        key = ("canvas", next(self._keys))
        if camera_property_for(self.workspace.network, self.canvas_id) is None:
            begin = slice_gestures.begin_zoom if ctrl else slice_gestures.begin_page
            gesture = begin(self, key)
            if gesture is not None:
                return gesture
        start = self._begin_gesture()
        if start is None:
            return None
        return {"mode": "zoom", "address": start[0], "camera": start[1], "notches": 0.0,
                "active": False, "key": key}

    def _end_wheel(self) -> None:
        wheel, self._wheel = self._wheel, None
        if wheel is not None and wheel["active"]:
            self.interacting.emit(False)
