"""Property editors, one class per property kind, generated from the property declarations.

Conventions:
- An editor shows a value (``show_value``, which never emits) and emits ``edited(value, merge)``
  when the user changes it; ``merge`` is None, or while a slider is dragged a key naming that one
  drag, so a drag becomes one undo step (and the next drag another). ``interacting(True)`` when
  such a drag starts and ``interacting(False)`` when it ends, so the window renders coarse frames
  meanwhile and refines on release. Editors do not validate: the inspector sends the value through the workspace,
  which validates and reports a rejection, and then shows the current value again.
- ``problem(str)`` reports input an editor cannot even turn into a value (e.g. malformed JSON).
- ``EDITOR_TYPES`` maps a property kind to its editor; ``register_editor`` adds or replaces one
  (the transfer-function and camera editors, in their own modules, register themselves this way).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (QAbstractItemView, QCheckBox, QColorDialog, QComboBox, QDoubleSpinBox,
                               QFileDialog, QHBoxLayout, QHeaderView, QLineEdit, QPushButton,
                               QSizePolicy, QSlider, QSpinBox, QTableWidget, QToolButton, QWidget)

from vgraph.processor import Processor
from vgraph.properties import Property

SLIDER_STEPS = 1000
UNBOUNDED = 1e9


def row_table(columns: tuple[str, ...], stretch: int) -> QTableWidget:
    """The table of a list-valued property's editor (label tables, markups): one row per entry,
    selected by whole rows, columns as wide as their contents but ``stretch``, which takes the rest."""
    table = QTableWidget(0, len(columns))
    table.setHorizontalHeaderLabels(list(columns))
    table.verticalHeader().setVisible(False)
    table.setSelectionBehavior(QAbstractItemView.SelectRows)
    table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeToContents)
    table.horizontalHeader().setSectionResizeMode(stretch, QHeaderView.Stretch)
    return table


class PropertyEditor(QWidget):
    edited = Signal(object, object)   # value, merge key (None: a separate undo step)
    problem = Signal(str)
    interacting = Signal(bool)        # a drag (slider, TF point) started / ended

    def __init__(self, prop: Property, processor: Processor, parent=None):
        super().__init__(parent)
        self.prop, self.processor = prop, processor
        self._showing = False
        self.layout_ = QHBoxLayout(self)
        self.layout_.setContentsMargins(0, 0, 0, 0)
        self.build()
        self.show_value(processor.property_values[prop.name])

    def build(self) -> None:
        raise NotImplementedError

    def show_value(self, value) -> None:
        self._showing = True
        try:
            self._show(value)
        finally:
            self._showing = False

    def _show(self, value) -> None:
        raise NotImplementedError

    def emit(self, value, merge=None) -> None:
        if not self._showing:
            self.edited.emit(value, merge)

    def _slider(self, low: int, high: int) -> QSlider:
        """A slider whose drags are numbered, so each drag merges into its own undo step."""
        slider = QSlider(Qt.Horizontal)
        slider.setRange(low, high)
        self._drags = 0
        slider.sliderPressed.connect(self._drag_started)
        slider.sliderReleased.connect(lambda: self.interacting.emit(False))
        return slider

    def _drag_started(self) -> None:
        self._drags += 1
        self.interacting.emit(True)

    def drag_key(self, slider: QSlider):
        return (id(self), self._drags) if slider.isSliderDown() else None


def spin_value(spin, exact):
    """The spin box's value, or ``exact`` when the box still shows ``exact`` rounded: editing one
    component of a vector must not round the others to the box's decimals."""
    if exact is None or isinstance(spin, QSpinBox):
        return spin.value()
    return exact if abs(spin.value() - exact) <= 0.51 * 10.0 ** -spin.decimals() else spin.value()


def narrow(spin):
    """Let a spin box of a vector shrink below the width of its widest value (+-1e9), so three
    fit side by side in the inspector."""
    spin.setMinimumWidth(64)
    spin.setSizePolicy(QSizePolicy.Ignored, QSizePolicy.Fixed)
    return spin


def list_popup(combo: QComboBox) -> QComboBox:
    """A popup that opens below the box as a list: the Fusion/macOS style opens it over the box
    with the current item under the cursor, so a click-release picks a neighbour by accident."""
    combo.setStyleSheet("QComboBox { combobox-popup: 0; }")
    return combo


def _bounded(prop) -> bool:
    return prop.min is not None and prop.max is not None


class FloatEditor(PropertyEditor):
    """A spin box, and a slider when the range is bounded."""

    def build(self):
        low = self.prop.min if self.prop.min is not None else -UNBOUNDED
        high = self.prop.max if self.prop.max is not None else UNBOUNDED
        self.spin = QDoubleSpinBox()
        self.spin.setRange(low, high)
        self.spin.setDecimals(4)
        self.spin.setKeyboardTracking(False)
        self.spin.setSingleStep((high - low) / 100 if _bounded(self.prop) else 0.1)
        self.spin.valueChanged.connect(lambda v: self.emit(float(v)))
        self.slider = None
        if _bounded(self.prop):
            self.slider = self._slider(0, SLIDER_STEPS)
            self.slider.valueChanged.connect(self._slid)
            self.layout_.addWidget(self.slider, 2)
        self.layout_.addWidget(self.spin, 1)

    def _slid(self, step: int):
        value = self.prop.min + (self.prop.max - self.prop.min) * step / SLIDER_STEPS
        self.emit(value, merge=self.drag_key(self.slider))

    def _show(self, value):
        self.spin.setValue(value)
        if self.slider is not None and self.prop.max > self.prop.min:
            self.slider.setValue(round((value - self.prop.min) / (self.prop.max - self.prop.min) * SLIDER_STEPS))


class IntEditor(PropertyEditor):
    def build(self):
        low = self.prop.min if self.prop.min is not None else -2**31 + 1
        high = self.prop.max if self.prop.max is not None else 2**31 - 1
        self.spin = QSpinBox()
        self.spin.setRange(int(low), int(high))
        self.spin.setKeyboardTracking(False)
        self.spin.valueChanged.connect(lambda v: self.emit(int(v)))
        self.slider = None
        if _bounded(self.prop) and self.prop.max - self.prop.min <= 10 * SLIDER_STEPS:
            self.slider = self._slider(int(low), int(high))
            self.slider.valueChanged.connect(lambda v: self.emit(int(v), merge=self.drag_key(self.slider)))
            self.layout_.addWidget(self.slider, 2)
        self.layout_.addWidget(self.spin, 1)

    def _show(self, value):
        self.spin.setValue(value)
        if self.slider is not None:
            self.slider.setValue(value)


class BoolEditor(PropertyEditor):
    def build(self):
        self.check = QCheckBox()
        self.check.toggled.connect(lambda on: self.emit(bool(on)))
        self.layout_.addWidget(self.check)

    def _show(self, value):
        self.check.setChecked(value)


class OptionEditor(PropertyEditor):
    def build(self):
        self.combo = list_popup(QComboBox())
        self.combo.addItems(list(self.prop.choices))
        self.combo.currentTextChanged.connect(lambda text: self.emit(text))
        self.layout_.addWidget(self.combo)

    def _show(self, value):
        self.combo.setCurrentText(value)


class StringEditor(PropertyEditor):
    def build(self):
        self.line = QLineEdit()
        self.line.editingFinished.connect(self._finished)
        self.layout_.addWidget(self.line)

    def _finished(self):
        if self.line.text() != self.processor.property_values[self.prop.name]:
            self.emit(self.line.text())

    def _show(self, value):
        self.line.setText(value)


class FilePathEditor(StringEditor):
    """A path and a browse button whose dialog offers the property's filters. Sinks (writers) get
    a save dialog, sources an open dialog. Chosen files inside the network's folder are stored
    relative to it, as the CLI resolves them."""

    def build(self):
        super().build()
        self.browse = QToolButton()
        self.browse.setText("...")
        self.browse.clicked.connect(self.choose_file)
        self.layout_.addWidget(self.browse)

    def name_filter(self) -> str:
        patterns = " ".join(self.prop.filters)
        return f"{self.prop.label} ({patterns});;All files (*)"

    def choose_file(self):
        current = self.processor.property_values[self.prop.name]
        start = str(self.processor.resolve_path(current)) if current else str(self._base_dir() or "")
        ask = QFileDialog.getSaveFileName if not self.processor.outports else QFileDialog.getOpenFileName
        path, _ = ask(self, f"{self.processor.id}.{self.prop.name}", start, self.name_filter())
        if path:
            self.emit(self.relative_to_network(path))

    def _base_dir(self) -> Path | None:
        network = self.processor.network
        return network.base_dir if network is not None else None

    def relative_to_network(self, path: str) -> str:
        base = self._base_dir()
        if base is None:
            return path
        relative = os.path.relpath(Path(path).resolve(), base.resolve())
        return path if relative.startswith("..") else relative


class VectorEditor(PropertyEditor):
    """One spin box per component; optional vectors get an "auto" box meaning None."""

    def build(self):
        low = self.prop.min if self.prop.min is not None else -UNBOUNDED
        high = self.prop.max if self.prop.max is not None else UNBOUNDED
        self.spins = []
        for _ in range(self.prop.size):
            spin = QSpinBox() if self.prop.integer else QDoubleSpinBox()
            if self.prop.integer:
                spin.setRange(int(max(low, -2**31 + 1)), int(min(high, 2**31 - 1)))
            else:
                spin.setRange(low, high)
                spin.setDecimals(4)
            spin.setKeyboardTracking(False)
            spin.valueChanged.connect(self._changed)
            narrow(spin)
            self.spins.append(spin)
            self.layout_.addWidget(spin)
        self.auto = None
        if self.prop.optional:
            self.auto = QCheckBox("auto")
            self.auto.setToolTip("no value: take it from the data")
            self.auto.toggled.connect(self._changed)
            self.layout_.addWidget(self.auto)

    def value(self):
        if self.auto is not None and self.auto.isChecked():
            return None
        current = self.processor.property_values[self.prop.name] or (None,) * len(self.spins)
        return tuple(spin_value(spin, exact) for spin, exact in zip(self.spins, current))

    def _changed(self, *_):
        for spin in self.spins:
            spin.setEnabled(self.auto is None or not self.auto.isChecked())
        self.emit(self.value())

    def _show(self, value):
        if self.auto is not None:
            self.auto.setChecked(value is None)
        # With no value the boxes show the value in use (show_in_use) once a frame says it, else 1
        # (clamped to the range): a valid start when "auto" is unchecked.
        for spin, component in zip(self.spins, value or self.in_use or (1,) * len(self.spins)):
            spin.setValue(component)
        for spin in self.spins:
            spin.setEnabled(value is not None)

    in_use = None

    def show_in_use(self, value) -> None:
        """The value an automatic (None) property took in the last run, shown greyed in the
        disabled boxes; unchecking "auto" starts from it."""
        self.in_use = tuple(value)
        if self.auto is None or not self.auto.isChecked():
            return
        for spin, component in zip(self.spins, self.in_use):
            spin.blockSignals(True)   # showing is no edit
            spin.setValue(component)
            spin.blockSignals(False)
            spin.setToolTip(f"in use: {component:g} (from the data; uncheck auto to set it)")


class ColorEditor(PropertyEditor):
    def build(self):
        self.button = QPushButton()
        self.button.clicked.connect(self.choose_color)
        self.layout_.addWidget(self.button)

    def choose_color(self):
        r, g, b, a = self.processor.property_values[self.prop.name]
        color = QColorDialog.getColor(QColor.fromRgbF(r, g, b, a), self, self.prop.label,
                                      QColorDialog.ShowAlphaChannel)
        if color.isValid():  # QColor keeps float32 channels: drop their noise from the .json
            channels = (color.redF(), color.greenF(), color.blueF(), color.alphaF())
            self.emit(tuple(round(c, 6) for c in channels))

    def _show(self, value):
        color = QColor.fromRgbF(*value)
        text = "#" + "".join(f"{round(c * 255):02x}" for c in value)
        self.button.setText(text)
        ink = "#000000" if color.lightnessF() > 0.5 else "#ffffff"
        self.button.setStyleSheet(f"background-color: {color.name()}; color: {ink};")


class JsonEditor(PropertyEditor):
    """Any value as JSON text: the fallback for property kinds without an editor."""

    blank = ""  # what an empty line means, as JSON text ("": an error)

    def build(self):
        self.line = QLineEdit()
        self.line.editingFinished.connect(self._finished)
        self.layout_.addWidget(self.line)

    def _finished(self):
        try:
            value = json.loads(self.line.text() or self.blank)
        except json.JSONDecodeError as error:
            self.problem.emit(f"{self.processor.id}.{self.prop.name}: not valid JSON: {error.msg}")
            return
        if value != self.prop.to_json(self.processor.property_values[self.prop.name]):
            self.emit(value)

    def _show(self, value):
        self.line.setText(json.dumps(self.prop.to_json(value)))


class DictEditor(JsonEditor):
    """Named numbers as one line of JSON ({} means the defaults)."""

    blank = "{}"


EDITOR_TYPES: dict[str, type[PropertyEditor]] = {
    "float": FloatEditor, "int": IntEditor, "bool": BoolEditor, "option": OptionEditor,
    "string": StringEditor, "file_path": FilePathEditor, "vector": VectorEditor, "dict": DictEditor,
    "color": ColorEditor,
}


def register_editor(kind: str, editor: type[PropertyEditor]) -> None:
    """Use ``editor`` for every property of ``kind`` (e.g. a richer transfer-function editor)."""
    EDITOR_TYPES[kind] = editor


def editor_for(prop: Property, processor: Processor) -> PropertyEditor:
    """The editor for a property; an unknown kind (a plug-in's) falls back to its JSON as text."""
    return EDITOR_TYPES.get(prop.kind, JsonEditor)(prop, processor)
