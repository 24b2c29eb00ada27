"""Markups placed and dragged with the mouse (issue 36, vgraph.gui.markup_placing): clicks with
the canvas toolbar's Place on pick through the render process (the tricubic surface point in iso
mode, the plane point in a slice), a ruler completes on its second click, each placement and each
whole drag is one undo step, and a click on nothing adds nothing and says why."""

import numpy as np
import pytest
from PySide6.QtCore import QEvent, QPointF, Qt

import vgraph
from vgraph.gui.hover import frame_pixel
from vgraph.gui.markup_placing import place_point
from vgraph.markups import Markup, Markups

from helpers.gui import open_mpr, send_mouse, settle
from helpers.paths import DATA, REPO

SIZE = 96
HEAD = REPO / "networks" / "raycast_head.json"
ISO = {"rc.compositing": "iso", "rc.iso_level": 0.3}


def with_markups(set_, connect, disconnect_canvas, link):
    """The head's ray caster drawn through a Markups processor 'mk' (as bench/make_markups_image.py)."""
    for address, value in ISO.items():
        set_(address, value)
    link("eep.camera", "mk.camera")
    disconnect_canvas()
    for source, target in (("rc.image", "mk.image"), ("rc.depth", "mk.depth"), ("source.volume", "mk.volume"),
                           ("mk.image", "canvas.image")):
        connect(source, target)


@pytest.fixture
def head(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    assert window.open_network(HEAD)
    workspace = window.workspace
    workspace.add_processor("Markups", (200, 200), id="mk")
    canvas_link = next(c for c in workspace.network.connections if c.target == "canvas")
    linked = any({link.source, link.target} == {"eep.camera", "mk.camera"} for link in workspace.network.links)
    with_markups(workspace.set_property, workspace.connect,
                 lambda: workspace.disconnect(canvas_link), lambda *a: None if linked else workspace.link(*a))
    workspace.set_property("canvas.size", [SIZE, SIZE])
    settle(window, qtbot)
    return window


def reference_network():
    network = vgraph.load(HEAD)
    network.add("Markups", id="mk")

    def disconnect_canvas():
        network.disconnect("rc.image", "canvas.image")
    with_markups(network.set, network.connect, disconnect_canvas, network.link)
    network.set("canvas.size", (SIZE, SIZE))
    return network


def click(view, pos, modifiers=Qt.NoModifier):
    send_mouse(view, QEvent.MouseButtonPress, pos, Qt.LeftButton, Qt.LeftButton, modifiers)
    send_mouse(view, QEvent.MouseButtonRelease, pos, Qt.LeftButton, Qt.NoButton, modifiers)


def answered(window, qtbot):
    """Wait until every requested pick is answered and the frames are final again."""
    hover = window.canvases.hover
    qtbot.waitUntil(lambda: not hover.requests and not hover._callbacks, timeout=60000)
    settle(window, qtbot)


def place_at(window, qtbot, view, pos):
    click(view, pos)
    answered(window, qtbot)


def head_pixels(view):
    """Two widget positions on the head: left and right of its centre."""
    rect = view.image_rect()
    centre = rect.center()
    return (centre.x() - rect.width() * 0.12, centre.y()), (centre.x() + rect.width() * 0.1, centre.y() + 4)


def test_a_ruler_placed_by_two_clicks_equals_the_picks_and_undo_removes_it(head, qtbot):
    view = head.canvases.views["canvas"]
    pane = view.parentWidget()
    pane.toolbar.place_action.trigger()
    assert view.placing
    network, undo = head.workspace.network, head.workspace.undo_stack
    first, second = head_pixels(view)
    steps = undo.count()
    place_at(head, qtbot, view, first)
    assert len(network.get("mk.markups")) == 0  # a ruler needs both points: the first is held
    assert "point 1 of 2" in head.statusBar().currentMessage()
    place_at(head, qtbot, view, second)
    ruler = network.get("mk.markups")["ruler 1"]
    assert undo.count() == steps + 1
    reference = reference_network()
    for pos, placed in zip((first, second), ruler.points):
        expected = reference.pick("canvas", *frame_pixel(view, QPointF(*pos)))
        assert expected.hit and expected.surface is not None
        np.testing.assert_allclose(placed, expected.surface.point, atol=1e-6)
    assert ruler.length > 10.0
    undo.undo()
    assert len(network.get("mk.markups")) == 0


def test_a_point_list_grows_by_one_undo_step_per_click(head, qtbot):
    view = head.canvases.views["canvas"]
    view.set_placing(True)
    head.scene.select_processor("mk")
    head.workspace.set_property("mk.place_kind", "points")
    network, undo = head.workspace.network, head.workspace.undo_stack
    first, second = head_pixels(view)
    place_at(head, qtbot, view, first)
    place_at(head, qtbot, view, second)
    assert [len(m.points) for m in network.get("mk.markups").markups] == [2]
    undo.undo()
    assert len(network.get("mk.markups")["points 1"].points) == 1
    view.set_placing(False)   # placing again starts a new point list
    view.set_placing(True)
    place_at(head, qtbot, view, second)
    assert [(m.name, len(m.points)) for m in network.get("mk.markups").markups] == [("points 1", 1), ("points 2", 1)]


def test_dragging_a_point_moves_it_to_the_picked_surface_in_one_undo_step(head, qtbot):
    view = head.canvases.views["canvas"]
    network, undo = head.workspace.network, head.workspace.undo_stack
    first, second = head_pixels(view)
    reference = reference_network()
    start = reference.pick("canvas", *frame_pixel(view, QPointF(*first))).surface.point
    other = reference.pick("canvas", *frame_pixel(view, QPointF(*second))).surface.point
    head.workspace.set_property("mk.markups", Markups(markups=(
        Markup(name="r", kind="ruler", points=(tuple(start), tuple(other))),)))
    settle(head, qtbot)
    steps = undo.count()
    assert not view.placing  # points are dragged in any mode
    end = (first[0] + 3, first[1] - 6)
    send_mouse(view, QEvent.MouseButtonPress, first, Qt.LeftButton, Qt.LeftButton)
    for i in (1, 2, 3):
        send_mouse(view, QEvent.MouseMove, (first[0] + i, first[1] - 2 * i), Qt.NoButton, Qt.LeftButton)
    send_mouse(view, QEvent.MouseButtonRelease, end, Qt.LeftButton, Qt.NoButton)
    answered(head, qtbot)
    moved = network.get("mk.markups")["r"]
    expected = reference.pick("canvas", *frame_pixel(view, QPointF(*end))).surface.point
    np.testing.assert_allclose(moved.points[0], expected, atol=1e-6)
    np.testing.assert_allclose(moved.points[1], other, atol=0)
    assert undo.count() == steps + 1
    undo.undo()
    np.testing.assert_allclose(network.get("mk.markups")["r"].points[0], start, atol=0)


def test_a_click_where_nothing_is_drawn_adds_nothing_and_says_why(head, qtbot):
    view = head.canvases.views["canvas"]
    view.set_placing(True)
    steps = head.workspace.undo_stack.count()
    rect = view.image_rect()
    place_at(head, qtbot, view, (rect.left() + 1, rect.top() + 1))
    assert len(head.workspace.network.get("mk.markups")) == 0
    assert head.workspace.undo_stack.count() == steps
    message = head.statusBar().currentMessage()
    assert message.startswith("nothing placed") and "nothing drawn" in message


def test_a_click_in_a_slice_places_the_point_on_its_plane(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    mpr = open_mpr(window, qtbot, SIZE)
    mpr.workspace.add_processor("Markups", (400, 0), id="mk")
    mpr.scene.select_processor("mk")
    mpr.workspace.set_property("mk.place_kind", "points")
    view = mpr.canvases.views["axial_canvas"]
    view.set_placing(True)
    centre = view.image_rect().center()
    pos = (centre.x() - 7, centre.y() + 5)
    place_at(mpr, qtbot, view, pos)
    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    expected = plane.pixel_to_world(*frame_pixel(view, QPointF(*pos)), (SIZE, SIZE))
    placed = mpr.workspace.network.get("mk.markups")["points 1"].points
    np.testing.assert_allclose(placed, [expected], atol=1e-9)


def test_place_point_holds_points_until_the_kind_is_complete():
    empty = Markups()
    changed, current, held = place_point(empty, "angle", None, (), (0.0, 0.0, 0.0))
    assert changed is None and current is None and held == ((0.0, 0.0, 0.0),)
    changed, current, held = place_point(empty, "angle", None, held, (1.0, 0.0, 0.0))
    assert changed is None and len(held) == 2
    changed, current, held = place_point(empty, "angle", None, held, (1.0, 1.0, 0.0))
    assert current == "angle 1" and held == () and changed["angle 1"].angle == pytest.approx(90.0)
    # an angle takes no more points: the next click starts a new one
    changed, current, held = place_point(changed, "angle", current, held, (5.0, 5.0, 5.0))
    assert changed is None and current is None and len(held) == 1


def test_a_point_drawn_in_a_slice_is_dragged_on_its_plane_in_one_undo_step(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    mpr = open_mpr(window, qtbot, SIZE)
    mpr.workspace.add_processor("Markups", (400, 0), id="mk")
    view = mpr.canvases.views["axial_canvas"]
    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    centre = view.image_rect().center()
    start, end = (centre.x() - 7, centre.y() + 5), (centre.x() + 9, centre.y() - 4)
    at_start = plane.pixel_to_world(*frame_pixel(view, QPointF(*start)), (SIZE, SIZE))
    other = np.asarray(plane.centre) + (20.0, 20.0, 0.0)
    mpr.workspace.set_property("mk.markups", Markups(markups=(
        Markup(name="r", kind="ruler", points=(tuple(at_start), tuple(other))),)))
    steps, cursor = mpr.workspace.undo_stack.count(), mpr.workspace.network.get("axial.cursor")
    send_mouse(view, QEvent.MouseButtonPress, start, Qt.LeftButton, Qt.LeftButton)
    for i in (1, 2, 3):
        point = (start[0] + (end[0] - start[0]) * i / 4, start[1] + (end[1] - start[1]) * i / 4)
        send_mouse(view, QEvent.MouseMove, point, Qt.NoButton, Qt.LeftButton)
    send_mouse(view, QEvent.MouseButtonRelease, end, Qt.LeftButton, Qt.NoButton)
    answered(mpr, qtbot)
    moved = mpr.workspace.network.get("mk.markups")["r"]
    expected = plane.pixel_to_world(*frame_pixel(view, QPointF(*end)), (SIZE, SIZE))
    np.testing.assert_allclose(moved.points[0], expected, atol=1e-9)
    np.testing.assert_allclose(moved.points[1], other, atol=0)
    assert mpr.workspace.undo_stack.count() == steps + 1
    # the slice cursor stayed: the press grabbed the point instead of moving the cursor
    assert mpr.workspace.network.get("axial.cursor") == cursor


def test_nearest_slice_point_takes_points_in_the_slice_only():
    from vgraph.gui.markup_placing import nearest_slice_point
    from vgraph.slicing import slice_plane
    plane = slice_plane("axial", None, (32.0, 32.0, 20.0), 1.0, (0.0, 0.0, 0.0), (1.0, 1.0, 2.0), (64, 64, 32),
                        (64, 64))
    markups = Markups(markups=(Markup(name="off", kind="points", points=((32.0, 32.0, 24.0),)),
                               Markup(name="on", kind="points", points=((33.0, 32.0, 20.0),))))
    rect = (0.0, 0.0, 64.0, 64.0)   # one widget pixel per world unit
    u, v = plane.uv_of((32.0, 32.0, 20.0))
    assert nearest_slice_point(markups, plane, 1.0, (u * 64, (1 - v) * 64), rect) == ("on", 0)
    assert nearest_slice_point(markups, plane, 1.0, (u * 64 + 20, (1 - v) * 64), rect) is None


def test_placing_with_a_linked_profile_selected_places_into_the_ruler_s_markups():
    from vgraph.gui.markup_placing import markups_address
    network = vgraph.Network()
    network.add("Markups", id="mk")
    network.add("LineProfile", id="profile")
    network.link("mk.markups", "profile.markups")
    assert markups_address(network, "nothing", "profile") == "mk.markups"
    assert markups_address(network, "nothing", "mk") == "mk.markups"
