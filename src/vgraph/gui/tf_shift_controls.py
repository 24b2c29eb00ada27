"""The transfer-function editor's shift and scale row: a slider and a box for ``tf_shift``, a box
for ``tf_scale`` (both in data units, see vgraph.transfer_function), and a readout of the data
values where the points sit once moved.

Conventions:
- The slider spans minus to plus the volume's value range (its width) in SLIDER_STEPS steps, so it
  can push any point across all of the data; it is off until the volume's ValueScale has come.
  The boxes take exact numbers at any time.
- ``moved(shift, scale, merge)`` reports an edit; a slider drag has one merge key of its own (one
  undo step), every other edit None. ``show_value`` displays a value and never emits.
- The readout names the selected point (its stored position and the data value it sits at), else
  the data values of the first and last points; without a scale it says when they will be known.
"""

from __future__ import annotations

import itertools

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QDoubleSpinBox, QHBoxLayout, QLabel, QSlider, QVBoxLayout, QWidget

from vgraph.transfer_function import TransferFunction, ValueScale

SLIDER_STEPS = 1000       # each side of 0
SHIFT_LIMIT = 1e9         # of the box; the model takes up to 1e30, a typed 1e9 is already absurd
SCALE_RANGE = (0.001, 1000.0)
DECIMALS = 4

_drag_numbers = itertools.count(1)


class ShiftControls(QWidget):
    moved = Signal(float, float, object)   # tf_shift, tf_scale, merge key (None: own undo step)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.value_scale: ValueScale | None = None
        self._drag = None
        self.slider = QSlider(Qt.Horizontal)
        self.slider.setRange(-SLIDER_STEPS, SLIDER_STEPS)
        self.slider.setToolTip("shift the points (data units), as far as the data's value range")
        self.slider.sliderPressed.connect(lambda: setattr(self, "_drag", next(_drag_numbers)))
        self.slider.sliderReleased.connect(lambda: setattr(self, "_drag", None))
        self.slider.valueChanged.connect(self._slid)
        self.shift = self._box((-SHIFT_LIMIT, SHIFT_LIMIT), "tf_shift: added to every point's data value")
        self.scale = self._box(SCALE_RANGE, "tf_scale: every point's data value times this (about 0)")
        self.scale.setSingleStep(0.05)
        self.readout = QLabel()
        self.readout.setTextInteractionFlags(Qt.TextSelectableByMouse)
        row = QHBoxLayout()
        for label, widget, stretch in (("shift", self.slider, 2), (None, self.shift, 1),
                                       ("scale", self.scale, 1)):
            if label:
                row.addWidget(QLabel(label))
            row.addWidget(widget, stretch)
        column = QVBoxLayout(self)
        column.setContentsMargins(0, 0, 0, 0)
        column.addLayout(row)
        column.addWidget(self.readout)

    def _box(self, limits, tip: str) -> QDoubleSpinBox:
        box = QDoubleSpinBox()
        box.setRange(*limits)
        box.setDecimals(DECIMALS)
        box.setKeyboardTracking(False)
        box.setToolTip(tip)
        box.valueChanged.connect(lambda _: self._typed())
        return box

    # --- showing --------------------------------------------------------------------------------
    def show_value(self, tf: TransferFunction, value_scale: ValueScale | None, selected: int | None) -> None:
        self.value_scale = value_scale
        for widget, value in ((self.shift, tf.tf_shift), (self.scale, tf.tf_scale)):
            widget.blockSignals(True)
            widget.setValue(value)
            widget.blockSignals(False)
        self.slider.blockSignals(True)
        self.slider.setEnabled(value_scale is not None and self._width() > 0)
        if self.slider.isEnabled():
            self.slider.setValue(round(tf.tf_shift / self._width() * SLIDER_STEPS))
        self.slider.blockSignals(False)
        self.readout.setText(readout_text(tf, value_scale, selected))

    def _width(self) -> float:
        low, high = self.value_scale.value_range
        return high - low

    # --- editing --------------------------------------------------------------------------------
    def _slid(self, step: int) -> None:
        shift = step / SLIDER_STEPS * self._width()
        merge = (id(self), self._drag) if self._drag is not None else None
        self.moved.emit(float(shift), float(self.scale.value()), merge)

    def _typed(self) -> None:
        self.moved.emit(float(self.shift.value()), float(self.scale.value()), None)


def readout_text(tf: TransferFunction, value_scale: ValueScale | None, selected: int | None) -> str:
    """Where the points sit in data values after tf_shift and tf_scale (see the module docstring)."""
    if tf.space != "data" and value_scale is None:
        return "points' data values: shown once the volume has been evaluated"
    positions = [p[0] for p in tf.points]
    data = positions if tf.space == "data" else value_scale.to_data(positions, tf.space)
    sits = tf.moved(data)
    if selected is not None and selected < len(positions):
        stored = f"{positions[selected]:.6g} {tf.space}"
        return f"point {selected}: {stored}, sits at data value {sits[selected]:.6g}"
    return f"points sit at data values {sits[0]:.6g} .. {sits[-1]:.6g}"
