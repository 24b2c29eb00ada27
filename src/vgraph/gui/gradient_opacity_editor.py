"""The gradient-opacity editor: the curve (vgraph.gradient_opacity) drawn and edited by the
transfer-function plot (``tf_plot.TransferFunctionPlot``, its mouse conventions), over the histogram
of the volume's gradient fractions.

Conventions:
- The plot's x is the gradient fraction, its y the opacity factor; the curve is shown as a TF of
  grey points whose opacity is the factor (their colour means nothing here and is not editable).
- Off (None) is shown as the factor 1 everywhere, which is what it means; the first edit of that
  curve turns gradient opacity on.
- The histogram (``set_histogram``) counts voxels per equal bin of gradient fraction (the
  render process delivers it under 'id.gradient_opacity' while a curve is set).
- Below the plot: Presets, Off and the histogram's log scale. Edits are one undo step each, a
  drag one in all (the plot's merge keys).
"""

from __future__ import annotations

from PySide6.QtWidgets import QCheckBox, QComboBox, QHBoxLayout, QPushButton, QVBoxLayout

from vgraph.gradient_opacity import PRESETS, GradientOpacity
from vgraph.gui.editors import PropertyEditor, list_popup, register_editor
from vgraph.gui.tf_plot import TransferFunctionPlot
from vgraph.transfer_function import TransferFunction

GREY = (0.85, 0.85, 0.85)
OFF = GradientOpacity(points=[(0.0, 1.0), (1.0, 1.0)])  # what None means: every opacity kept


def as_transfer_function(curve: GradientOpacity | None) -> TransferFunction:
    """The curve as the plot shows it: grey points with the factor as opacity."""
    return TransferFunction(points=[(g, *GREY, factor) for g, factor in (curve or OFF).points])


def as_curve(transfer_function: TransferFunction) -> GradientOpacity:
    """The plot's points back as a curve (position, opacity)."""
    return GradientOpacity(points=[(point[0], point[4]) for point in transfer_function.points])


class GradientOpacityEditor(PropertyEditor):
    """The plot, and below it Presets, Off and the histogram's log scale."""

    def build(self):
        self.plot = TransferFunctionPlot()
        self.plot.changed.connect(lambda tf, merge: self.emit(as_curve(tf), merge))
        self.plot.interacting.connect(self.interacting)
        self.presets = list_popup(QComboBox())
        self.presets.addItem("Presets...")
        self.presets.addItems(list(PRESETS))
        self.presets.currentIndexChanged.connect(self._preset_chosen)
        self.off_button = QPushButton("Off")
        self.off_button.setToolTip("no gradient opacity: the TF's opacity alone")
        self.off_button.clicked.connect(lambda: self.emit(None))
        self.log_scale = QCheckBox("log")
        self.log_scale.setToolTip("histogram on a logarithmic scale")
        self.log_scale.toggled.connect(self.plot.set_log_scale)
        row = QHBoxLayout()
        for widget in (self.presets, self.off_button, self.log_scale):
            row.addWidget(widget)
        column = QVBoxLayout()
        column.addWidget(self.plot, 1)
        column.addLayout(row)
        self.layout_.addLayout(column)

    def _show(self, value: GradientOpacity | None):
        self.plot.set_transfer_function(as_transfer_function(value))

    def set_histogram(self, counts) -> None:
        """Voxel counts per bin of gradient fraction, or None (the inspector delivers them)."""
        self.plot.set_histogram(counts)

    def _preset_chosen(self, index: int) -> None:
        if index > 0:
            self.emit(PRESETS[self.presets.itemText(index)])
            self.presets.setCurrentIndex(0)


register_editor("gradient_opacity", GradientOpacityEditor)
