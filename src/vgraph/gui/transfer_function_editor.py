"""The graphical transfer-function editor: control points over the volume's histogram, and the
actions around them.

The plot (``tf_plot.TransferFunctionPlot``: histogram, curve, colour strip, mouse editing; its
conventions are there) sits above a row of actions: Point... (or Return on the selected point)
types in its position, colour and opacity (``tf_point_dialog``) in the TF's own space; the
shift and scale row (``tf_shift_controls``: tf_shift, tf_scale and where the points sit); Presets;
Load.../Save... of TF files (.json, opened in the network's folder); the histogram's log scale.

Conventions:
- The plot's edits become the property's value through ``emit`` (a drag is one undo step: the
  plot gives each drag its own merge key); presets, files, typed points and colours are one step each.
- The application delivers the histogram (``set_histogram``) and the volume's ValueScale
  (``set_value_scale``, for TFs in data units or percentiles) when the render process has them.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtGui import QColor
from PySide6.QtWidgets import (QCheckBox, QColorDialog, QComboBox, QDialog, QFileDialog, QHBoxLayout,
                               QPushButton, QVBoxLayout)

from vgraph.errors import VGraphError
from vgraph.gui.editors import PropertyEditor, list_popup, register_editor
from vgraph.gui.tf_plot import TransferFunctionPlot
from vgraph.gui.tf_point_dialog import PointDialog
from vgraph.gui.tf_shift_controls import ShiftControls
from vgraph.transfer_function import PRESETS, TransferFunction, ValueScale

JSON_FILTER = "Transfer functions (*.json);;All files (*)"

__all__ = ["TransferFunctionEditor", "TransferFunctionPlot"]   # the plot lives in tf_plot


class TransferFunctionEditor(PropertyEditor):
    """The plot, and below it presets, Load/Save of TF files and the histogram's log scale."""

    def build(self):
        self.plot = TransferFunctionPlot()
        self.plot.changed.connect(lambda tf, merge: self.emit(tf, merge))
        self.plot.color_requested.connect(self.choose_color)
        self.plot.interacting.connect(self.interacting)
        self.plot.point_requested.connect(self.edit_point)
        self.point_button = QPushButton("Point...")
        self.point_button.setToolTip("type in the selected point's position, colour and opacity (Return)")
        self.point_button.clicked.connect(lambda: self.edit_point(self.plot.selected))
        self.presets = list_popup(QComboBox())
        self.presets.addItem("Presets...")
        self.presets.addItems(list(PRESETS))
        self.presets.currentIndexChanged.connect(self._preset_chosen)
        self.load_button = QPushButton("Load...")
        self.load_button.clicked.connect(self.load)
        self.save_button = QPushButton("Save...")
        self.save_button.clicked.connect(self.save)
        self.log_scale = QCheckBox("log")
        self.log_scale.setToolTip("histogram on a logarithmic scale")
        self.log_scale.toggled.connect(self.plot.set_log_scale)
        self.shift = ShiftControls()
        self.shift.moved.connect(self._moved)
        self.plot.interacting.connect(lambda _: self._show_shift())   # a pressed point: its readout
        row = QHBoxLayout()
        for widget in (self.point_button, self.presets, self.load_button, self.save_button, self.log_scale):
            row.addWidget(widget)
        column = QVBoxLayout()
        column.addWidget(self.plot, 1)
        column.addWidget(self.shift)
        column.addLayout(row)
        self.layout_.addLayout(column)

    def _show(self, value: TransferFunction):
        self.plot.set_transfer_function(value)
        self._show_shift()

    def _show_shift(self) -> None:
        self.shift.show_value(self.plot.transfer_function, self.plot.scale, self.plot.selected)

    def _moved(self, shift: float, scale: float, merge) -> None:
        """The shift row's edit: the same points, moved (see vgraph.transfer_function)."""
        tf = self.plot.transfer_function
        self.emit(TransferFunction(space=tf.space, points=tf.points, tf_shift=shift, tf_scale=scale), merge)

    def set_histogram(self, counts) -> None:
        """Counts per equal bin over normalised intensity (``Volume.histogram()[0]``), or None."""
        self.plot.set_histogram(counts)

    def set_value_scale(self, scale: ValueScale | None) -> None:
        """The volume's ValueScale (for TFs in data units or percentiles), or None."""
        self.plot.set_value_scale(scale)
        self._show_shift()

    def _preset_chosen(self, index: int) -> None:
        if index > 0:
            self.emit(PRESETS[self.presets.itemText(index)])
            self.presets.setCurrentIndex(0)   # the combo is a menu: it shows no current preset

    def edit_point(self, index: int | None) -> None:
        if index is None or index >= len(self.plot.points) or not self.plot.editable:
            self.problem.emit(f"{self.processor.id}.{self.prop.name}: click a point first, then Point...")
            return
        dialog = PointDialog(self.plot.points[index], self.plot.transfer_function.space,
                             *self.plot.neighbour_limits(index), parent=self,
                             title=f"{self.prop.label}: point {index}")
        if dialog.exec() == QDialog.Accepted and dialog.point() != self.plot.points[index]:
            self.plot.set_point(index, dialog.point())

    def choose_color(self, index: int) -> None:
        r, g, b = self.plot.points[index][1:4]
        color = QColorDialog.getColor(QColor.fromRgbF(r, g, b), self, f"{self.prop.label}: point {index}")
        if color.isValid():
            self.plot.set_point_color(index, (color.redF(), color.greenF(), color.blueF()))

    # --- files ----------------------------------------------------------------------------------
    def _start_dir(self) -> str:
        network = self.processor.network
        return str(network.base_dir) if network is not None and network.base_dir is not None else ""

    def ask_load_path(self) -> str:
        path, _ = QFileDialog.getOpenFileName(self, "Load transfer function", self._start_dir(), JSON_FILTER)
        return path

    def ask_save_path(self) -> str:
        path, _ = QFileDialog.getSaveFileName(self, "Save transfer function", self._start_dir(), JSON_FILTER)
        return path

    def load(self) -> None:
        path = self.ask_load_path()
        if not path:
            return
        try:
            transfer_function = TransferFunction.load(path)
        except VGraphError as error:
            self.problem.emit(str(error))
            return
        self.emit(transfer_function)

    def save(self) -> None:
        path = self.ask_save_path()
        if not path:
            return
        path = Path(path) if Path(path).suffix else Path(path).with_suffix(".json")
        try:
            self.processor.property_values[self.prop.name].save(path)
        except OSError as error:
            self.problem.emit(f"{path}: cannot save the transfer function: {error.strerror or error}")


register_editor("transfer_function", TransferFunctionEditor)
