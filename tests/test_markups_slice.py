"""Markups in the slice views (issue 36): what lies within half a voxel step of the slice plane
(or half the thick slab) is drawn over the slice canvas, in the Markups processor's colour,
labelled with its length in world units or its angle; what lies off the slice is not."""

import numpy as np
import pytest
from PySide6.QtCore import QSettings

from vgraph.gui.canvas_view import CanvasView
from vgraph.markups import Markup, Markups
from vgraph.markups_slice import slice_marks, slice_reach
from vgraph.slicing import slice_plane

from helpers.widget_pixels import grab_rgba, near_colour

ORIGIN, SPACING, DIMS = (0.0, 0.0, 0.0), (1.0, 1.0, 2.0), (64, 64, 32)   # slices 2 apart along z
CURSOR = (32.0, 32.0, 20.0)
YELLOW = (255, 217, 0)


def axial(cursor=CURSOR, size=(64, 64)):
    return slice_plane("axial", None, cursor, 1.0, ORIGIN, SPACING, DIMS, size)


RULER = Markup(name="r", kind="ruler", points=((10.0, 10.0, 20.0), (40.0, 50.0, 20.0)))       # in the slice
ABOVE = Markup(name="above", kind="ruler", points=((10.0, 50.0, 24.0), (50.0, 50.0, 24.0)))   # 2 slices up
ACROSS = Markup(name="across", kind="ruler", points=((50.0, 10.0, 10.0), (50.0, 10.0, 30.0)))  # along z
ANGLE = Markup(name="a", kind="angle", points=((20.0, 40.0, 20.0), (10.0, 40.0, 20.0), (10.0, 50.0, 20.0)))


def test_the_reach_is_half_a_voxel_step_along_the_normal_or_half_the_slab():
    plane = axial()
    assert slice_reach(plane) == pytest.approx(1.0)          # spacing 2 along z
    assert slice_reach(plane, slab_thickness=10.0) == pytest.approx(5.0)
    sagittal = slice_plane("sagittal", None, CURSOR, 1.0, ORIGIN, SPACING, DIMS, (64, 64))
    assert slice_reach(sagittal) == pytest.approx(0.5)


def test_only_what_lies_in_the_slice_is_drawn():
    plane = axial()
    marks = slice_marks([RULER, ABOVE, ACROSS], plane, 1.0, "mm")
    # the ruler in the plane whole; the one two slices up not at all; the one along z as a dot
    assert len(marks.lines) == 2 and len(marks.points) == 2
    np.testing.assert_allclose(marks.lines[0], plane.uv_of(RULER.array), atol=1e-12)
    np.testing.assert_allclose(marks.lines[1][0], marks.lines[1][1], atol=1e-12)
    np.testing.assert_allclose(marks.lines[1][0], plane.uv_of((50.0, 10.0, 20.0)), atol=1e-12)
    assert len(marks.crossings) == 1    # the line along z crosses the slice: a mark where it does
    np.testing.assert_allclose(marks.crossings[0], plane.uv_of((50.0, 10.0, 20.0)), atol=1e-12)
    # labelled with the length in world units: 50 for the 30-40-50 ruler, 20 for the one along z
    assert [text for _, text in marks.labels] == ["r: 50 mm", "across: 20 mm"]
    np.testing.assert_allclose(marks.labels[0][0], plane.uv_of((25.0, 30.0, 20.0)), atol=1e-12)
    # a thick slab reaches the ruler above
    assert "above: 40 mm" in [text for _, text in slice_marks([ABOVE], plane, 5.0, "mm").labels]


def test_a_slice_line_is_cut_to_the_slab():
    plane = axial()
    oblique = Markup(name="o", kind="ruler", points=((0.0, 0.0, 10.0), (0.0, 40.0, 30.0)))  # z rises 1 per 2 y
    marks = slice_marks([oblique], plane, 1.0)
    (ends,) = marks.lines
    np.testing.assert_allclose(plane.world_at(*ends.T)[:, 1], [18.0, 22.0], atol=1e-9)
    np.testing.assert_allclose(plane.world_at(*marks.crossings[0])[1], 20.0, atol=1e-9)
    assert not marks.points      # its ends lie off the slice


def test_hidden_markups_are_not_drawn():
    hidden = RULER.model_copy(update={"visible": False})
    marks = slice_marks([hidden], axial(), 1.0)
    assert not marks.lines and not marks.points and not marks.labels


@pytest.fixture
def slice_workspace(tmp_path):
    from vgraph.gui.workspace import Workspace
    workspace = Workspace(QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat))
    workspace.add_processor("SliceViewer", (0, 0), id="axial")
    workspace.add_processor("Canvas", (0, 120), id="canvas")
    workspace.connect("axial.image", "canvas.image")
    workspace.add_processor("Markups", (200, 0), id="markups")
    workspace.set_property("markups.units", "mm")
    return workspace


@pytest.fixture
def drawn_slice(slice_workspace, qtbot):
    """``draw(markups, plane)``: the slice canvas of ``slice_workspace`` showing a black frame of
    ``plane`` with ``markups`` set -> its pixels and ``widget(point)``, the widget pixel of a world
    point."""
    def draw(markups, plane):
        slice_workspace.set_property("markups.markups", markups)
        view = CanvasView(slice_workspace, "canvas", view_cameras=lambda: {"axial.slice_plane": plane})
        qtbot.addWidget(view)
        view.resize(256, 256)
        view.show()
        qtbot.waitExposed(view)
        frame = np.zeros((64, 64, 4), np.uint8)
        frame[..., 3] = 255
        view.show_frame(frame)
        rect = view.image_rect()

        def widget(point):
            u, v = plane.uv_of(point)
            return rect.left() + u * rect.width(), rect.top() + (1 - v) * rect.height()
        return grab_rgba(view), widget
    return draw


def test_the_slice_canvas_draws_the_markups_in_the_slice_where_they_lie(drawn_slice):
    pixels, widget = drawn_slice(Markups(markups=(RULER, ABOVE, ANGLE)), axial())
    # the ruler's ends and middle, the angle's vertex and its arms' middles carry the markups' colour
    for point in ((10.0, 10.0, 20.0), (40.0, 50.0, 20.0), (25.0, 30.0, 20.0), (10.0, 40.0, 20.0),
                  (15.0, 40.0, 20.0), (10.0, 45.0, 20.0)):
        assert near_colour(pixels, widget(point), YELLOW, reach=1, tolerance=40), point
    # the ruler two slices up is not drawn: its middle stays black (labels lie beside, not on it)
    for point in ((30.0, 50.0, 24.0), (48.0, 50.0, 24.0)):
        assert not near_colour(pixels, widget(point), YELLOW, reach=2, tolerance=120), point
    # the label beside the ruler's middle: yellow text up and right of it
    x, y = widget((25.0, 30.0, 20.0))
    label = pixels[int(y) - 18: int(y) - 4, int(x) + 6: int(x) + 60, :3].astype(int)
    assert (np.abs(label - YELLOW).max(axis=-1) <= 60).sum() >= 20


def test_the_markups_follow_the_slice_plane(drawn_slice):
    """Paging to the slice of the ruler above draws it, and no longer the one at z = 20."""
    pixels, widget = drawn_slice(Markups(markups=(RULER, ABOVE)), axial(cursor=(32.0, 32.0, 24.0)))
    assert near_colour(pixels, widget((30.0, 50.0, 24.0)), YELLOW, reach=1)
    assert not near_colour(pixels, widget((32.5, 40.0, 20.0)), YELLOW, reach=2, tolerance=120)


def test_a_markups_property_that_follows_another_through_a_link_is_drawn_once(slice_workspace):
    from vgraph.gui.slice_markups import markups_sources
    workspace = slice_workspace
    workspace.set_property("markups.markups", Markups(markups=(RULER,)))
    workspace.add_processor("LineProfile", (400, 0), id="profile")
    workspace.link("markups.markups", "profile.markups")
    assert workspace.network.get("profile.markups") == workspace.network.get("markups.markups")
    assert [address for address, *_ in markups_sources(workspace.network)] == ["markups.markups"]
