"""The property inspector: editors generated from the declarations, edits applied live through
the undo stack and followed by an evaluation, rejected values reported."""

import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QColorDialog, QFileDialog

from vgraph.camera import Camera
from vgraph.gui import editors
from vgraph.registry import registry



def select(window, processor_id):
    window.scene.select_processor(processor_id)
    assert window.inspector.processor_id == processor_id
    return window.inspector.editors


def test_editing_a_spin_box_sets_the_property_and_triggers_evaluation(window, qtbot):
    ws = window.workspace
    ws.add_processor("FunctionSelector", (0, 0), id="f")
    ws.add_processor("CubicSplineProcessor", (0, 150), id="spline")
    ws.add_processor("RayCaster", (200, 150), id="rc")   # not ready (no entry points): not run
    ws.connect("f.volume", "spline.volume")
    ws.connect("f.volume", "rc.volume")
    outcome = window.evaluation.run(wait=True)
    assert outcome.ran == ["f", "spline"] and outcome.not_ready == ["rc"]
    voxels = lambda: window.evaluation.last_result.histograms["rc"].sum()  # the TF editor's histogram
    assert voxels() == 64 ** 3

    spin = select(window, "f")["resolution"].spin
    with qtbot.waitSignal(window.evaluation.finished, timeout=20000) as blocker:
        spin.lineEdit().selectAll()
        qtbot.keyClicks(spin.lineEdit(), "32")
        qtbot.keyClick(spin.lineEdit(), Qt.Key_Return)
    assert ws.network.get("f.resolution") == 32
    assert blocker.args[0].ran == ["f", "spline"]
    assert voxels() == 32 ** 3                                       # the render process has it
    assert window.scene.nodes["spline"].status.state == "evaluated"

    ws.undo_stack.undo()
    assert ws.network.get("f.resolution") == 64 and spin.value() == 64   # the widget follows
    assert window.inspector.editors["resolution"].slider.value() == 64


def test_each_slider_drag_is_one_undo_step(window):
    ws = window.workspace
    ws.add_processor("Grayscale", (0, 0), id="gray")
    editor = select(window, "gray")["saturation"]
    count = ws.undo_stack.count()
    for steps in ((100, 300, 500), (600, 700)):
        editor.slider.setSliderDown(True)
        for step in steps:
            editor.slider.setValue(step)
        editor.slider.setSliderDown(False)
    assert ws.network.get("gray.saturation") == 0.7 and editor.spin.value() == 0.7
    assert ws.undo_stack.count() == count + 2
    ws.undo_stack.undo()
    assert ws.network.get("gray.saturation") == 0.5 and editor.slider.value() == 500
    ws.undo_stack.undo()
    assert ws.network.get("gray.saturation") == 0.0 and editor.slider.value() == 0


def test_a_rejected_value_is_reported_and_the_editor_shows_the_current_value(window):
    ws = window.workspace
    ws.add_processor("EntryExitPoints", (0, 0), id="eep")
    editor = select(window, "eep")["camera"]
    count = ws.undo_stack.count()
    z = ws.network.get("eep.camera").position[2]
    for spin in editor.vectors["position"]:   # move the camera onto its focus (the origin)
        spin.setValue(0.0)
    assert window.statusBar().currentMessage().startswith("eep.camera: invalid value")
    assert "position and focus must differ" in window.statusBar().currentMessage()
    assert ws.network.get("eep.camera").position == (0.0, 0.0, z)
    assert editor.vectors["position"][2].value() == pytest.approx(z, abs=1e-4)
    assert ws.undo_stack.count() == count + 2  # the two accepted components, not the refused one


def test_camera_reset_restores_the_declared_default(window):
    ws = window.workspace
    ws.add_processor("EntryExitPoints", (0, 0), id="eep")
    default = ws.network.get("eep.camera")
    ws.set_property("eep.camera", default.zoom(2.0))
    editor = select(window, "eep")["camera"]
    assert editor.vectors["position"][2].value() == pytest.approx(default.position[2] / 2, abs=1e-4)
    editor.reset.click()
    assert ws.network.get("eep.camera") == default
    assert editor.vectors["position"][2].value() == pytest.approx(default.position[2], abs=1e-4)


def test_the_camera_editor_fits_to_data_until_a_position_is_typed(window):
    ws = window.workspace
    ws.add_processor("EntryExitPoints", (0, 0), id="eep")
    editor = select(window, "eep")["camera"]
    assert editor.fit.isChecked() and ws.network.get("eep.camera").fit_to_data
    editor.fov.setValue(40.0)                     # the view angle: still fitting
    assert ws.network.get("eep.camera").fit_to_data and ws.network.get("eep.camera").fov == 40.0
    editor.vectors["position"][0].setValue(5.0)   # a typed position: stored from now on
    assert not ws.network.get("eep.camera").fit_to_data and not editor.fit.isChecked()
    editor.fit.setChecked(True)
    assert ws.network.get("eep.camera").fit_to_data


def test_option_bool_dict_and_vector_editors(window):
    ws = window.workspace
    ws.add_processor("FunctionSelector", (0, 0), id="f")
    ws.add_processor("RayCaster", (250, 0), id="rc")
    f = select(window, "f")
    f["function"].combo.setCurrentText("sphere")
    assert ws.network.get("f.function") == "sphere"
    f["parameters"].line.setText("{oops")
    f["parameters"].line.editingFinished.emit()
    assert "f.parameters: not valid JSON" in window.statusBar().currentMessage()
    rc = select(window, "rc")
    rc["empty_space_skipping"].check.setChecked(False)
    assert ws.network.get("rc.empty_space_skipping") is False
    rc["light_direction"].spins[0].setValue(-1.0)
    assert ws.network.get("rc.light_direction")[0] == -1.0


def test_colour_and_file_editors_use_their_dialogs(window, monkeypatch, tmp_path):
    ws = window.workspace
    ws.add_processor("RayCaster", (0, 0), id="rc")
    ws.add_processor("ImageSource", (250, 0), id="source")
    ws.network.base_dir = tmp_path
    monkeypatch.setattr(QColorDialog, "getColor", lambda *args: QColor.fromRgbF(1.0, 0.6, 0.0, 0.2))
    select(window, "rc")["background"].button.click()
    assert ws.network.get("rc.background") == (1.0, 0.6, 0.0, 0.2)

    asked = {}

    def get_open_file_name(parent, caption, start, name_filter):
        asked["filter"] = name_filter
        return str(tmp_path / "images" / "head.png"), name_filter

    monkeypatch.setattr(QFileDialog, "getOpenFileName", get_open_file_name)
    select(window, "source")["path"].browse.click()
    assert asked["filter"].startswith("Path (*.png *.jpg *.jpeg)")
    assert ws.network.get("source.path") == "images/head.png"  # relative to the network's folder


def test_optional_vector_switches_between_auto_and_values(window):
    ws = window.workspace
    ws.add_processor("VolumeSource", (0, 0), id="vs")
    editor = select(window, "vs")["spacing"]
    assert editor.auto.isChecked() and not editor.spins[0].isEnabled()
    editor.auto.setChecked(False)
    assert ws.network.get("vs.spacing") == (1.0, 1.0, 1.0)
    editor.spins[2].setValue(2.5)
    assert ws.network.get("vs.spacing") == (1.0, 1.0, 2.5)
    editor.auto.setChecked(True)
    assert ws.network.get("vs.spacing") is None


def test_every_built_in_property_gets_an_editor_that_shows_its_value(window):
    """Editors exist for every kind; showing the current value must not emit an edit."""
    ws = window.workspace
    for cls in registry.all():
        ws.add_processor(cls.type_name, (0, 0))
    count = ws.undo_stack.count()
    for pid, processor in ws.network.processors.items():
        shown = select(window, pid)
        assert set(shown) == set(processor.properties)
        for name, editor in shown.items():
            assert type(editor) is editors.EDITOR_TYPES.get(processor.properties[name].kind, editors.JsonEditor)
            editor.show_value(processor.property_values[name])
    assert ws.undo_stack.count() == count


def test_register_editor_replaces_the_editor_of_a_kind(window, monkeypatch):
    class Marked(editors.JsonEditor):
        pass

    monkeypatch.setitem(editors.EDITOR_TYPES, "transfer_function", Marked)
    window.workspace.add_processor("RayCaster", (0, 0), id="rc")
    assert isinstance(select(window, "rc")["transfer_function"], Marked)


def test_linked_properties_are_marked_and_follow_each_other(window):
    ws = window.workspace
    ws.add_processor("EntryExitPoints", (0, 0), id="eep")
    ws.add_processor("RayCaster", (0, 150), id="rc")        # cameras auto-linked
    select(window, "rc")
    assert window.inspector.labels["camera"].text().endswith("\u2194")
    assert "linked with eep.camera" in window.inspector.labels["camera"].toolTip()
    moved = ws.network.get("eep.camera").zoom(1.5)
    ws.set_property("eep.camera", moved)
    assert ws.network.get("rc.camera") == moved
    assert window.inspector.editors["camera"].vectors["position"][2].value() == pytest.approx(moved.position[2], abs=1e-4)
    assert isinstance(moved, Camera)
