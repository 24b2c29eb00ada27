"""The 2D transfer-function editor: a TF's primitives (vgraph.transfer_function_2d) over the
volume's value x gradient histogram, as Kniss et al. 2002 (fig. 3) and Voreen's TransFunc2D editor
draw them, and the actions around them.

Conventions:
- Plot coordinates: x = normalised intensity in [0, 1], left -> right; y = gradient fraction in
  [0, 1], bottom -> top (``TransferFunction2DPlot.area``).
- The histogram (``set_histogram``) holds counts [gradient, value] over that plane
  (vgraph.gl.raycasting.gradient_classification.editor_histogram, delivered by the render process
  under 'id.transfer_function_2d' while a 2D TF is set), drawn grey on a log scale.
- Each primitive is filled with its colour (its opacity, at least a little so a transparent one
  stays visible) and outlined; the selected one is outlined thicker in yellow. A Gaussian is drawn
  as its ellipse of one width.
- Mouse: a press on a primitive selects it (the last drawn, topmost, where several cover the
  point) and a left-drag moves it, kept inside the plane; the selected primitive shows its handles
  (small squares: a rectangle's two corners, a triangle's vertices, a Gaussian's centre and the
  corner of its box of one width), and a drag on a handle reshapes it; Delete removes the
  selected one. Each
  drag emits ``changed`` with one merge key of its own (one undo step); every other edit emits with
  ``merge=None``. Removing the last primitive turns the 2D TF off (None). Emitted values are
  rounded to 6 decimals to keep saved networks readable.
- The row below: Add (a rectangle, triangle or Gaussian in the middle of the plane), Remove,
  Colour... (the selected primitive's colour and opacity), Presets and Off.
"""

from __future__ import annotations

import itertools

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QImage, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import QColorDialog, QComboBox, QHBoxLayout, QPushButton, QVBoxLayout, QWidget

from vgraph.gui.delete_key import OwnsDeleteKey, is_delete_key
from vgraph.gui.editors import PropertyEditor, list_popup, register_editor
from vgraph.transfer_function_2d import PRESETS, Gaussian, Rectangle, TransferFunction2D, Triangle, new_primitive

MARGIN = 4
HANDLE = 4          # px: half the side of a handle's square
PICK_DISTANCE = HANDLE + 3
DECIMALS = 6
KINDS = ("rectangle", "triangle", "gaussian")
_drag_numbers = itertools.count(1)  # unique over all plots: a new editor never merges into an old drag


def rounded(transfer_function: TransferFunction2D) -> TransferFunction2D:
    """The same TF with every number rounded to DECIMALS."""
    def walk(value):
        if isinstance(value, float):
            return round(value, DECIMALS)
        if isinstance(value, (list, tuple)):
            return [walk(v) for v in value]
        if isinstance(value, dict):
            return {k: walk(v) for k, v in value.items()}
        return value
    return TransferFunction2D.model_validate(walk(transfer_function.model_dump()))


class TransferFunction2DPlot(OwnsDeleteKey, QWidget):
    """Paints a 2D TF's primitives over a histogram and moves them with the mouse."""

    changed = Signal(object, object)   # TransferFunction2D or None, merge key
    interacting = Signal(bool)         # a drag started / ended

    def __init__(self, parent=None):
        super().__init__(parent)
        self.transfer_function: TransferFunction2D | None = None
        self.selected: int | None = None
        self._histogram: QImage | None = None
        self._drag = None  # (index, drag number, press point, the primitive at the press)
        self.setMinimumSize(200, 160)
        self.setFocusPolicy(Qt.ClickFocus)

    @property
    def primitives(self) -> list:
        return list(self.transfer_function.primitives) if self.transfer_function is not None else []

    def set_transfer_function(self, transfer_function: TransferFunction2D | None) -> None:
        self.transfer_function = transfer_function
        if self.selected is not None and self.selected >= len(self.primitives):
            self.selected = None
        self.update()

    def set_histogram(self, counts) -> None:
        """(n, n) counts [gradient, value], or None; shown on a log scale."""
        if counts is None or np.ndim(counts) != 2 or not np.any(counts):
            self._histogram = None
        else:
            shade = np.log1p(np.asarray(counts, dtype=np.float64))[::-1]  # gradient upwards
            grey = np.ascontiguousarray((shade / shade.max()) ** 0.6 * 200.0, dtype=np.uint8)
            self._histogram = QImage(grey.data, grey.shape[1], grey.shape[0], grey.strides[0],
                                     QImage.Format_Grayscale8).copy()
        self.update()

    # --- coordinates ------------------------------------------------------------------------------
    def area(self) -> QRectF:
        return QRectF(MARGIN, MARGIN, max(self.width() - 2 * MARGIN, 1), max(self.height() - 2 * MARGIN, 1))

    def to_pixel(self, value: float, gradient: float) -> QPointF:
        area = self.area()
        return QPointF(area.left() + value * area.width(), area.bottom() - gradient * area.height())

    def from_pixel(self, pixel: QPointF) -> tuple[float, float]:
        area = self.area()
        value = (pixel.x() - area.left()) / area.width()
        gradient = (area.bottom() - pixel.y()) / area.height()
        return min(max(value, 0.0), 1.0), min(max(gradient, 0.0), 1.0)

    def primitive_at(self, pixel: QPointF) -> int | None:
        """The topmost (last) primitive covering the point."""
        value, gradient = self.from_pixel(pixel)
        for index in reversed(range(len(self.primitives))):
            if self.primitives[index].covers(value, gradient):
                return index
        return None

    def handle_at(self, pixel: QPointF) -> int | None:
        """The selected primitive's handle under the pixel, if any."""
        if self.selected is None:
            return None
        for index, point in enumerate(self.primitives[self.selected].handles()):
            at = self.to_pixel(*point)
            if abs(at.x() - pixel.x()) <= PICK_DISTANCE and abs(at.y() - pixel.y()) <= PICK_DISTANCE:
                return index
        return None

    # --- edits ------------------------------------------------------------------------------------
    def commit(self, primitives: list, merge=None) -> None:
        self.transfer_function = rounded(TransferFunction2D(primitives=primitives)) if primitives else None
        self.update()
        self.changed.emit(self.transfer_function, merge)

    def replace(self, index: int, primitive, merge=None) -> None:
        primitives = self.primitives
        primitives[index] = primitive
        self.commit(primitives, merge)

    def add(self, kind: str) -> None:
        self.selected = len(self.primitives)
        self.commit(self.primitives + [new_primitive(kind, 0.5, 0.5)])

    def remove_selected(self) -> None:
        if self.selected is None:
            return
        primitives = self.primitives
        del primitives[self.selected]
        self.selected = None
        self.commit(primitives)

    # --- mouse and keys ---------------------------------------------------------------------------
    def mousePressEvent(self, event):
        if event.button() != Qt.LeftButton:
            return
        handle = self.handle_at(event.position())
        if handle is None:
            self.selected = self.primitive_at(event.position())
        if self.selected is not None:
            self._drag = (self.selected, handle, next(_drag_numbers), self.from_pixel(event.position()),
                          self.primitives[self.selected])
            self.interacting.emit(True)
        self.update()

    def mouseMoveEvent(self, event):
        if self._drag is None or not event.buttons() & Qt.LeftButton:
            return
        index, handle, number, (value0, gradient0), original = self._drag
        value, gradient = self.from_pixel(event.position())
        if handle is None:
            changed = original.moved(value - value0, gradient - gradient0)
        else:  # the handle follows the mouse by as much as the mouse moved
            start = original.handles()[handle]
            changed = original.with_handle(handle, start[0] + value - value0, start[1] + gradient - gradient0)
        self.replace(index, changed, merge=(id(self), number))

    def mouseReleaseEvent(self, event):
        if event.button() == Qt.LeftButton and self._drag is not None:
            self._drag = None
            self.interacting.emit(False)

    def keyPressEvent(self, event):
        if is_delete_key(event):
            self.remove_selected()
        else:
            super().keyPressEvent(event)

    # --- painting ---------------------------------------------------------------------------------
    def paintEvent(self, event):
        painter = QPainter(self)
        painter.setRenderHint(QPainter.Antialiasing)
        area = self.area()
        painter.fillRect(area, QColor(20, 20, 24))
        if self._histogram is not None:
            painter.drawImage(area, self._histogram)
        for index, primitive in enumerate(self.primitives):
            self._paint_primitive(painter, primitive, index == self.selected)
        if self.selected is not None:
            painter.setBrush(QBrush(QColor(255, 230, 0)))
            painter.setPen(QPen(QColor(0, 0, 0), 1))
            for point in self.primitives[self.selected].handles():
                at = self.to_pixel(*point)
                painter.drawRect(QRectF(at.x() - HANDLE, at.y() - HANDLE, 2 * HANDLE, 2 * HANDLE))
        painter.end()

    def _paint_primitive(self, painter: QPainter, primitive, selected: bool) -> None:
        r, g, b, a = (int(255 * c) for c in primitive.color)
        painter.setBrush(QBrush(QColor(r, g, b, max(40, int(0.6 * a)))))
        painter.setPen(QPen(QColor(255, 230, 0) if selected else QColor(r, g, b), 3 if selected else 1.5))
        if isinstance(primitive, Rectangle):
            (v0, v1), (g0, g1) = primitive.value, primitive.gradient
            painter.drawRect(QRectF(self.to_pixel(v0, g1), self.to_pixel(v1, g0)))
        elif isinstance(primitive, Triangle):
            painter.drawPolygon(QPolygonF([self.to_pixel(*vertex) for vertex in primitive.vertices]))
        elif isinstance(primitive, Gaussian):
            (cv, cg), (wv, wg) = primitive.centre, primitive.width
            painter.drawEllipse(QRectF(self.to_pixel(cv - wv, cg + wg), self.to_pixel(cv + wv, cg - wg)))


class TransferFunction2DEditor(PropertyEditor):
    """The plot, and below it Add, Remove and Colour..., then Presets and Off."""

    def build(self):
        self.plot = TransferFunction2DPlot()
        self.plot.changed.connect(lambda tf, merge: self.emit(tf, merge))
        self.plot.interacting.connect(self.interacting)
        self.add_kind = list_popup(QComboBox())
        self.add_kind.addItem("Add...")
        self.add_kind.addItems(list(KINDS))
        self.add_kind.currentIndexChanged.connect(self._add_chosen)
        self.remove_button = QPushButton("Remove")
        self.remove_button.clicked.connect(self.plot.remove_selected)
        self.color_button = QPushButton("Colour...")
        self.color_button.setToolTip("the selected primitive's colour and opacity")
        self.color_button.clicked.connect(self.choose_color)
        self.presets = list_popup(QComboBox())
        self.presets.addItem("Presets...")
        self.presets.addItems(list(PRESETS))
        self.presets.currentIndexChanged.connect(self._preset_chosen)
        self.off_button = QPushButton("Off")
        self.off_button.setToolTip("no 2D TF: the 1D transfer function classifies")
        self.off_button.clicked.connect(lambda: self.emit(None))
        column = QVBoxLayout()
        column.addWidget(self.plot, 1)
        # two rows: five buttons in one made the inspector wider than a 1280-pixel window gives it
        for widgets in ((self.add_kind, self.remove_button, self.color_button), (self.presets, self.off_button)):
            row = QHBoxLayout()
            for widget in widgets:
                row.addWidget(widget)
            column.addLayout(row)
        self.layout_.addLayout(column)

    def _show(self, value: TransferFunction2D | None):
        self.plot.set_transfer_function(value)

    def set_histogram(self, counts) -> None:
        """The (gradient, value) histogram of the volume, or None (the inspector delivers it)."""
        self.plot.set_histogram(counts)

    def _add_chosen(self, index: int) -> None:
        if index > 0:
            self.plot.add(KINDS[index - 1])
            self.add_kind.setCurrentIndex(0)

    def _preset_chosen(self, index: int) -> None:
        if index > 0:
            self.plot.selected = None
            self.emit(PRESETS[self.presets.itemText(index)])
            self.presets.setCurrentIndex(0)

    def choose_color(self) -> None:
        index = self.plot.selected
        if index is None:
            return
        primitive = self.plot.primitives[index]
        start = QColor.fromRgbF(*primitive.color)
        color = QColorDialog.getColor(start, self, "Primitive colour", QColorDialog.ShowAlphaChannel)
        if color.isValid():
            self.plot.replace(index, primitive.with_color(color.getRgbF()))


register_editor("transfer_function_2d", TransferFunction2DEditor)
