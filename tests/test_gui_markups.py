"""The markups editor in the inspector: the Markups processor's markups as a table; Add, typed
points, visibility and Remove edit the network (one undo step each), a refused edit is reported and
the current markups shown again, Import and Export go through the markups files."""

import json

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog

from vgraph.gui.markups_editor import MarkupsEditor

from helpers.markups_files import SLICER_LINE


def markups_editor(window):
    window.workspace.add_processor("Markups", (0, 0), id="mk")
    window.scene.select_processor("mk")
    editor = window.inspector.editors["markups"]
    assert isinstance(editor, MarkupsEditor)
    return editor


def test_add_type_points_hide_remove_and_undo(window):
    editor = markups_editor(window)
    network, undo = window.workspace.network, window.workspace.undo_stack
    window.workspace.set_property("mk.place_kind", "angle")
    editor = window.inspector.editors["markups"]
    editor.add_markup()
    editor = window.inspector.editors["markups"]
    assert network.get("mk.markups").names == ["angle 1"]
    assert editor.table.item(0, 2).text() == "90.00°"
    editor.table.item(0, 3).setText("1 0 0; 0 0 0; 1, 1, 0")            # commas are taken too
    markup = network.get("mk.markups")["angle 1"]
    assert markup.points[2] == (1.0, 1.0, 0.0) and markup.angle == pytest.approx(45.0)
    assert window.inspector.editors["markups"].table.item(0, 2).text() == "45.00°"
    window.inspector.editors["markups"].table.item(0, 4).setCheckState(Qt.Unchecked)
    assert network.get("mk.markups")["angle 1"].visible is False
    undo.undo()
    assert network.get("mk.markups")["angle 1"].visible is True
    undo.undo()
    assert network.get("mk.markups")["angle 1"].angle == pytest.approx(90.0)
    editor = window.inspector.editors["markups"]
    editor.table.selectRow(0)
    editor.remove_selected()
    assert len(network.get("mk.markups")) == 0


def test_a_refused_edit_is_reported_and_the_current_markups_shown_again(window):
    editor = markups_editor(window)
    editor.add_markup()                                                   # a ruler
    before = window.workspace.network.get("mk.markups")
    editor = window.inspector.editors["markups"]
    editor.table.item(0, 3).setText("0 0 0; 1 1 1; 2 2 2")
    assert window.workspace.network.get("mk.markups") == before
    assert "a ruler has exactly 2 points, got 3" in window.statusBar().currentMessage()
    assert window.inspector.editors["markups"].table.item(0, 3).text() == "0.0 0.0 0.0; 10.0 0.0 0.0"


def test_import_a_slicer_file_and_export_csv(window, tmp_path, monkeypatch):
    editor = markups_editor(window)
    (tmp_path / "Measure.mrk.json").write_text(SLICER_LINE)
    monkeypatch.setattr(QFileDialog, "getOpenFileName", lambda *a: (str(tmp_path / "Measure.mrk.json"), ""))
    editor.import_file()
    markups = window.workspace.network.get("mk.markups")
    assert markups.names == ["Measure-1", "Measure-2"] and markups["Measure-1"].length == pytest.approx(5.0)
    monkeypatch.setattr(QFileDialog, "getSaveFileName", lambda *a: (str(tmp_path / "out.json"), ""))
    window.inspector.editors["markups"].export_file()
    assert json.loads((tmp_path / "out.json").read_text())["markups"][0]["points"][0] == [-10.5, 20.0, 30.0]
    (tmp_path / "bad.mrk.json").write_text('{"markups": [{"type": "ROI", "controlPoints": []}]}')
    monkeypatch.setattr(QFileDialog, "getOpenFileName", lambda *a: (str(tmp_path / "bad.mrk.json"), ""))
    window.inspector.editors["markups"].import_file()
    assert "'ROI' is not a markup vgraph holds" in window.statusBar().currentMessage()
    assert window.workspace.network.get("mk.markups") == markups
