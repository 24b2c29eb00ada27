"""The graphical transfer-function editor: real mouse and key events on the plot change the network's
transfer function through the undo stack; presets, TF files, histogram painting."""

import json

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QColorDialog

from vgraph.gl.raycasting.components import TransferFunctionLut
from vgraph.gui import transfer_function_editor as tfe
from vgraph.transfer_function import PRESETS, ValueScale

from helpers.gui import ray_caster_tf, ray_caster_tf_editor



@pytest.fixture
def editor(window):
    """The TF editor of a selected RayCaster (the inspector's editor for transfer functions), on
    the ray casters' ramp over normalised intensity (the palette's RayCaster starts with the auto
    preset, in percentiles, which the plot edits once a volume has given it a scale)."""
    return ray_caster_tf_editor(window, TransferFunctionLut.DEFAULT)


tf = ray_caster_tf


def pixel_of(plot, position, opacity) -> QPoint:
    return plot.to_pixel(position, opacity).toPoint()


def value_at(plot, pixel: QPoint):
    """The documented mapping, written out: x = intensity left->right, y = opacity bottom->top."""
    area = plot.curve_rect()
    return (round((pixel.x() - area.left()) / area.width(), 6),
            round((area.bottom() - pixel.y()) / area.height(), 6))


def mouse_drag(qtbot, plot, start: QPoint, end: QPoint, steps=4):
    qtbot.mousePress(plot, Qt.LeftButton, pos=start)
    for i in range(1, steps + 1):
        qtbot.mouseMove(plot, start + (end - start) * (i / steps))
    qtbot.mouseRelease(plot, Qt.LeftButton, pos=end)


def test_the_inspector_edits_transfer_functions_with_this_editor(window):
    from vgraph.gui.editors import EDITOR_TYPES
    assert EDITOR_TYPES["transfer_function"] is tfe.TransferFunctionEditor


def test_a_drag_moves_a_point_and_is_one_undo_step(window, editor, qtbot):
    plot, stack = editor.plot, window.workspace.undo_stack
    original = tf(window)
    assert plot.height() > 100 and plot.width() > 150
    count = stack.count()
    position, r, g, b, opacity = original.points[2]
    target = pixel_of(plot, 0.7, 0.75)
    mouse_drag(qtbot, plot, pixel_of(plot, position, opacity), target)
    moved = tf(window).points[2]
    assert moved[0] == pytest.approx(value_at(plot, target)[0], abs=1e-6)
    assert moved[4] == pytest.approx(value_at(plot, target)[1], abs=1e-6)
    assert moved[1:4] == (r, g, b) and tf(window).points[:2] == original.points[:2]
    assert stack.count() == count + 1

    # A second drag pushes the point past its right neighbour: x stops there. Its own undo step.
    neighbour = tf(window).points[2][0]
    left = original.points[1]
    mouse_drag(qtbot, plot, pixel_of(plot, left[0], left[4]), pixel_of(plot, 0.95, 0.5))
    assert tf(window).points[1][0] == neighbour
    assert stack.count() == count + 2
    last = original.points[3]                    # and leftwards past its left neighbour
    mouse_drag(qtbot, plot, pixel_of(plot, last[0], last[4]), pixel_of(plot, 0.05, 0.5))
    assert tf(window).points[3][0] == neighbour
    assert stack.count() == count + 3

    stack.undo()
    stack.undo()
    assert tf(window).points[1] == original.points[1]
    stack.undo()
    assert tf(window) == original and plot.transfer_function == original   # the plot follows


def test_double_click_adds_a_point_with_the_colour_of_the_function_there(window, editor, qtbot):
    plot, stack = editor.plot, window.workspace.undo_stack
    original = tf(window)
    count = stack.count()
    spot = pixel_of(plot, 0.3, 0.5)
    position, opacity = value_at(plot, spot)
    qtbot.mouseDClick(plot, Qt.LeftButton, pos=spot)
    points = tf(window).points
    assert len(points) == len(original.points) + 1
    assert points[1][0] == pytest.approx(position, abs=1e-6) and points[1][4] == pytest.approx(opacity, abs=1e-6)
    # between (0, black) and (0.45, (0.85, 0.55, 0.3)): linear interpolation
    assert points[1][1:4] == pytest.approx(original(position)[:3], abs=1e-6)
    assert points[1][1] == pytest.approx(0.85 * position / 0.45, abs=1e-6)
    assert stack.count() == count + 1 and plot.selected == 1


def test_delete_and_right_click_remove_points_but_never_the_last(window, editor, qtbot):
    plot = editor.plot
    original = tf(window)
    qtbot.mouseClick(plot, Qt.LeftButton, pos=pixel_of(plot, *original.points[2][::4]))
    assert plot.selected == 2
    qtbot.keyClick(plot, Qt.Key_Delete)
    assert tf(window).points == [original.points[i] for i in (0, 1, 3)]
    assert "rc" in window.workspace.network      # the window's Delete (processors) did not fire
    while len(tf(window).points) > 1:
        last = tf(window).points[-1]
        qtbot.mouseClick(plot, Qt.RightButton, pos=pixel_of(plot, last[0], last[4]))
    assert tf(window).points == [original.points[0]]
    qtbot.mouseClick(plot, Qt.RightButton, pos=pixel_of(plot, 0.0, 0.0))
    plot.selected = 0
    qtbot.keyClick(plot, Qt.Key_Delete)
    assert tf(window).points == [original.points[0]]


def test_double_click_on_a_point_asks_for_its_colour(window, editor, qtbot, monkeypatch):
    plot = editor.plot
    monkeypatch.setattr(QColorDialog, "getColor", lambda *args: QColor.fromRgbF(0.2, 0.4, 0.6))
    position, *_, opacity = tf(window).points[3]
    qtbot.mouseDClick(plot, Qt.LeftButton, pos=pixel_of(plot, position, opacity))
    assert tf(window).points[3] == pytest.approx((1.0, 0.2, 0.4, 0.6, 0.8), abs=1e-4)
    assert len(tf(window).points) == 4
    monkeypatch.setattr(QColorDialog, "getColor", lambda *args: QColor())   # cancelled: no change
    count = window.workspace.undo_stack.count()
    editor.choose_color(3)
    assert window.workspace.undo_stack.count() == count


def test_presets_set_the_function(window, editor):
    editor.presets.setCurrentText("ct-bone")
    assert tf(window) == PRESETS["ct-bone"] and editor.presets.currentIndex() == 0
    assert editor.plot.transfer_function == PRESETS["ct-bone"]


def test_a_tf_in_hounsfield_units_is_edited_in_hounsfield_units(qtbot):
    plot = tfe.TransferFunctionPlot()
    qtbot.addWidget(plot)
    plot.resize(300, 200)
    emitted = []
    plot.changed.connect(lambda value, merge: emitted.append(value))
    plot.set_transfer_function(PRESETS["ct-bone"])
    assert not plot.editable and plot.point_at(plot.to_pixel(0.5, 0.25)) is None  # no scale yet
    plot.set_value_scale(ValueScale((-1000.0, 1000.0), tuple(np.linspace(-1000, 1000, 101))))
    assert plot.editable
    np.testing.assert_allclose(plot.display_positions(), [0.0, 0.575, 0.65, 0.85, 2.0])
    plot.move_point(2, 0.75, 0.5)              # bone's start point dragged to 500 HU
    edited = emitted[-1]
    assert edited.space == "data" and edited.points[2] == pytest.approx((500.0, 0.55, 0.4, 0.3, 0.5))
    assert edited.points[:2] + edited.points[3:] == PRESETS["ct-bone"].points[:2] + PRESETS["ct-bone"].points[3:]
    index = plot.add_point(0.25, 0.0)           # -500 HU, between -1000 and 150
    assert index == 1 and emitted[-1].points[1][0] == pytest.approx(-500.0)


def test_save_then_load_round_trips_and_a_bad_file_is_reported(window, editor, qtbot, tmp_path, monkeypatch):
    window.workspace.set_property("rc.transfer_function", PRESETS["rainbow"])
    monkeypatch.setattr(editor, "ask_save_path", lambda: str(tmp_path / "colours"))
    editor.save_button.click()
    saved = tmp_path / "colours.json"
    assert json.loads(saved.read_text())["points"] == [list(p) for p in PRESETS["rainbow"].points]

    editor.presets.setCurrentText("grayscale ramp")
    monkeypatch.setattr(editor, "ask_load_path", lambda: str(saved))
    editor.load_button.click()
    assert tf(window) == PRESETS["rainbow"]

    bad = tmp_path / "bad.json"
    bad.write_text('{"points": [[0.5, 1, 1, 1]]}')
    monkeypatch.setattr(editor, "ask_load_path", lambda: str(bad))
    count = window.workspace.undo_stack.count()
    with qtbot.waitSignal(editor.problem, timeout=1000) as blocker:
        editor.load_button.click()
    assert blocker.args[0].startswith(f"{bad}: not a transfer function: points: Value error, point 0 needs 5")
    assert window.statusBar().currentMessage() == blocker.args[0]   # the inspector shows it
    assert tf(window) == PRESETS["rainbow"] and window.workspace.undo_stack.count() == count


def test_histogram_bars_follow_the_log_scale(window, editor):
    plot = editor.plot
    window.workspace.set_property("rc.transfer_function", {"points": [[1.0, 1.0, 0.0, 0.0, 1.0]]})
    counts = np.full(64, 10)
    counts[0] = 100_000                 # skewed: a linear scale flattens every other bin
    area = plot.curve_rect()
    probe = QPoint(round(area.left() + area.width() * 32.5 / 64), round(area.bottom() - 0.15 * area.height()))

    def colour_at(point):
        return QColor(plot.grab().toImage().pixel(point))

    assert colour_at(probe) == plot.BACKGROUND                 # no histogram yet
    editor.set_histogram(counts)
    assert colour_at(probe) == plot.BACKGROUND                 # linear: 1e-4 of the height
    editor.log_scale.setChecked(True)
    assert colour_at(probe) == plot.BAR_COLOR                  # log1p(10) / log1p(1e5) = 0.21
    above = QPoint(probe.x(), round(area.bottom() - 0.25 * area.height()))
    assert colour_at(above) == plot.BACKGROUND
    # the gradient strip: an opaque red function paints it red over the checkerboard
    strip = plot.strip_rect()
    assert colour_at(strip.center().toPoint()) == QColor(255, 0, 0)


def test_the_histogram_of_the_volume_reaches_the_editor_from_the_render_process(window, qtbot):
    from helpers.paths import REPO
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.evaluation.run(wait=True)
    window.scene.select_processor("rc")                 # selected after the result: still shown
    counts = window.inspector.editors["transfer_function"].plot.counts
    resolution = window.workspace.network.get("source.resolution")
    assert counts is not None and counts.sum() == resolution ** 3
    np.testing.assert_array_equal(counts, window.evaluation.last_result.histograms["rc"])

    with qtbot.waitSignal(window.evaluation.histograms, timeout=20000):
        window.workspace.set_property("source.resolution", 32)   # a new volume, a new histogram
    assert window.inspector.editors["transfer_function"].plot.counts.sum() == 32 ** 3
