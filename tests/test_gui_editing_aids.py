"""Editing aids of the inspector (issue #17): TF points typed in, camera near/far planes, what a
VolumeSource loaded, tooltips from the property declarations, combo popups as lists."""

import pickle

import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QColorDialog, QDialog, QStyle

from vgraph.gui import tf_point_dialog
from vgraph.live.evaluator import processor_status
from vgraph.network import Network
from vgraph.transfer_function import TransferFunction, ValueScale


def select(window, processor_id):
    window.scene.select_processor(processor_id)
    assert window.inspector.processor_id == processor_id
    return window.inspector.editors


def answer_dialog(monkeypatch, position=None, opacity=None, color=None, accept=True):
    """Make PointDialog.exec type the given numbers and press OK (or Cancel); returns the dialogs shown."""
    shown = []

    def exec_(dialog):
        shown.append(dialog)
        if position is not None:
            dialog.position.setValue(position)
        if opacity is not None:
            dialog.opacity.setValue(opacity)
        if color is not None:
            monkeypatch.setattr(QColorDialog, "getColor", lambda *args: QColor.fromRgbF(*color))
            dialog.color_button.click()
        return QDialog.Accepted if accept else QDialog.Rejected
    monkeypatch.setattr(tf_point_dialog.PointDialog, "exec", exec_)
    return shown


def test_a_tf_point_typed_in_round_trips_and_is_one_undo_step(window, qtbot, monkeypatch):
    from vgraph.gl.raycasting.components import TransferFunctionLut
    window.workspace.add_processor("RayCaster", (0, 0), id="rc")
    window.workspace.set_property("rc.transfer_function", TransferFunctionLut.DEFAULT)  # normalised
    editor = select(window, "rc")["transfer_function"]
    stack, original = window.workspace.undo_stack, window.workspace.network.get("rc.transfer_function")
    low, high = original.points[1][0], original.points[3][0]
    shown = answer_dialog(monkeypatch, position=0.612345, opacity=0.05, color=(0.2, 0.4, 0.6))
    editor.plot.selected = 2
    editor.plot.setFocus()
    count = stack.count()
    qtbot.keyClick(editor.plot, Qt.Key_Return)            # Return on the selected point
    assert len(shown) == 1 and shown[0].position.minimum() == low and shown[0].position.maximum() == high
    point = window.workspace.network.get("rc.transfer_function").points[2]
    assert point == pytest.approx((0.612345, 0.2, 0.4, 0.6, 0.05), abs=1e-6)
    assert point[0] == 0.612345 and point[4] == 0.05       # the typed numbers, not a pixel's
    assert stack.count() == count + 1
    assert window.workspace.network.get("rc.transfer_function").points[:2] == original.points[:2]

    answer_dialog(monkeypatch, opacity=0.3)                # the button; untouched boxes keep exact values
    editor.point_button.click()
    again = window.workspace.network.get("rc.transfer_function").points[2]
    assert again == (0.612345, 0.2, 0.4, 0.6, 0.3) and stack.count() == count + 2

    answer_dialog(monkeypatch, opacity=0.9, accept=False)  # Cancel: nothing changes
    editor.edit_point(2)
    assert stack.count() == count + 2
    stack.undo()
    stack.undo()
    assert window.workspace.network.get("rc.transfer_function") == original
    assert editor.plot.transfer_function == original


def test_a_tf_point_in_data_units_is_typed_in_data_units(qtbot, monkeypatch):
    from vgraph.gui.transfer_function_editor import TransferFunctionPlot
    plot = TransferFunctionPlot()
    qtbot.addWidget(plot)
    plot.set_transfer_function(TransferFunction(space="data", points=[(-1000, 0, 0, 0, 0), (300, 1, 1, 1, 0.5),
                                                                      (2000, 1, 1, 1, 1)]))
    plot.set_value_scale(ValueScale(-1024.0, 3071.0))
    changed = []
    plot.changed.connect(lambda tf, merge: changed.append((tf, merge)))
    plot.set_point(1, (250.5, 0.1, 0.2, 0.3, 0.25))
    assert changed[-1][0].points[1] == (250.5, 0.1, 0.2, 0.3, 0.25) and changed[-1][1] is None
    plot.set_point(1, (5000.0, 0.1, 0.2, 0.3, 0.25))       # beyond the right neighbour: stops there
    assert plot.points[1][0] == 2000


def test_camera_near_and_far_are_shown_and_editable(window):
    ws = window.workspace
    ws.add_processor("EntryExitPoints", (0, 0), id="eep")
    editor = select(window, "eep")["camera"]
    near, far = editor.planes["near"], editor.planes["far"]
    assert ws.network.get("eep.camera").near is None and near.text() == "auto" and far.text() == "auto"
    near.setValue(0.25)
    far.setValue(40.0)
    camera = ws.network.get("eep.camera")
    assert (camera.near, camera.far) == (0.25, 40.0)
    ws.undo_stack.undo()                                 # the widget follows an undo
    assert ws.network.get("eep.camera").far is None and far.text() == "auto"
    near.setValue(0.0)                                   # back to automatic
    assert ws.network.get("eep.camera").near is None
    ws.set_property("eep.camera", ws.network.get("eep.camera").model_dump() | {"near": 2.0, "far": 9.0})
    assert near.value() == 2.0 and far.value() == 9.0


def test_the_volume_source_status_says_what_was_loaded(data_dir):
    network = Network()
    network.add("VolumeSource", id="src")
    network.set("src.path", str(data_dir / "mri_head_tiny/HeadMRVolume.mhd"))
    network.update("src")
    status = pickle.loads(pickle.dumps(processor_status(network, network["src"])))
    assert status.state == "evaluated"
    volume = network.output("src.volume")
    x, y, z = volume.dims
    assert f"{x} \u00d7 {y} \u00d7 {z} uint8" in status.data and (x, y, z) == (48, 62, 42)
    lo, hi = volume.value_range
    assert f"values {lo:g} to {hi:g}" in status.data and "spacing (" in status.data
    size = sum(f.stat().st_size for f in (data_dir / "mri_head_tiny").glob("HeadMRVolume.*"))
    assert size > 48 * 62 * 42 and f"file: {size / 1024:.1f} KiB" in status.data   # header and raw
    assert len(pickle.dumps(status)) < 1000


def test_the_inspector_shows_what_the_render_process_loaded(window, data_dir, qtbot):
    ws = window.workspace
    ws.add_processor("VolumeSource", (0, 0), id="src")
    select(window, "src")
    assert window.inspector.data.isHidden()
    ws.set_property("src.path", str(data_dir / "mri_head_tiny/HeadMRVolume.mhd"))
    qtbot.waitUntil(lambda: "48 \u00d7 62 \u00d7 42 uint8" in window.inspector.data.text(), timeout=20000)
    assert not window.inspector.data.isHidden() and "file:" in window.inspector.data.text()
    window.scene.clearSelection()
    assert window.inspector.data.isHidden() and not window.inspector.data.text()


def test_every_editor_has_its_declaration_as_tooltip(window):
    ws = window.workspace
    ws.add_processor("VolumeSource", (0, 0), id="src")
    editors = select(window, "src")
    time_step = editors["time_step"].toolTip()
    doc = ws.network["src"].properties["time_step"].doc
    assert doc and time_step.startswith(doc) and "range: 0 to -" in time_step and "default: 0" in time_step
    assert "choices: uint8" in editors["raw_dtype"].toolTip()
    assert window.inspector.labels["time_step"].toolTip() == time_step
    for name, prop in ws.network["src"].properties.items():
        if prop.doc:
            assert prop.doc in editors[name].toolTip(), name


def test_combo_popups_open_as_lists(window):
    """The style sheet decides the popup (a style sheet saying 1 gives the over-the-box popup), so
    each editor combo must carry the list one."""
    ws = window.workspace
    ws.add_processor("VolumeSource", (0, 0), id="src")
    ws.add_processor("RayCaster", (0, 100), id="rc")
    ws.add_processor("EntryExitPoints", (0, 200), id="eep")
    for processor_id, combo_of in (("src", lambda e: e["window"].combo),
                                   ("rc", lambda e: e["transfer_function"].presets),
                                   ("eep", lambda e: e["camera"].projection)):
        combo = combo_of(select(window, processor_id))
        assert "combobox-popup: 0" in combo.styleSheet()
        assert combo.style().styleHint(QStyle.SH_ComboBox_Popup, None, combo) == 0
