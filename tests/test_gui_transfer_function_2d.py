"""The 2D transfer-function editor (vgraph.gui.transfer_function_2d_editor) and the gradient-opacity
editor (vgraph.gui.gradient_opacity_editor): real mouse and key events on their plots change the
RayCaster's transfer_function_2d and gradient_opacity through the undo stack; Add, presets, Off;
the histograms come from the render process."""

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from vgraph.gl.raycasting.gradient_classification import editor_histogram
from vgraph.gradient_opacity import PRESETS as CURVES, GradientOpacity
from vgraph.gui import gradient_opacity_editor, transfer_function_2d_editor as editor_module
from vgraph.transfer_function_2d import PRESETS, Rectangle, TransferFunction2D

SQUARE = TransferFunction2D(primitives=[Rectangle(value=(0.2, 0.4), gradient=(0.1, 0.3), color=(1, 0, 0, 0.5))])


@pytest.fixture
def editor(window):
    window.workspace.add_processor("RayCaster", (0, 0), id="rc")
    window.workspace.set_property("rc.transfer_function_2d", SQUARE)
    window.scene.select_processor("rc")
    shown = window.inspector.editors["transfer_function_2d"]
    assert isinstance(shown, editor_module.TransferFunction2DEditor)
    return shown


def tf(window) -> TransferFunction2D | None:
    return window.workspace.network.get("rc.transfer_function_2d")


def pixel_of(plot, value, gradient) -> QPoint:
    return plot.to_pixel(value, gradient).toPoint()


def plane_at(plot, pixel: QPoint):
    """The documented mapping, written out: x = value left->right, y = gradient bottom->top."""
    area = plot.area()
    return (pixel.x() - area.left()) / area.width(), (area.bottom() - pixel.y()) / area.height()


def mouse_drag(qtbot, plot, start: QPoint, end: QPoint, steps=4):
    qtbot.mousePress(plot, Qt.LeftButton, pos=start)
    for i in range(1, steps + 1):
        qtbot.mouseMove(plot, start + (end - start) * (i / steps))
    qtbot.mouseRelease(plot, Qt.LeftButton, pos=end)


def test_a_drag_moves_the_primitive_under_the_mouse_as_one_undo_step(window, editor, qtbot):
    plot, stack = editor.plot, window.workspace.undo_stack
    assert plot.width() > 150 and plot.height() > 100
    count = stack.count()
    start, end = pixel_of(plot, 0.3, 0.2), pixel_of(plot, 0.6, 0.5)
    mouse_drag(qtbot, plot, start, end)
    (v0, g0), (v1, g1) = plane_at(plot, start), plane_at(plot, end)
    moved = tf(window).primitives[0]
    assert moved.value == pytest.approx((0.2 + v1 - v0, 0.4 + v1 - v0), abs=1e-6)
    assert moved.gradient == pytest.approx((0.1 + g1 - g0, 0.3 + g1 - g0), abs=1e-6)
    assert moved.color == (1, 0, 0, 0.5) and stack.count() == count + 1
    # Dragged far beyond the plane's corner, it stops at the edge, whole.
    centre = (sum(moved.value) / 2, sum(moved.gradient) / 2)
    mouse_drag(qtbot, plot, pixel_of(plot, *centre), QPoint(plot.width() + 300, -300))
    corner = tf(window).primitives[0]
    assert corner.value[1] == pytest.approx(1.0) and corner.gradient[1] == pytest.approx(1.0)
    assert corner.value[1] - corner.value[0] == pytest.approx(0.2, abs=1e-6)
    assert stack.count() == count + 2
    stack.undo()
    stack.undo()
    assert tf(window) == SQUARE


def test_a_handle_drag_reshapes_the_selected_primitive(window, editor, qtbot):
    plot = editor.plot
    qtbot.mouseClick(plot, Qt.LeftButton, pos=pixel_of(plot, 0.3, 0.2))  # selects the square
    assert plot.selected == 0
    start, end = pixel_of(plot, 0.4, 0.3), pixel_of(plot, 0.7, 0.8)  # its high corner's handle
    mouse_drag(qtbot, plot, start, end)
    (v0, g0), (v1, g1) = plane_at(plot, start), plane_at(plot, end)
    reshaped = tf(window).primitives[0]
    assert reshaped.value == pytest.approx((0.2, 0.4 + v1 - v0), abs=1e-6)
    assert reshaped.gradient == pytest.approx((0.1, 0.3 + g1 - g0), abs=1e-6)
    # The low corner dragged past the high one stops there: never an inverted box.
    mouse_drag(qtbot, plot, pixel_of(plot, 0.2, 0.1), QPoint(plot.width() + 100, -100))
    squeezed = tf(window).primitives[0]
    assert squeezed.value[0] == squeezed.value[1] == reshaped.value[1]
    assert squeezed.gradient[0] == squeezed.gradient[1] == reshaped.gradient[1]


def test_add_presets_delete_and_off(window, editor, qtbot):
    editor.add_kind.setCurrentIndex(editor_module.KINDS.index("gaussian") + 1)
    added = tf(window).primitives
    assert len(added) == 2 and added[1].kind == "gaussian" and added[1].centre == (0.5, 0.5)
    assert editor.add_kind.currentIndex() == 0

    # Delete on the selected primitive (the one just added) removes it; on the last one: off.
    editor.plot.setFocus()
    qtbot.keyClick(editor.plot, Qt.Key_Delete)
    assert tf(window) == SQUARE
    qtbot.mouseClick(editor.plot, Qt.LeftButton, pos=pixel_of(editor.plot, 0.3, 0.2))
    qtbot.keyClick(editor.plot, Qt.Key_Delete)
    assert tf(window) is None

    editor.presets.setCurrentIndex(list(PRESETS).index("two-materials") + 1)
    assert tf(window) == PRESETS["two-materials"]
    qtbot.mouseClick(editor.off_button, Qt.LeftButton)
    assert tf(window) is None


def test_the_histogram_reaches_the_editor_from_the_render_process(window, qtbot):
    from helpers.paths import REPO
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.evaluation.run(wait=True)
    assert "rc.transfer_function_2d" not in window.evaluation.last_result.histograms  # off: not computed
    with qtbot.waitSignal(window.evaluation.histograms, timeout=20000):
        window.workspace.set_property("rc.transfer_function_2d", "boundaries")
    with qtbot.waitSignal(window.evaluation.histograms, timeout=20000):
        window.workspace.set_property("rc.gradient_opacity", "boundaries")
    window.scene.select_processor("rc")
    counts = window.evaluation.last_result.histograms["rc.transfer_function_2d"]
    resolution = window.workspace.network.get("source.resolution")
    assert counts.shape == (128, 128) and counts.sum() == resolution ** 3
    volume = window.workspace.network["rc"].inputs.get("volume")
    if volume is not None:  # the network of this process evaluated too (not only the render process)
        np.testing.assert_array_equal(counts, editor_histogram(volume))
    assert window.inspector.editors["transfer_function_2d"].plot._histogram is not None
    by_gradient = window.evaluation.last_result.histograms["rc.gradient_opacity"]
    np.testing.assert_array_equal(by_gradient, counts.sum(axis=1))
    np.testing.assert_array_equal(window.inspector.editors["gradient_opacity"].plot.counts, by_gradient)


def test_the_gradient_opacity_curve_is_edited_on_the_tf_plot(window, qtbot):
    window.workspace.add_processor("RayCaster", (0, 0), id="rc")
    window.scene.select_processor("rc")
    editor = window.inspector.editors["gradient_opacity"]
    assert isinstance(editor, gradient_opacity_editor.GradientOpacityEditor)
    plot = editor.plot
    assert [p[4] for p in plot.points] == [1.0, 1.0]  # off: every opacity kept
    # Dragging the right end down turns gradient opacity on with that curve.
    start, end = plot.to_pixel(1.0, 1.0).toPoint(), plot.to_pixel(1.0, 0.4).toPoint()
    mouse_drag(qtbot, plot, start, end)
    curve = window.workspace.network.get("rc.gradient_opacity")
    area = plot.curve_rect()
    assert curve.points[0] == (0.0, 1.0)
    assert curve.points[1] == pytest.approx((1.0, (area.bottom() - end.y()) / area.height()), abs=1e-6)
    editor.presets.setCurrentIndex(list(CURVES).index("strong-edges") + 1)
    assert window.workspace.network.get("rc.gradient_opacity") == CURVES["strong-edges"]
    assert [p[4] for p in editor.plot.points] == [0.0, 0.0, 1.0, 1.0]
    qtbot.mouseClick(editor.off_button, Qt.LeftButton)
    assert window.workspace.network.get("rc.gradient_opacity") is None
    window.workspace.undo_stack.undo()
    assert isinstance(window.workspace.network.get("rc.gradient_opacity"), GradientOpacity)
