"""The "Slices" overlay of a 3D canvas (issue #18 item 1): each SliceViewer's plane, where it cuts
the volume's box, drawn over the frame through the frame's camera in its orientation's colour,
cut at the near plane; a toggle on the canvas toolbar (S), on by default and remembered; in the
MPR network a click or the wheel in a slice moves that slice's outline in the 3D canvas."""

import numpy as np
import pytest
from PySide6.QtCore import QPoint, QPointF, QSettings, Qt
from PySide6.QtGui import QWheelEvent
from PySide6.QtWidgets import QApplication

from vgraph.camera import Camera
from vgraph.gui import overlays
from vgraph.gui.canvas_toolbar import CanvasPane
from vgraph.gui.canvas_view import CanvasView
from vgraph.gui.overlays import ViewGeometry
from vgraph.live.slice_clicks import slice_outlines
from helpers.gui import open_mpr, raycast_workspace, settle
from vgraph.slicing import slice_plane

from helpers.widget_pixels import grab_rgba, near_colour, rgb, widget_points
from helpers.paths import DATA

BOX = ((0.0, 0.0, 0.0), (200.0, 200.0, 100.0))
DIMS = (100, 100, 50)          # voxels of spacing 2 whose cells fill BOX ...
ORIGIN = (1.0, 1.0, 1.0)       # ... centre i at 1 + 2 i
SPACING = (2.0, 2.0, 2.0)


@pytest.fixture
def settings(tmp_path):
    return QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)


@pytest.fixture
def ws(qtbot, settings):
    workspace = raycast_workspace(settings)
    for orientation in ("axial", "coronal", "sagittal"):
        workspace.add_processor("SliceViewer", (200, 0), id=orientation)
        workspace.set_property(f"{orientation}.orientation", orientation)
    return workspace


def planes(cursor=(60.0, 80.0, 30.0), orientations=("axial", "coronal", "sagittal")) -> dict:
    """view_cameras as the render process reports them, from vgraph.slicing itself."""
    return {f"{o}.slice_plane": slice_plane(o, None, cursor, 1.0, ORIGIN, SPACING, DIMS, (64, 64))
            for o in orientations}


def make_pane(qtbot, ws, settings, cameras, size=(320, 280)) -> CanvasPane:
    pane = CanvasPane(CanvasView(ws, "canvas", view_cameras=lambda: cameras), settings)
    qtbot.addWidget(pane)
    pane.resize(*size)
    pane.show()
    qtbot.waitExposed(pane)
    return pane


def show(view, camera, frame_size=(160, 120)):
    frame = np.zeros((frame_size[1], frame_size[0], 4), np.uint8)
    frame[..., :3], frame[..., 3] = 40, 255
    view.set_view_geometry(ViewGeometry(camera, *BOX))
    view.show_frame(frame)


def inside_polygon(point, polygon, margin) -> bool:
    """Inside the convex polygon (widget points in order) or within ``margin`` of its edges."""
    point = np.asarray(point, float)
    edges = [(polygon[i], polygon[(i + 1) % len(polygon)]) for i in range(len(polygon))]
    near = min(np.linalg.norm(point - (a + np.clip((point - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
                                       * (b - a))) for a, b in edges)
    sides = [(b - a)[0] * (point - a)[1] - (b - a)[1] * (point - a)[0] for a, b in edges]
    return near < margin or all(s >= 0 for s in sides) or all(s <= 0 for s in sides)


CAMERA = Camera.looking_at_box(*BOX, direction=(-0.6, 0.8, -0.5), up=(0, 0, 1), aspect=160 / 120)


def test_each_outline_is_drawn_where_its_corners_project_in_its_colour(ws, qtbot, settings):
    cameras = planes()
    pane = make_pane(qtbot, ws, settings, cameras)
    view = pane.view
    show(view, CAMERA)
    assert view.slices_visible() and pane.toolbar.slices_action.isChecked()   # on by default
    pane.toolbar.axes_action.setChecked(False)
    pane.toolbar.slices_action.setChecked(False)
    plain = grab_rgba(view)
    pane.toolbar.slices_action.setChecked(True)
    drawn = grab_rgba(view)
    rect = view.image_rect()
    outlines = slice_outlines(cameras)
    assert set(outlines) == {"axial", "coronal", "sagittal"}
    np.testing.assert_allclose(outlines["axial"][:, 2], 30.0)   # the plane through the cursor
    projected = {}
    for name, outline in outlines.items():
        points = widget_points(CAMERA, outline, (160, 120), rect)
        projected[name] = points
        colour = rgb(overlays.SLICE_COLOURS[name])
        for a, b in zip(points, np.roll(points, -1, axis=0)):
            for t in (0.0, 0.3, 0.7):  # corners and points along each edge
                assert near_colour(drawn, a + t * (b - a), colour), (name, a, b, t)
    # every pixel the overlay changed lies on or inside one of the projected polygons
    changed = np.nonzero(np.abs(drawn.astype(int) - plain).max(axis=-1) > 0)
    assert len(changed[0]) > 0
    for y, x in list(zip(*changed))[:: max(1, len(changed[0]) // 400)]:
        assert any(inside_polygon((x + 0.5, y + 0.5), p, 2.5) for p in projected.values()), (x, y)


def test_colours_follow_3d_slicer():
    """Axial red, sagittal yellow, coronal green, as 3D Slicer's views (and the slice views'
    crosshairs, slice_overlay.py)."""
    rgb_of = {name: overlays.SLICE_COLOURS[name].getRgb()[:3] for name in ("axial", "sagittal", "coronal")}
    assert rgb_of == {"axial": (243, 74, 51), "sagittal": (237, 213, 76), "coronal": (110, 176, 75)}


def test_near_plane_clipping_keeps_the_part_in_front():
    camera = Camera(position=(100.0, 100.0, 50.0), focus=(100.0, 300.0, 50.0), up=(0, 0, 1),
                    near=1.0, far=500.0)
    # The coronal plane y = 150 in front, and the axial plane z = 50 through the eye: half behind.
    axial = slice_plane("axial", None, (100.0, 100.0, 50.0), 1.0, ORIGIN, SPACING, DIMS, (64, 64))
    outline = axial.outline()
    clip = overlays.to_clip(camera, outline, 1.0)
    kept = overlays.near_clipped(clip)
    assert len(kept) >= 3
    assert np.all(kept[:, 2] + kept[:, 3] >= -1e-9)               # nothing behind the near plane
    # the cut vertices lie on the near plane; the others are the outline's vertices in front
    in_front = clip[clip[:, 2] + clip[:, 3] >= 0]
    on_plane = np.abs(kept[:, 2] + kept[:, 3]) < 1e-9
    assert on_plane.sum() == 2
    for vertex in kept[~on_plane]:
        assert np.min(np.abs(in_front - vertex).max(axis=1)) < 1e-9
    # world points of the cut vertices are at the near distance in front of the camera
    inverse = np.linalg.inv(camera.view_projection(1.0))
    world = kept[on_plane] @ inverse.T
    world = world[:, :3] / world[:, 3:]
    np.testing.assert_allclose(world[:, 1], 101.0, atol=1e-6)
    assert len(overlays.near_clipped(overlays.to_clip(
        Camera(position=(100.0, -100.0, 50.0), focus=(100.0, -300.0, 50.0), up=(0, 0, 1), near=1.0,
               far=500.0), outline, 1.0))) == 0                    # wholly behind: nothing


def test_a_camera_inside_the_box_still_draws_the_slices_in_front(ws, qtbot, settings):
    # The axial plane z = 45 runs just below the eye, half of it behind the camera.
    cameras = planes(cursor=(100.0, 180.0, 45.0), orientations=("coronal", "axial"))
    pane = make_pane(qtbot, ws, settings, cameras)
    view = pane.view
    pane.toolbar.axes_action.setChecked(False)
    inside = Camera(position=(100.0, 100.0, 50.0), focus=(100.0, 300.0, 50.0), up=(0, 0, 1),
                    fov=90.0, near=1.0, far=500.0)
    show(view, inside)
    pixels = grab_rgba(view)
    rect = view.image_rect()
    # the coronal plane y = 180 faces the camera: its edges at the box's floor and ceiling
    for point in widget_points(inside, [(100.0, 180.0, 0.0), (100.0, 180.0, 100.0)], (160, 120), rect):
        assert rect.contains(QPointF(*point))
        assert near_colour(pixels, point, rgb(overlays.SLICE_COLOURS["coronal"])), point
    # the axial plane's far edge (on the box's face y = 200) is drawn, its part behind is cut off
    far_edge = widget_points(inside, [(100.0, 200.0, 45.0)], (160, 120), rect)[0]
    assert near_colour(pixels, far_edge, rgb(overlays.SLICE_COLOURS["axial"])), far_edge
    kept = overlays.polygon_points(ViewGeometry(inside, *BOX), slice_outlines(cameras)["axial"], rect)
    assert len(kept) >= 3 and np.all(np.isfinite(kept))
    assert kept[:, 1].min() >= rect.center().y() - 1e-6     # all of it below the horizon


def test_the_slices_switch_is_remembered_per_canvas_and_has_the_key_s(ws, qtbot, settings):
    first = make_pane(qtbot, ws, settings, planes())
    assert first.toolbar.slices_action.shortcut().toString() == "S"
    first.toolbar.slices_action.setChecked(False)
    again = make_pane(qtbot, ws, settings, planes())
    assert not again.view.slices_visible() and not again.toolbar.slices_action.isChecked()
    again.view.setFocus()
    qtbot.waitUntil(again.view.hasFocus)
    qtbot.keyClick(again.view, Qt.Key_S)
    assert again.view.slices_visible()


def test_a_removed_slice_viewer_draws_nothing(ws, qtbot, settings):
    cameras = planes(orientations=("axial",))
    pane = make_pane(qtbot, ws, settings, cameras)
    pane.toolbar.axes_action.setChecked(False)
    show(pane.view, CAMERA)
    with_slice = grab_rgba(pane.view)
    ws.remove(["axial"])
    pane.toolbar.slices_action.setChecked(False)
    without = grab_rgba(pane.view)
    pane.toolbar.slices_action.setChecked(True)
    assert np.array_equal(grab_rgba(pane.view), without) and not np.array_equal(with_slice, without)


# --- in the main window: networks/mpr_mri_head.json ---------------------------------------------

SIZE = 96


@pytest.fixture
def mpr(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    return open_mpr(window, qtbot, SIZE)


def axial_corners(window, view):
    """The axial outline's corners as the 3D canvas's frame camera projects them."""
    outline = slice_outlines(window.evaluation.view_cameras)["axial"]
    height, width = view.frame().shape[:2]
    return outline, widget_points(view.view_geometry().camera, outline, (width, height), view.image_rect())


def wheel(view, notches):
    point = view.image_rect().center()
    event = QWheelEvent(point, view.mapToGlobal(point), QPoint(0, 0), QPoint(0, 120 * notches),
                        Qt.NoButton, Qt.NoModifier, Qt.NoScrollPhase, False)
    QApplication.sendEvent(view, event)


def test_the_3d_canvas_shows_the_axial_outline_and_it_follows_the_cursor(mpr, qtbot):
    view = mpr.canvases.views["canvas"]
    assert view.slices_visible()
    colour = rgb(overlays.SLICE_COLOURS["axial"])
    outline, before = axial_corners(mpr, view)
    pixels = grab_rgba(view)
    for point in before:
        assert near_colour(pixels, point, colour), point

    # A click in the coronal slice, above its centre, moves the axial plane up there.
    coronal = mpr.canvases.views["coronal_canvas"]
    rect = coronal.image_rect()
    qtbot.mouseClick(coronal, Qt.LeftButton, pos=QPoint(round(rect.center().x()), round(rect.top() + 0.3 * rect.height())))
    settle(mpr, qtbot)
    cursor = np.array(mpr.workspace.network.get("axial.cursor"))
    moved, after = axial_corners(mpr, view)
    np.testing.assert_allclose(moved[:, 2], cursor[2], atol=1e-9)
    assert cursor[2] > outline[0, 2] + 1.0
    pixels = grab_rgba(view)
    for point in after:
        assert near_colour(pixels, point, colour), point
    for point in before:     # nothing axial left where the old corners were
        if np.min(np.linalg.norm(after - point, axis=1)) > 4:
            assert not near_colour(pixels, point, colour), point

    # The wheel in the axial canvas pages the axial plane: its outline moves again.
    wheel(mpr.canvases.views["axial_canvas"], 3)
    qtbot.waitUntil(lambda: mpr.workspace.network.get("axial.cursor")[2] != cursor[2], timeout=5000)
    settle(mpr, qtbot)
    paged, _ = axial_corners(mpr, view)
    assert abs(paged[0, 2] - moved[0, 2]) > 1.0
