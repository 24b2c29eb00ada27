"""Masks and cut-aways in the GUI: networks/mask_engine.json opens with the label volume on the
RayCaster's mask inport, the inspector shows the mask and cut-away properties, an edit there
changes the picture and undo brings it back."""

import numpy as np

from helpers.paths import REPO

MASK_PROPERTIES = ("mask_labels", "mask_mode", "mask_boundary", "mask_smoothing", "cutaway", "cutaway_center",
                   "cutaway_size")


def test_the_mask_and_cutaway_properties_edit_the_picture(window, data_dir):
    assert window.open_network(REPO / "networks" / "mask_engine.json")
    window.workspace.set_property("canvas.size", [64, 64])  # quick frames
    window.evaluation.run(wait=True)
    window.scene.select_processor("rc")
    assert set(MASK_PROPERTIES) <= set(window.inspector.editors)
    hidden_casing = window.canvases.views["canvas"].frame()

    window.workspace.set_property("rc.mask_mode", "keep")  # the casing alone, instead of hidden
    window.evaluation.run(wait=True)
    casing = window.canvases.views["canvas"].frame()
    assert (np.abs(casing.astype(int) - hidden_casing.astype(int)).max(axis=2) > 40).mean() > 0.05

    window.workspace.undo_stack.undo()
    window.evaluation.run(wait=True)
    np.testing.assert_array_equal(window.canvases.views["canvas"].frame(), hidden_casing)
