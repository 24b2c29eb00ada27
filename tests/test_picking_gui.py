"""The GUI's hover readout (issue 36): moving the mouse over a canvas (no button pressed) shows in
the status bar what ``Network.pick`` gives for that pixel (world point, voxel, values), and with
View > Corner Annotation the same in the canvas's corner; over a slice canvas the point on the
plane. The pick runs in the render process (vgraph.live.probes), on the frame it drew."""

import numpy as np
import pytest
from PySide6.QtCore import QEvent, QPointF, Qt

import vgraph
from vgraph.gui.hover import frame_pixel
from vgraph.live.probes import Probe, answer, corner_lines, status_text

from helpers.gui import open_mpr, send_mouse, settle
from helpers.paths import DATA, REPO

SIZE = 96
HEAD = REPO / "networks" / "raycast_head.json"


def hover(window, qtbot, view, pos):
    """Move the mouse to widget ``pos`` with no button and wait for the readout's answer."""
    before = window.canvases.hover.answers
    send_mouse(view, QEvent.MouseMove, pos, Qt.NoButton, Qt.NoButton)
    qtbot.waitUntil(lambda: window.canvases.hover.answers > before, timeout=60000)
    return window.canvases.hover.last


@pytest.fixture
def head(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    assert window.open_network(HEAD)
    window.workspace.set_property("canvas.size", [SIZE, SIZE])
    settle(window, qtbot)
    return window


def centre_of(view) -> tuple[float, float]:
    rect = view.image_rect()
    return rect.center().x(), rect.center().y()


def test_hovering_the_head_shows_the_picked_point_voxel_and_value(head, qtbot):
    view = head.canvases.views["canvas"]
    pos = centre_of(view)
    shown = hover(head, qtbot, view, pos)
    x, y = frame_pixel(view, QPointF(*pos))
    # the same pick in this process, on the same network at the same size
    network = vgraph.load(HEAD)
    network.set("canvas.size", (SIZE, SIZE))
    expected = network.pick("canvas", x, y)
    assert shown.result.hit and expected.hit
    np.testing.assert_allclose(shown.result.point, expected.point, atol=1e-3)
    assert shown.result.voxel == expected.voxel
    assert shown.result.value == pytest.approx(expected.value, abs=1e-3)
    text = head.statusBar().currentMessage()
    assert text == status_text(shown)
    assert f"voxel {expected.voxel}" in text and "source.volume" in text
    assert head.evaluation.hovered == ("canvas",)  # its frames draw the depth from now on


def test_the_corner_annotation_is_switched_on_and_off(head, qtbot):
    view = head.canvases.views["canvas"]
    action = head.canvases.hover.corner_action
    action.setChecked(False)
    shown = hover(head, qtbot, view, centre_of(view))
    assert view.annotation() == ()
    action.setChecked(True)
    assert view.annotation() == tuple(corner_lines(shown))
    assert any(line.startswith("voxel (") for line in view.annotation())
    shown = hover(head, qtbot, view, (centre_of(view)[0] + 2, centre_of(view)[1]))
    assert view.annotation() == tuple(corner_lines(shown))
    action.setChecked(False)
    assert view.annotation() == ()


def test_hovering_beside_the_head_says_nothing_is_drawn(head, qtbot):
    view = head.canvases.views["canvas"]
    rect = view.image_rect()
    shown = hover(head, qtbot, view, (rect.left() + 1, rect.top() + 1))
    assert not shown.result.hit
    assert "nothing drawn" in head.statusBar().currentMessage()


def test_hovering_a_slice_gives_the_point_on_its_plane(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    mpr = open_mpr(window, qtbot, SIZE)
    view = mpr.canvases.views["axial_canvas"]
    pos = centre_of(view)
    shown = hover(mpr, qtbot, view, (pos[0] - 7, pos[1] + 5))
    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    x, y = frame_pixel(view, QPointF(pos[0] - 7, pos[1] + 5))
    assert shown.result.kind == "slice"
    np.testing.assert_allclose(shown.result.point, plane.pixel_to_world(x, y, (SIZE, SIZE)), atol=1e-9)
    assert shown.result.samples and shown.result.samples[0].value is not None


def test_a_probe_of_a_processor_that_is_no_canvas_is_answered_with_its_error():
    network = vgraph.Network()
    network.add("EntryExitPoints", id="eep")
    reply = answer(network, Probe("eep", 1, 1, (8, 8)))
    assert reply.result is None and "not a canvas" in reply.error
    assert status_text(reply) == reply.error and corner_lines(reply) == []
