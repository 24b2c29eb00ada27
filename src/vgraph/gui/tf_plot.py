"""The transfer-function plot: a TF's control points over the volume's histogram, edited with the
mouse (the painting and pointing half of ``transfer_function_editor``, whose editor adds the
buttons: presets, files, typed points).

After the TF editors of Inácio 2009 (fig. 4.4) and Monsalve 2016 (ch. 3): the histogram of the volume as grey
bars in the background (linear or log scale), the opacity curve as a polyline through the control
points, each point a circle filled with its colour, and the resulting colour gradient (RGB with
alpha over a checkerboard) as a strip along the bottom.

Conventions:
- Plot coordinates: x = normalised intensity in [0, 1], left -> right; y = opacity in [0, 1],
  bottom -> top of the curve area (``TransferFunctionPlot.curve_rect``). The strip is below it.
- A TF in data units or percentiles is shown on the same axis through the volume's ValueScale
  (``set_value_scale``) and edited in its own space: a moved or added point gets the data value
  or percentile under the mouse, the other points keep theirs exactly. Points beyond the value
  range sit on the plot's edge. Until a scale arrives such a TF is shown but not editable.
- A TF with tf_shift/tf_scale (data units) is drawn where the renderers see it: each point at its
  data value times tf_scale plus tf_shift; a dragged point is written back without the move.
- Mouse: left-drag moves a point (x clamped between its neighbours, both in [0, 1]); a
  double-click on empty space adds a point (colour of the TF there, opacity = mouse y); a
  double-click on a point asks for its colour (``color_requested``); right-click or Delete
  removes a point (never the last); Return on the selected point asks to type it in
  (``point_requested``).
- Each drag emits ``changed`` with one merge key of its own, so a drag is one undo step; every
  other edit emits with ``merge=None``. Emitted values are rounded to 6 decimals to keep saved
  networks readable.
- The histogram (``set_histogram``) holds counts per equal bin over normalised intensity, as
  ``Volume.histogram()[0]`` gives.
"""

from __future__ import annotations

import itertools

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QImage, QPainter, QPen, QPixmap, QPolygonF
from PySide6.QtWidgets import QWidget

from vgraph.gui.delete_key import OwnsDeleteKey, is_delete_key
from vgraph.transfer_function import POSITION_LIMITS, TransferFunction, ValueScale

MARGIN = 7          # px around the curve area: room for the circles of points at the edges
STRIP_HEIGHT = 12   # px of the colour gradient strip
STRIP_GAP = 4
RADIUS = 5          # px of a control point's circle
PICK_DISTANCE = RADIUS + 3
DECIMALS = 6

_drag_numbers = itertools.count(1)  # unique over all plots: a new editor never merges into an old drag


def _rounded(point) -> tuple:
    return tuple(round(float(v), DECIMALS) for v in point)


class TransferFunctionPlot(OwnsDeleteKey, QWidget):
    """Paints a transfer function over a histogram and edits its control points with the mouse."""

    changed = Signal(object, object)    # TransferFunction, merge key (None: a separate undo step)
    color_requested = Signal(int)       # index of a double-clicked point
    point_requested = Signal(int)       # index of a point to type in (Return)
    interacting = Signal(bool)          # a point drag started / ended

    BACKGROUND = QColor(255, 255, 255)
    BAR_COLOR = QColor(200, 200, 200)
    CURVE_COLOR = QColor(40, 40, 40)
    SELECTED_COLOR = QColor(255, 140, 0)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.transfer_function = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 0.0)])
        self.counts: np.ndarray | None = None
        self.scale: ValueScale | None = None
        self.log_scale = False
        self.selected: int | None = None
        self._drag: tuple[int, int] | None = None   # (point index, drag number) while dragging
        self.setMinimumSize(220, 200)
        self.setFocusPolicy(Qt.StrongFocus)          # Delete reaches the plot after a click
        self.setMouseTracking(False)

    # --- state ----------------------------------------------------------------------------------
    @property
    def points(self) -> list[tuple]:
        return list(self.transfer_function.points)

    def set_transfer_function(self, transfer_function: TransferFunction) -> None:
        self.transfer_function = transfer_function
        if self.selected is not None and self.selected >= len(transfer_function.points):
            self.selected = None
        self.update()

    def set_histogram(self, counts) -> None:
        self.counts = None if counts is None else np.asarray(counts, dtype=np.float64).ravel()
        self.update()

    def set_value_scale(self, scale: ValueScale | None) -> None:
        self.scale = scale
        self.update()

    @property
    def editable(self) -> bool:
        return not self.transfer_function.needs_volume or self.scale is not None

    def display_positions(self) -> np.ndarray:
        """The points' positions on the normalised axis (not clamped), where tf_shift and tf_scale
        put them; needs ``editable``."""
        tf = self.transfer_function
        positions = np.array([p[0] for p in self.points])
        if tf.is_moved:
            return self.scale.to_normalized(tf.moved(self.scale.to_data(positions, tf.space)), "data")
        return positions if tf.space == "normalized" else self.scale.to_normalized(positions, tf.space)

    def display_function(self) -> TransferFunction:
        """The TF over the normalised axis, as the renderers see it."""
        return self.transfer_function.normalized_at(self.display_positions())

    def _position_at(self, x: float) -> float:
        """The TF-space position of a point that sits at normalised x (after the TF's move)."""
        tf = self.transfer_function
        if not tf.is_moved:
            return float(self.scale.from_normalized(x, tf.space)) if tf.space != "normalized" else x
        position = float(self.scale.from_data(tf.unmoved(self.scale.from_normalized(x, "data")), tf.space))
        low, high = POSITION_LIMITS[tf.space]  # a shifted edge may lie beyond the stored range
        return min(max(position, low), high)

    def set_log_scale(self, on: bool) -> None:
        self.log_scale = bool(on)
        self.update()

    def _commit(self, points: list, merge=None) -> None:
        """Show the edited points at once and report them."""
        old = self.transfer_function
        self.transfer_function = TransferFunction(space=old.space, points=[_rounded(p) for p in points],
                                                  tf_shift=old.tf_shift, tf_scale=old.tf_scale)
        self.update()
        self.changed.emit(self.transfer_function, merge)

    # --- coordinates ----------------------------------------------------------------------------
    def curve_rect(self) -> QRectF:
        return QRectF(MARGIN, MARGIN, self.width() - 2 * MARGIN,
                      self.height() - 2 * MARGIN - STRIP_HEIGHT - STRIP_GAP)

    def strip_rect(self) -> QRectF:
        area = self.curve_rect()
        return QRectF(area.left(), area.bottom() + STRIP_GAP, area.width(), STRIP_HEIGHT)

    def to_pixel(self, position: float, opacity: float) -> QPointF:
        area = self.curve_rect()
        position = min(max(position, 0.0), 1.0)  # points beyond the value range sit on the edge
        return QPointF(area.left() + position * area.width(), area.bottom() - opacity * area.height())

    def from_pixel(self, pixel: QPointF) -> tuple[float, float]:
        """(position, opacity) under a pixel, clamped to [0, 1]."""
        area = self.curve_rect()
        position = (pixel.x() - area.left()) / area.width()
        opacity = (area.bottom() - pixel.y()) / area.height()
        return float(np.clip(position, 0.0, 1.0)), float(np.clip(opacity, 0.0, 1.0))

    def point_at(self, pixel: QPointF) -> int | None:
        """The index of the nearest point within PICK_DISTANCE pixels, else None."""
        if not self.editable:
            return None
        distances = [np.hypot(*(self.to_pixel(x, p[4]) - pixel).toTuple())
                     for x, p in zip(self.display_positions(), self.points)]
        nearest = int(np.argmin(distances))
        return nearest if distances[nearest] <= PICK_DISTANCE else None

    # --- editing --------------------------------------------------------------------------------
    def move_point(self, index: int, position: float, opacity: float, merge=None) -> None:
        """Move point ``index`` to normalised ``position`` (kept between its neighbours)."""
        points, shown = self.points, self.display_positions()
        low = shown[index - 1] if index > 0 else 0.0
        high = shown[index + 1] if index + 1 < len(points) else 1.0
        position = self._position_at(min(max(position, low), high))
        # The order holds in the TF's own space too (a percentile table can round a hair across).
        if index > 0:
            position = max(position, points[index - 1][0])
        if index + 1 < len(points):
            position = min(position, points[index + 1][0])
        points[index] = (position, *points[index][1:4], opacity)
        self._commit(points, merge)

    def add_point(self, position: float, opacity: float) -> int:
        """Insert a point with the TF's colour at normalised ``position``; returns its index."""
        r, g, b, _ = self.display_function()(position)
        points = self.points
        index = int(np.searchsorted(self.display_positions(), position, side="right"))
        points.insert(index, (self._position_at(position), r, g, b, opacity))
        self.selected = index
        self._commit(points)
        return index

    def remove_point(self, index: int) -> None:
        if len(self.points) > 1:
            points = self.points
            del points[index]
            self.selected = None
            self._commit(points)

    def set_point(self, index: int, point) -> None:
        """Replace point ``index`` (in the TF's space), its position kept between its neighbours."""
        low, high = self.neighbour_limits(index)
        position = min(max(point[0], -np.inf if low is None else low), np.inf if high is None else high)
        points = self.points
        points[index] = (position, *point[1:])
        self._commit(points)

    def neighbour_limits(self, index: int) -> tuple[float | None, float | None]:
        points = self.points
        return (points[index - 1][0] if index > 0 else None,
                points[index + 1][0] if index + 1 < len(points) else None)

    def set_point_color(self, index: int, rgb) -> None:
        points = self.points
        points[index] = (points[index][0], *rgb, points[index][4])
        self._commit(points)

    # --- events ---------------------------------------------------------------------------------
    def mousePressEvent(self, event):
        hit = self.point_at(event.position())
        if event.button() == Qt.LeftButton:
            self.selected = hit
            self._drag = (hit, next(_drag_numbers)) if hit is not None else None
            if self._drag is not None:
                self.interacting.emit(True)
            self.update()
        elif event.button() == Qt.RightButton and hit is not None:
            self.remove_point(hit)

    def mouseMoveEvent(self, event):
        if self._drag is not None and event.buttons() & Qt.LeftButton:
            index, number = self._drag
            if index < len(self.points):
                self.move_point(index, *self.from_pixel(event.position()), merge=(id(self), number))

    def mouseReleaseEvent(self, event):
        if event.button() == Qt.LeftButton and self._drag is not None:
            self._drag = None
            self.interacting.emit(False)

    def mouseDoubleClickEvent(self, event):
        if event.button() != Qt.LeftButton or not self.editable:
            return
        hit = self.point_at(event.position())
        if hit is None:
            self.add_point(*self.from_pixel(event.position()))
        else:
            self.selected = hit
            self.color_requested.emit(hit)

    def keyPressEvent(self, event):
        if is_delete_key(event) and self.selected is not None:
            self.remove_point(self.selected)
        elif event.key() in (Qt.Key_Return, Qt.Key_Enter) and self.selected is not None:
            self.point_requested.emit(self.selected)
        else:
            super().keyPressEvent(event)

    # --- painting -------------------------------------------------------------------------------
    def paintEvent(self, event):
        painter = QPainter(self)
        painter.fillRect(self.rect(), self.palette().window())
        area = self.curve_rect()
        painter.fillRect(area, self.BACKGROUND)
        self._paint_histogram(painter, area)
        if self.editable:
            self._paint_strip(painter, self.strip_rect())
            painter.setRenderHint(QPainter.Antialiasing)
            self._paint_curve(painter, area)
        else:
            painter.setPen(QColor(90, 90, 90))
            space = self.transfer_function.space
            what = f"positions in {space} values" if space != "normalized" else "shifted in data units"
            painter.drawText(area, Qt.AlignCenter | Qt.TextWordWrap,
                             f"{what}:\nshown once the volume has been evaluated")
        painter.setPen(QPen(QColor(120, 120, 120)))
        painter.setBrush(Qt.NoBrush)
        painter.drawRect(area)
        painter.end()

    def histogram_heights(self) -> np.ndarray | None:
        """Bar heights as fractions of the curve area (log1p on the log scale: empty bins stay empty)."""
        if self.counts is None or self.counts.size == 0 or self.counts.max() <= 0:
            return None
        values = np.log1p(self.counts) if self.log_scale else self.counts
        return values / values.max()

    def _paint_histogram(self, painter: QPainter, area: QRectF) -> None:
        heights = self.histogram_heights()
        if heights is None:
            painter.setPen(QColor(170, 170, 170))
            painter.drawText(area, Qt.AlignCenter, "no histogram yet")
            return
        edges = area.left() + np.linspace(0.0, 1.0, heights.size + 1) * area.width()
        for left, right, height in zip(edges[:-1], edges[1:], heights):
            if height > 0:
                top = area.bottom() - height * area.height()
                painter.fillRect(QRectF(left, top, right - left, area.bottom() - top), self.BAR_COLOR)

    def _paint_strip(self, painter: QPainter, strip: QRectF) -> None:
        painter.fillRect(strip, QBrush(_checkerboard()))
        width = max(int(strip.width()), 1)
        rgba = self.display_function()((np.arange(width) + 0.5) / width)
        pixels = np.ascontiguousarray(np.round(rgba * 255).astype(np.uint8))
        image = QImage(pixels.data, width, 1, 4 * width, QImage.Format_RGBA8888).copy()  # own the bytes
        painter.drawImage(strip, image)

    def _paint_curve(self, painter: QPainter, area: QRectF) -> None:
        points = [(x, *p[1:]) for x, p in zip(self.display_positions(), self.points)]
        # Below the first point and above the last the end values hold: flat ends to the borders.
        curve = [self.to_pixel(0.0, points[0][4])] + [self.to_pixel(p[0], p[4]) for p in points] \
            + [self.to_pixel(1.0, points[-1][4])]
        painter.setPen(QPen(self.CURVE_COLOR, 1.5))
        painter.drawPolyline(QPolygonF(curve))
        for index, (position, r, g, b, opacity) in enumerate(points):
            centre = self.to_pixel(position, opacity)
            painter.setPen(QPen(self.CURVE_COLOR, 1.0))
            painter.setBrush(QColor.fromRgbF(r, g, b))
            painter.drawEllipse(centre, RADIUS, RADIUS)
            if index == self.selected:   # a ring around it: the fill keeps showing the colour
                painter.setPen(QPen(self.SELECTED_COLOR, 2.0))
                painter.setBrush(Qt.NoBrush)
                painter.drawEllipse(centre, RADIUS + 3, RADIUS + 3)


def _checkerboard(cell: int = 4) -> QPixmap:
    pixmap = QPixmap(2 * cell, 2 * cell)
    pixmap.fill(QColor(255, 255, 255))
    painter = QPainter(pixmap)
    painter.fillRect(0, 0, cell, cell, QColor(190, 190, 190))
    painter.fillRect(cell, cell, cell, cell, QColor(190, 190, 190))
    painter.end()
    return pixmap
