"""The canvas view: shows the frames rendered for one Canvas; its mouse input (canvas_mouse.py,
``CanvasMouse``, the input half mixed in here) becomes camera, slice and clip-plane edits.

The GUI holds no OpenGL: frames arrive from the render process as uint8 RGBA arrays (H, W, 4),
row 0 at the TOP, and are drawn scaled to fit the widget, aspect kept, centred on a dark background.

- overlays (overlays.py): the data's box, an axes triad and the SliceViewers' planes, drawn by
  Qt over the frame with the camera and box the frame was rendered with (``set_view_geometry``;
  the planes from the last ``view_cameras``), never into the frame, so Save Image writes what
  ``vgraph run`` writes (image_export.py).
- the hover readout (hover.py): the mouse moving with no button pressed emits ``hovered``; the
  readout's corner annotation is drawn in the frame's top-right corner (``set_annotation``).
- the context menu (a right click without movement): Save Image... and the View entries (as the
  toolbar's, canvas_toolbar.py): a named view or fit to the data, each one undo step.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QColor, QImage, QPainter
from PySide6.QtWidgets import QFileDialog, QMenu, QWidget

from vgraph.camera import VIEWS
from vgraph.errors import OutputFileError
from vgraph.gui.canvas_mouse import CanvasMouse, camera_property_for
from vgraph.gui.image_export import IMAGE_FILTER, suggested_image_path, write_frame
from vgraph.gui.overlays import ViewGeometry, draw_overlays
from vgraph.gui.slice_markups import draw_slice_markups
from vgraph.gui.slice_overlay import draw_slice_overlay
from vgraph.live import slice_clicks

__all__ = ["BACKGROUND", "CanvasView", "camera_property_for"]

BACKGROUND = QColor(32, 32, 36)


class CanvasView(CanvasMouse, QWidget):
    interacting = Signal(bool)
    problem = Signal(str)
    activated = Signal(str)  # the canvas id, when the view gets the focus (File > Export Image's canvas)
    hovered = Signal(object)  # the mouse moved with no button pressed: its position (hover.py)
    hover_left = Signal()

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
        self._annotation: tuple[str, ...] = ()  # the hover readout's corner lines (hover.py)
        self._init_mouse()
        self.setMouseTracking(True)  # moves without a button: the hover readout
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

    def set_annotation(self, lines) -> None:
        """The corner annotation's lines (top right of the frame; empty: none)."""
        lines = tuple(lines)
        if lines != self._annotation:
            self._annotation = lines
            self.update()

    def annotation(self) -> tuple[str, ...]:
        return self._annotation

    def mouseMoveEvent(self, event) -> None:
        if self._drag is None and event.buttons() == Qt.NoButton:
            self.hovered.emit(event.position())
        super().mouseMoveEvent(event)

    def leaveEvent(self, event) -> None:
        self.hover_left.emit()
        super().leaveEvent(event)

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
            if viewer_id is not None:  # markups are data, drawn with or without the Slices overlay
                draw_slice_markups(painter, viewer_id, self.workspace.network, self.view_cameras(),
                                   self.image_rect())
        if self._annotation:
            self._draw_annotation(painter)
        if self._message:
            box = painter.fontMetrics().boundingRect(self._message).adjusted(-4, -2, 4, 2)
            box.moveBottomLeft(self.rect().bottomLeft() + QPointF(4, -4).toPoint())
            painter.fillRect(box, QColor(0, 0, 0, 160))
            painter.setPen(QColor(230, 230, 230))
            painter.drawText(box, Qt.AlignCenter, self._message)
        painter.end()

    def _draw_annotation(self, painter: QPainter) -> None:
        metrics = painter.fontMetrics()
        width = max(metrics.horizontalAdvance(line) for line in self._annotation) + 8
        # the frame's top-right corner: a slice canvas's top left holds its slice position
        # (slice_overlay.py), the bottom right the axes, the bottom left the messages
        corner = self.image_rect().topRight() + QPointF(-4 - width, 4)
        box = QRectF(corner.x(), corner.y(), width, metrics.height() * len(self._annotation) + 4)
        painter.fillRect(box, QColor(0, 0, 0, 140))
        painter.setPen(QColor(235, 235, 160))
        painter.drawText(box.adjusted(4, 2, -4, -2), Qt.AlignLeft | Qt.AlignTop, "\n".join(self._annotation))

    def focusInEvent(self, event) -> None:
        super().focusInEvent(event)
        self.activated.emit(self.canvas_id)

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
