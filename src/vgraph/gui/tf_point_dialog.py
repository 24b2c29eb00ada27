"""A transfer-function control point typed in: position, opacity and colour.

Dragging places a point only to the pixel; a threshold at HU 300 or an opacity of exactly 0.05
needs numbers. The position is in the TF's own space (normalised, data values or percentiles), as
stored and as the plot edits it; the dialog allows only the interval between the point's
neighbours, so the order of the points holds. Accepting returns the point; the editor applies it as
one undo step (``TransferFunctionPlot.set_point``).
"""

from __future__ import annotations

from PySide6.QtGui import QColor
from PySide6.QtWidgets import (QColorDialog, QDialog, QDialogButtonBox, QDoubleSpinBox, QFormLayout,
                               QPushButton)

from vgraph.transfer_function import POSITION_LIMITS

DECIMALS = 6
UNITS = {"normalized": "normalised intensity, 0 to 1", "data": "data value",
         "percentile": "percentile of the voxels, 0 to 100"}


class PointDialog(QDialog):
    def __init__(self, point, space: str, low: float | None, high: float | None, parent=None,
                 title: str = "Edit point"):
        """``low``/``high``: the neighbours' positions (None at an end: the space's limit)."""
        super().__init__(parent)
        self.setWindowTitle(title)
        position, r, g, b, opacity = point
        limits = POSITION_LIMITS[space]
        self.position = QDoubleSpinBox()
        self.position.setDecimals(DECIMALS)
        self.position.setRange(limits[0] if low is None else low, limits[1] if high is None else high)
        self.position.setValue(position)
        self.position.setToolTip(f"{UNITS[space]}; between the neighbouring points")
        self.opacity = QDoubleSpinBox()
        self.opacity.setDecimals(DECIMALS)
        self.opacity.setRange(0.0, 1.0)
        self.opacity.setSingleStep(0.01)
        self.opacity.setValue(opacity)
        self.rgb = (r, g, b)
        self.color_button = QPushButton()
        self.color_button.clicked.connect(self.choose_color)
        self._show_color()
        buttons = QDialogButtonBox(QDialogButtonBox.Ok | QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form = QFormLayout(self)
        form.addRow(f"position ({space})", self.position)
        form.addRow("opacity", self.opacity)
        form.addRow("colour", self.color_button)
        form.addRow(buttons)
        self._exact = point   # untouched boxes give back the stored numbers, not their rounding

    def choose_color(self) -> None:
        color = QColorDialog.getColor(QColor.fromRgbF(*self.rgb), self, "Point colour")
        if color.isValid():   # QColor keeps float32 channels: drop their noise
            self.rgb = tuple(round(c, DECIMALS) for c in (color.redF(), color.greenF(), color.blueF()))
            self._show_color()

    def _show_color(self) -> None:
        color = QColor.fromRgbF(*self.rgb)
        ink = "#000000" if color.lightnessF() > 0.5 else "#ffffff"
        self.color_button.setText(color.name())
        self.color_button.setStyleSheet(f"background-color: {color.name()}; color: {ink};")

    def point(self) -> tuple:
        def kept(spin, exact):
            return exact if abs(spin.value() - exact) <= 0.51 * 10.0 ** -DECIMALS else spin.value()
        return (kept(self.position, self._exact[0]), *self.rgb, kept(self.opacity, self._exact[4]))
