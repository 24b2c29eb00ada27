"""The canvas view: shows the frames rendered for one Canvas and turns mouse input into camera edits.

The GUI holds no OpenGL: frames arrive from the render process as uint8 RGBA arrays (H, W, 4),
row 0 at the TOP, and are drawn scaled to fit the widget, aspect kept, centred on a dark background.

Interaction (on the camera returned by ``camera_property_for``, i.e. the nearest upstream one):

- left drag: trackball rotate, ``Camera.rotate(pi * dx / h, -pi * dy / h)``;
- right drag: zoom, ``Camera.zoom(exp(-ZOOM_PER_PIXEL * dy))`` (drag up zooms in; 100 px = e^1);
  a right click without movement opens the context menu instead ("Save Image...");
- wheel: zoom by ``WHEEL_ZOOM = 1.1`` per 120-unit notch, forward zooms in;
- middle drag or shift + left drag: pan, ``Camera.pan(dx / h, -dy / h)``, so the scene follows the
  cursor.
- ctrl + left drag: moves the first clip plane upstream along its normal (clip_drag.py).
- a canvas that shows a slice and has no camera (slice_gestures.py): a left click or drag moves
  the shared cursor (slice_clicks.py; the cursor follows the mouse), the wheel pages through the
  volume, a right drag sets window/level, a middle (Shift + left) drag pans and Ctrl + wheel zooms.
- a camera that fits the data (``Camera.fit_to_data``) keeps fitting while it rotates; zoom and pan
  start from the camera of the last frame (``view_cameras``, from the render process) and store it,
  so the view does not jump. The context menu's View entries (and the toolbar, canvas_toolbar.py)
  set a named view or fit to the data.
- overlays (overlays.py): the data's box, an axes triad and the SliceViewers' planes, drawn by
  Qt over the frame with the camera and box the frame was rendered with (``set_view_geometry``;
  the planes from the last ``view_cameras``), never into the frame, so Save Image writes what
  ``vgraph run`` writes (image_export.py).

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
from pathlib import Path

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt, QTimer, Signal
from PySide6.QtGui import QColor, QImage, QPainter
from PySide6.QtWidgets import QFileDialog, QMenu, QWidget

from vgraph.camera import VIEWS
from vgraph.errors import OutputFileError, VGraphError
from vgraph.gui import clip_drag
from vgraph.gui import slice_gestures
from vgraph.live import slice_clicks
from vgraph.gui.image_export import IMAGE_FILTER, suggested_image_path, write_frame
from vgraph.gui.overlays import ViewGeometry, draw_overlays
from vgraph.gui.slice_overlay import draw_slice_overlay
from vgraph.live.upstream import NO_CAMERA, nearest_upstream, property_of_type
from vgraph.properties import CameraProperty

BACKGROUND = QColor(32, 32, 36)
ZOOM_PER_PIXEL = 0.01      # right drag: factor exp(-k * dy_pixels)
WHEEL_ZOOM = 1.1           # per 120 units of angleDelta (one notch of a common wheel)
WHEEL_IDLE_MS = 250        # a wheel burst ends after this long without wheel events
CLICK_SLOP = 3             # a right press/release closer than this (pixels) is a click (menu)
_MAX_EXPONENT = 50.0       # keeps exp() and powers finite on absurd drags


def camera_property_for(network, canvas_id: str) -> str | None:
    """'id.name' of the nearest upstream camera property of ``canvas_id`` (breadth-first over
    predecessors, in connection order), or None."""
    return nearest_upstream(network, canvas_id, property_of_type(CameraProperty))


class CanvasView(QWidget):
    interacting = Signal(bool)
    problem = Signal(str)
    activated = Signal(str)  # the canvas id, when the view gets the focus (File > Export Image's canvas)

    _keys = itertools.count(1)  # merge keys, unique across all views

    def __init__(self, workspace, canvas_id: str, parent: QWidget | None = None, view_cameras=dict):
        super().__init__(parent)
        self.workspace = workspace
        self.view_cameras = view_cameras  # () -> {'id.camera': concrete camera of the last frame}
        self.canvas_id = canvas_id
        self.is_final = True
        self._frame: np.ndarray | None = None
        self._image: QImage | None = None
        self._message = ""
        self._geometry: ViewGeometry | None = None  # the shown frame's camera and box
        self._overlays = {"axes": False, "box": False}
        self._slices = False  # the SliceViewers' planes (kept apart: overlays() is axes and box)
        self._drag = None   # dict(mode, button, start, address, camera, key, active) while dragging
        self._wheel = None  # dict(address, camera, key, delta) during a wheel burst
        self._wheel_timer = QTimer(self)
        self._wheel_timer.setSingleShot(True)
        self._wheel_timer.setInterval(WHEEL_IDLE_MS)
        self._wheel_timer.timeout.connect(self._end_wheel)
        # Right drags zoom, so the menu opens on a right click without movement (mouseReleaseEvent).
        self.setContextMenuPolicy(Qt.PreventContextMenu)
        self.setMinimumSize(64, 64)
        self.setFocusPolicy(Qt.ClickFocus)  # the toolbar's keys work once the canvas is clicked

    # --- display --------------------------------------------------------------------------------
    def show_frame(self, rgba: np.ndarray, final: bool = True) -> None:
        rgba = np.asarray(rgba)
        if rgba.ndim != 3 or rgba.shape[2] != 4 or rgba.dtype != np.uint8 or 0 in rgba.shape:
            raise ValueError(f"canvas frame must be a non-empty uint8 (H, W, 4) array, "
                             f"got {rgba.dtype} {rgba.shape}")
        self._frame = np.ascontiguousarray(rgba)
        height, width = self._frame.shape[:2]
        # copy(): the QImage must own its pixels, not borrow the array's buffer.
        self._image = QImage(self._frame.data, width, height, 4 * width, QImage.Format_RGBA8888).copy()
        self.is_final = bool(final)
        self.update()

    def frame(self) -> np.ndarray | None:
        return self._frame

    def set_view_geometry(self, geometry: ViewGeometry | None) -> None:
        """The camera and box of the frame shown (or about to be): where the overlays go."""
        self._geometry = geometry
        self.update()

    def view_geometry(self) -> ViewGeometry | None:
        return self._geometry

    def set_axes_visible(self, on: bool) -> None:
        self._overlays["axes"] = bool(on)
        self.update()

    def set_box_visible(self, on: bool) -> None:
        self._overlays["box"] = bool(on)
        self.update()

    def set_slices_visible(self, on: bool) -> None:
        self._slices = bool(on)
        self.update()

    def slices_visible(self) -> bool:
        return self._slices

    def overlays(self) -> dict[str, bool]:
        return dict(self._overlays)

    def set_message(self, text: str) -> None:
        self._message = text or ""
        self.update()

    def message(self) -> str:
        return self._message

    def image_rect(self) -> QRectF:
        """Where the frame is drawn: scaled to fit, aspect kept, centred (the widget if no frame)."""
        if self._frame is None:
            return QRectF(self.rect())
        height, width = self._frame.shape[:2]
        scale = min(self.width() / width, self.height() / height)
        w, h = width * scale, height * scale
        return QRectF((self.width() - w) / 2.0, (self.height() - h) / 2.0, w, h)

    def paintEvent(self, event) -> None:
        painter = QPainter(self)
        painter.fillRect(self.rect(), BACKGROUND)
        if self._image is not None:
            painter.setRenderHint(QPainter.SmoothPixmapTransform, True)
            painter.drawImage(self.image_rect(), self._image)
            slices = (slice_clicks.slice_overlays(self.workspace.network, self.view_cameras())
                      if self._slices and self._geometry is not None else ())
            draw_overlays(painter, self._geometry, self.image_rect(), **self._overlays, slices=slices)
            viewer_id = slice_clicks.slice_viewer_for(self.workspace.network, self.canvas_id)
            if self._slices and viewer_id is not None:
                draw_slice_overlay(painter, viewer_id, self.workspace.network, self.view_cameras(),
                                   self.image_rect())
        if self._message:
            box = painter.fontMetrics().boundingRect(self._message).adjusted(-4, -2, 4, 2)
            box.moveBottomLeft(self.rect().bottomLeft() + QPointF(4, -4).toPoint())
            painter.fillRect(box, QColor(0, 0, 0, 160))
            painter.setPen(QColor(230, 230, 230))
            painter.drawText(box, Qt.AlignCenter, self._message)
        painter.end()

    def focusInEvent(self, event) -> None:
        super().focusInEvent(event)
        self.activated.emit(self.canvas_id)

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
        if drag["active"]:
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

    # --- saving ---------------------------------------------------------------------------------
    def context_menu(self) -> QMenu:
        menu = QMenu(self)
        action = menu.addAction("Save Image...", self.save_image)
        action.setEnabled(self._frame is not None)
        views = menu.addMenu("View")
        views.addAction("Fit to Data", self.fit_to_data)
        for name in VIEWS:
            views.addAction(name.capitalize(), lambda name=name: self.set_view(name))
        views.setEnabled(camera_property_for(self.workspace.network, self.canvas_id) is not None)
        return menu

    def set_view(self, name: str) -> None:
        """Turn the camera to a named view (Camera.viewed_from) that fits the data; one undo step."""
        self._set_camera(lambda camera: camera.viewed_from(name))

    def fit_to_data(self) -> None:
        """Let the camera frame the data again, keeping its direction (and choose near/far)."""
        self._set_camera(lambda camera: camera.model_copy(
            update={"fit_to_data": True, "near": None, "far": None}))

    def _set_camera(self, make_camera) -> None:
        start = self._begin_gesture()
        if start is not None:
            gesture = {"address": start[0], "camera": self.workspace.network.get(start[0]),
                       "key": None, "active": True}
            self._apply(gesture, make_camera)

    def suggested_path(self) -> str:
        """Where the save dialog starts: the network's folder, '<network>_<canvas>.png'."""
        return str(suggested_image_path(self.workspace.path, self.canvas_id))

    def ask_save_path(self) -> str:
        path, _ = QFileDialog.getSaveFileName(self, f"Save Image of {self.canvas_id}",
                                              self.suggested_path(), IMAGE_FILTER)
        return path

    def save_image(self, path: str | Path | None = None) -> Path | None:
        """Write the current frame as an RGBA PNG (atomically); returns the path, or None if there
        was nothing to save, the dialog was cancelled or writing failed (reported)."""
        if self._frame is None:
            return self._report("no image to save yet")
        if path is None:
            path = self.ask_save_path()
            if not path:
                return None
        try:
            return write_frame(self._frame, path)
        except OutputFileError as error:
            return self._report(f"could not save {path}: {error.reason}")

    def _report(self, text: str) -> None:
        self.set_message(text)
        self.problem.emit(text)
        return None
