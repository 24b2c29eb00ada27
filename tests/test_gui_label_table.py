"""The label-table editor in the inspector: it shows the LabelRayCaster's table, a colour chosen in
the dialog reaches the network and the rendered picture follows (and undo brings it back); opacity,
visibility, Add and Remove edit the table; a refused table is reported and the editor shows the
current one again."""

import numpy as np
import pytest
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QColorDialog

from vgraph.gui.label_table_editor import LabelTableEditor
from vgraph.labels import LabelEntry, palette_color

from helpers.paths import REPO

DENSE = 2  # the row of label 2, "dense parts" (orange), in networks/labels_engine.json


def open_engine_labels(window):
    assert window.open_network(REPO / "networks" / "labels_engine.json")
    window.workspace.set_property("canvas.size", [64, 64])   # quick frames
    window.evaluation.run(wait=True)
    window.scene.select_processor("labels")
    editor = window.inspector.editors["label_table"]
    assert isinstance(editor, LabelTableEditor)
    return editor


def orange_and_green(frame):
    rgb = frame[..., :3].astype(int)
    return (rgb[..., 0] > rgb[..., 1] + 60).sum(), (rgb[..., 1] > rgb[..., 0] + 60).sum()


def test_a_colour_chosen_in_the_editor_changes_the_picture(window, jobs, monkeypatch, data_dir):
    editor = open_engine_labels(window)
    assert [editor.table.item(row, 1).text() for row in range(3)] == ["background", "casing", "dense parts"]
    assert editor.table.cellWidget(DENSE, 2).text() == "#f2731a"           # (0.95, 0.45, 0.1)
    before = window.canvases.views["canvas"].frame()
    orange, green = orange_and_green(before)
    assert orange > 20 and green == 0

    monkeypatch.setattr(QColorDialog, "getColor", lambda *args: QColor.fromRgbF(0.1, 0.9, 0.2))
    editor.table.cellWidget(DENSE, 2).click()
    window.evaluation.run(wait=True)
    entry = window.workspace.network.get("labels.label_table").labels[DENSE]
    assert entry.color == pytest.approx((0.1, 0.9, 0.2), abs=1e-4)       # QColor keeps 16 bits
    assert entry.name == "dense parts" and entry.opacity == 1.0
    assert window.inspector.editors["label_table"].table.cellWidget(DENSE, 2).text() == "#1ae633"
    after = window.canvases.views["canvas"].frame()
    orange, green = orange_and_green(after)
    assert orange == 0 and green > 20                                     # the dense parts turned green

    window.workspace.undo_stack.undo()
    window.evaluation.run(wait=True)
    np.testing.assert_array_equal(window.canvases.views["canvas"].frame(), before)


def test_opacity_visibility_add_and_remove_edit_the_table(window, data_dir):
    editor = open_engine_labels(window)
    network = window.workspace.network
    editor.table.cellWidget(1, 3).setValue(0.5)
    assert network.get("labels.label_table").labels[1].opacity == 0.5
    editor = window.inspector.editors["label_table"]
    editor.table.cellWidget(DENSE, 4).setChecked(False)
    assert not network.get("labels.label_table").labels[DENSE].visible
    editor = window.inspector.editors["label_table"]
    editor.add.click()
    added = network.get("labels.label_table").labels[-1]
    assert added == LabelEntry(value=3, color=palette_color(3))
    editor = window.inspector.editors["label_table"]
    editor.table.selectRow(3)
    editor.remove.click()
    assert [entry.value for entry in network.get("labels.label_table").labels] == [0, 1, 2]
    assert network.get("labels.label_table").labels[1].opacity == 0.5      # exact, not the box's rounding


def test_a_refused_table_is_reported_and_the_current_one_shown_again(window, data_dir):
    editor = open_engine_labels(window)
    before = window.workspace.network.get("labels.label_table")
    editor.table.item(DENSE, 0).setText("1")                             # label 1 twice
    assert window.workspace.network.get("labels.label_table") == before
    assert "label 1 is listed twice" in window.statusBar().currentMessage()
    assert window.inspector.editors["label_table"].table.item(DENSE, 0).text() == "2"
