"""vgraph.gui.delete_key: the TF plot and the 2D TF plot claim Delete and Backspace from the window's
Delete shortcut (which deletes the selected processors) while they have the focus, and no other key."""

import pytest
from PySide6.QtCore import QEvent, Qt
from PySide6.QtGui import QKeyEvent

from vgraph.gui.tf_plot import TransferFunctionPlot
from vgraph.gui.transfer_function_2d_editor import TransferFunction2DPlot


def claims(plot, key) -> bool:
    override = QKeyEvent(QEvent.ShortcutOverride, key, Qt.NoModifier)
    override.ignore()
    plot.event(override)
    return override.isAccepted()


@pytest.mark.parametrize("plot_class", [TransferFunctionPlot, TransferFunction2DPlot])
def test_the_plots_claim_delete_and_backspace_only(qtbot, plot_class):
    plot = plot_class()
    qtbot.addWidget(plot)
    assert claims(plot, Qt.Key_Delete) and claims(plot, Qt.Key_Backspace)
    assert not claims(plot, Qt.Key_A) and not claims(plot, Qt.Key_Return)
