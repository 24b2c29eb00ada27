"""The multi-planar layout in the GUI: a click in the axial slice of networks/mpr_mri_head.json
moves the shared cursor there (the coronal and sagittal viewers follow through their linked
cursor properties, and their images change), as one undo step; a click beside the image or in a
3D canvas moves nothing; View > Tile Canvases puts the four views in a grid."""

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from vgraph.gui.slice_clicks import OUTSIDE, slice_outlines, slice_viewer_for

from helpers.paths import DATA, REPO

SIZE = 96  # canvas side: small frames keep the test quick


@pytest.fixture
def mpr(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    assert window.open_network(REPO / "networks" / "mpr_mri_head.json")
    for canvas in ("axial_canvas", "coronal_canvas", "sagittal_canvas", "canvas"):
        window.workspace.set_property(f"{canvas}.size", [SIZE, SIZE])
    settle(window, qtbot)
    return window


def settle(window, qtbot):
    qtbot.waitUntil(lambda: window.evaluation.idle()
                    and all(view.is_final and view.frame() is not None
                            for view in window.canvases.views.values()), timeout=120000)


def frame(window, canvas_id) -> np.ndarray:
    return window.canvases.views[canvas_id].frame().copy()


def widget_point(view, u, v) -> QPoint:
    """The widget pixel at image coordinates (u, v) (u right, v up) of the frame the view shows."""
    rect = view.image_rect()
    return QPoint(round(rect.left() + u * rect.width()), round(rect.top() + (1.0 - v) * rect.height()))


def test_a_click_in_the_axial_slice_moves_the_coronal_and_sagittal_planes(mpr, qtbot):
    network = mpr.workspace.network
    assert network.get("axial.cursor") is None  # the volume's centre
    axial = mpr.canvases.views["axial_canvas"]
    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    before = {c: frame(mpr, c) for c in ("coronal_canvas", "sagittal_canvas")}
    point = widget_point(axial, 0.3, 0.7)
    qtbot.mouseClick(axial, Qt.LeftButton, pos=point)
    settle(mpr, qtbot)

    # The clicked world point, from the plane the render process reported (the widget point is
    # rounded to whole pixels, so recompute its (u, v)).
    rect = axial.image_rect()
    u, v = (point.x() - rect.left()) / rect.width(), 1.0 - (point.y() - rect.top()) / rect.height()
    expected = plane.world_at(u, v)
    cursor = np.array(network.get("axial.cursor"))
    np.testing.assert_allclose(cursor, expected, atol=1e-9)
    np.testing.assert_allclose(cursor[2], plane.centre[2])  # on the axial plane: same slice
    assert network.get("coronal.cursor") == network.get("axial.cursor")
    assert network.get("sagittal.cursor") == network.get("axial.cursor")
    for canvas, old in before.items():
        assert not np.array_equal(frame(mpr, canvas), old), f"{canvas} did not change"
    # The planes the render process reports now pass through the cursor.
    for viewer in ("coronal", "sagittal"):
        moved = mpr.evaluation.view_cameras[f"{viewer}.slice_plane"]
        np.testing.assert_allclose(np.dot(cursor - moved.centre, moved.normal), 0.0, atol=1e-6)
    # One undo step puts all three back.
    mpr.workspace.undo_stack.undo()
    assert network.get("axial.cursor") is None and network.get("sagittal.cursor") is None


def test_clicks_beside_the_slice_or_in_the_3d_view_move_no_cursor(mpr, qtbot):
    network = mpr.workspace.network
    axial = mpr.canvases.views["axial_canvas"]
    axial.resize(3 * SIZE, SIZE + 10)  # the frame is letterboxed: there is room beside it
    qtbot.mouseClick(axial, Qt.LeftButton, pos=QPoint(3, SIZE // 2))
    assert network.get("axial.cursor") is None and axial.message() == OUTSIDE
    qtbot.mouseClick(mpr.canvases.views["canvas"], Qt.LeftButton, pos=QPoint(SIZE // 2, SIZE // 2))
    assert network.get("axial.cursor") is None


def test_the_slice_a_canvas_shows_is_found_upstream(mpr):
    network = mpr.workspace.network
    assert slice_viewer_for(network, "sagittal_canvas") == "sagittal"
    assert slice_viewer_for(network, "canvas") is None


def test_tile_canvases_shows_the_four_views_side_by_side(mpr, qtbot):
    docks = [mpr.canvases.docks[c] for c in ("axial_canvas", "coronal_canvas", "sagittal_canvas", "canvas")]
    assert mpr.tabifiedDockWidgets(docks[0])  # tabbed together by default
    mpr.tile_canvases_action.trigger()  # View > Tile Canvases
    qtbot.waitUntil(lambda: all(dock.isVisible() for dock in docks))
    assert all(not mpr.tabifiedDockWidgets(dock) for dock in docks)
    top_left, top_right, bottom_left, bottom_right = (dock.geometry() for dock in docks)
    assert top_left.top() == top_right.top() < bottom_left.top() == bottom_right.top()
    assert top_left.left() == bottom_left.left() < top_right.left() == bottom_right.left()
    assert all(mpr.canvases.views[c].isVisible() for c in mpr.canvases.views)


def test_the_slices_outlines_for_a_3d_overlay(mpr):
    outlines = slice_outlines(mpr.evaluation.view_cameras)
    assert set(outlines) == {"axial", "coronal", "sagittal"}
    assert all(len(outline) == 4 for outline in outlines.values())  # axis-aligned: rectangles
