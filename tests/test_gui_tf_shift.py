"""The TF editor's shift and scale row: the slider and the boxes set tf_shift and tf_scale through
the undo stack, the plot draws the points where the move puts them, a dragged point is stored
without the move, and the readout says where the points sit in data values."""

import numpy as np
import pytest
from PySide6.QtCore import Qt

from vgraph.gui import transfer_function_editor as tfe
from vgraph.gui.tf_shift_controls import SLIDER_STEPS
from vgraph.transfer_function import PRESETS, TransferFunction, ValueScale

from helpers.gui import ray_caster_tf, ray_caster_tf_editor

# A volume spanning -1000 .. 1000 HU, its percentiles evenly spread.
SCALE = ValueScale((-1000.0, 1000.0), tuple(np.linspace(-1000, 1000, 101)))


@pytest.fixture
def editor(window):
    return ray_caster_tf_editor(window, PRESETS["ct-bone"])


tf = ray_caster_tf


def test_the_shift_slider_waits_for_the_volumes_range(window, editor):
    assert not editor.shift.slider.isEnabled()
    assert "shown once the volume has been evaluated" not in editor.shift.readout.text()  # data units: known
    editor.set_value_scale(SCALE)
    assert editor.shift.slider.isEnabled()


def test_a_slider_drag_shifts_the_points_in_one_undo_step(window, editor, qtbot):
    editor.set_value_scale(SCALE)
    stack, slider = window.workspace.undo_stack, editor.shift.slider
    count = stack.count()
    slider.setFocus()
    slider.setSliderDown(True)   # a drag, as sliderPressed/Released bracket it
    slider.sliderPressed.emit()
    for step in (20, 60, 100):   # 100 of SLIDER_STEPS over the range's width 2000: +200 HU
        slider.setValue(step)
    slider.setSliderDown(False)
    slider.sliderReleased.emit()
    assert tf(window).tf_shift == pytest.approx(100 / SLIDER_STEPS * 2000.0)
    assert tf(window).points == PRESETS["ct-bone"].points and tf(window).tf_scale == 1.0
    assert stack.count() == count + 1
    # The plot draws bone's start (300 HU) at 500 HU: 0.75 of the range.
    assert editor.plot.display_positions()[2] == pytest.approx(0.75)
    assert editor.shift.readout.text() == "points sit at data values -800 .. 3200"
    stack.undo()
    assert tf(window) == PRESETS["ct-bone"]


def test_the_boxes_take_exact_numbers_and_the_readout_follows(window, editor, qtbot):
    editor.set_value_scale(SCALE)
    editor.shift.shift.setValue(-50.0)
    assert tf(window).tf_shift == -50.0
    editor.shift.scale.setValue(2.0)
    assert (tf(window).tf_shift, tf(window).tf_scale) == (-50.0, 2.0)
    assert editor.shift.readout.text() == "points sit at data values -2050 .. 5950"
    editor.plot.selected = 2
    editor.show_value(tf(window))
    assert editor.shift.readout.text() == "point 2: 300 data, sits at data value 550"


def test_a_point_dragged_on_a_shifted_tf_is_stored_without_the_shift(window, editor, qtbot):
    editor.set_value_scale(SCALE)
    editor.shift.shift.setValue(200.0)
    plot = editor.plot
    start = plot.to_pixel(plot.display_positions()[2], PRESETS["ct-bone"].points[2][4]).toPoint()
    end = plot.to_pixel(0.8, 0.5).toPoint()   # 600 HU where it sits: 400 HU stored
    qtbot.mousePress(plot, Qt.LeftButton, pos=start)
    qtbot.mouseMove(plot, end)
    qtbot.mouseRelease(plot, Qt.LeftButton, pos=end)
    sits = plot.from_pixel(end)[0] * 2000.0 - 1000.0
    assert tf(window).points[2][0] == pytest.approx(sits - 200.0, abs=1e-4)
    assert tf(window).tf_shift == 200.0
    assert plot.display_positions()[2] == pytest.approx(plot.from_pixel(end)[0], abs=1e-6)


def test_a_shifted_normalised_tf_waits_for_the_volume_and_says_so(qtbot):
    plot = tfe.TransferFunctionPlot()
    qtbot.addWidget(plot)
    plot.set_transfer_function(TransferFunction(points=PRESETS["grayscale"].points, tf_shift=100.0))
    assert not plot.editable   # a shift in data units needs the volume's range
    plot.set_value_scale(SCALE)
    assert plot.editable
    np.testing.assert_allclose(plot.display_positions(), [0.05, 1.05])   # 100 of the range's 2000
