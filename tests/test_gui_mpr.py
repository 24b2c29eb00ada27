"""The multi-planar layout in the GUI: a click in the axial slice of networks/mpr_mri_head.json
moves the shared cursor there (the coronal and sagittal viewers follow through their linked
cursor properties, and their images change), as one undo step; a click beside the image or in a
3D canvas moves nothing; View > Tile Canvases puts the four views in a grid. On a slice canvas
the wheel pages the slice by the voxel spacing along its normal (Shift: 10 voxels) and a right
drag sets window (horizontal) and level (vertical), each gesture one undo step."""

import numpy as np
import pytest
from PySide6.QtCore import QEvent, QPoint, Qt
from PySide6.QtGui import QWheelEvent
from PySide6.QtWidgets import QApplication

from vgraph.gui import slice_gestures
from vgraph.live.slice_clicks import OUTSIDE, slice_outlines, slice_viewer_for

from helpers.gui import open_mpr, send_mouse, settle
from helpers.paths import DATA

MRI = DATA / "mri_head_t1" / "MR.nii.gz"

SIZE = 96  # canvas side: small frames keep the test quick


@pytest.fixture
def mpr(window, jobs, qtbot):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    return open_mpr(window, qtbot, SIZE)


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


# --- the wheel and the right drag on a slice ----------------------------------------------------


def wheel(view, notches, modifiers=Qt.NoModifier):
    point = view.image_rect().center()
    event = QWheelEvent(point, view.mapToGlobal(point), QPoint(0, 0), QPoint(0, round(120 * notches)),
                        Qt.NoButton, modifiers, Qt.NoScrollPhase, False)
    QApplication.sendEvent(view, event)


def end_wheel_burst(view, qtbot):
    qtbot.waitUntil(lambda: view._wheel is None, timeout=5000)


def right_drag(view, offset, steps=4):
    start = view.image_rect().center()
    start = (start.x(), start.y())
    send_mouse(view, QEvent.MouseButtonPress, start, Qt.RightButton, Qt.RightButton)
    for i in range(1, steps + 1):
        pos = (start[0] + offset[0] * i / steps, start[1] + offset[1] * i / steps)
        send_mouse(view, QEvent.MouseMove, pos, Qt.NoButton, Qt.RightButton)
    end = (start[0] + offset[0], start[1] + offset[1])
    send_mouse(view, QEvent.MouseButtonRelease, end, Qt.RightButton, Qt.NoButton)


def nifti():
    nibabel = pytest.importorskip("nibabel")
    return nibabel.load(MRI)


def test_the_wheel_pages_the_slice_by_the_voxel_spacing_along_its_normal(mpr, qtbot):
    network, undo = mpr.workspace.network, mpr.workspace.undo_stack
    axial = mpr.canvases.views["axial_canvas"]
    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    spacing_z = float(nifti().header.get_zooms()[2])      # the file's own voxel size along z
    np.testing.assert_allclose(plane.normal, (0.0, 0.0, -1.0))  # axial: seen from below
    depth = undo.count()

    wheel(axial, 1)
    wheel(axial, 1)                                         # one burst of two notches
    expected = np.array(plane.centre) + 2 * spacing_z * np.array(plane.normal)
    np.testing.assert_allclose(network.get("axial.cursor"), expected, atol=1e-6)
    assert network.get("coronal.cursor") == network.get("sagittal.cursor") == network.get("axial.cursor")
    end_wheel_burst(axial, qtbot)
    assert undo.count() == depth + 1                        # one undo step for the burst
    settle(mpr, qtbot)
    moved = mpr.evaluation.view_cameras["axial.slice_plane"]
    np.testing.assert_allclose(moved.centre[2], expected[2], atol=1e-6)  # the image shows it

    wheel(axial, -1, Qt.ShiftModifier)                      # Shift: ten voxels, back up
    np.testing.assert_allclose(network.get("axial.cursor"),
                               expected - 10 * spacing_z * np.array(plane.normal), atol=1e-6)
    end_wheel_burst(axial, qtbot)
    undo.undo()
    np.testing.assert_allclose(network.get("axial.cursor"), expected, atol=1e-6)
    undo.undo()
    assert network.get("axial.cursor") is None and network.get("coronal.cursor") is None


def test_paging_stops_at_the_last_slice(mpr, qtbot):
    network = mpr.workspace.network
    sagittal = mpr.canvases.views["sagittal_canvas"]
    plane = mpr.evaluation.view_cameras["sagittal.slice_plane"]
    image = nifti()
    spacing_x, dims_x = float(image.header.get_zooms()[0]), image.shape[0]
    wheel(sagittal, 1000, Qt.ShiftModifier)
    cursor = np.array(network.get("sagittal.cursor"))
    # sagittal: normal -x, so forward goes to the first voxel centre along x
    np.testing.assert_allclose(cursor[0], plane.box_low[0] + spacing_x / 2, atol=1e-6)
    wheel(sagittal, -3)                                     # and back from the end at once
    np.testing.assert_allclose(network.get("sagittal.cursor")[0], cursor[0] + 3 * spacing_x, atol=1e-6)
    np.testing.assert_allclose(plane.box_size[0], dims_x * spacing_x, rtol=1e-6)


def test_a_right_drag_sets_window_and_level(mpr, qtbot, monkeypatch):
    network, undo = mpr.workspace.network, mpr.workspace.undo_stack
    axial = mpr.canvases.views["axial_canvas"]
    data = np.asarray(nifti().dataobj)
    span = float(data.max() - data.min())                   # VolumeSource window "full"
    # The network's windows come from the data (the source's robust window); a fixed window and the
    # full range make the drag's numbers easy to follow.
    mpr.workspace.set_property("source.window", "full")
    mpr.workspace.set_property("axial.window", (220.0, 440.0))
    settle(mpr, qtbot)
    assert network.get("coronal.window") == (220.0, 440.0)  # linked
    before, depth = frame(mpr, "axial_canvas"), undo.count()
    height = axial.image_rect().height()

    right_drag(axial, (30, -20))                            # right: wider; up: higher centre
    centre, width = network.get("axial.window")
    assert width > 440.0 and centre > 220.0
    np.testing.assert_allclose(width, 440.0 + 30 * span / height, rtol=1e-4)
    np.testing.assert_allclose(centre, 220.0 + 20 * span / height, rtol=1e-4)
    assert network.get("coronal.window") == network.get("axial.window")   # linked
    assert undo.count() == depth + 1
    settle(mpr, qtbot)
    assert not np.array_equal(frame(mpr, "axial_canvas"), before)

    right_drag(axial, (-10, 15))                            # left: narrower; down: lower
    assert network.get("axial.window")[1] < width and network.get("axial.window")[0] < centre
    undo.undo()
    undo.undo()
    assert network.get("axial.window") == (220.0, 440.0)

    menus = []                                              # a right click still opens the menu
    monkeypatch.setattr(axial, "context_menu", lambda: type("Menu", (), {"exec": menus.append})())
    right_drag(axial, (0, 0), steps=1)
    assert len(menus) == 1 and network.get("axial.window") == (220.0, 440.0)


def test_window_drag_needs_the_window_mapping(mpr, qtbot):
    network = mpr.workspace.network
    mpr.workspace.set_property("sagittal.mapping", "tf")
    settle(mpr, qtbot)
    sagittal = mpr.canvases.views["sagittal_canvas"]
    right_drag(sagittal, (40, -40))
    assert network.get("sagittal.window") is None  # still the automatic window
    assert sagittal.message() == slice_gestures.NOT_WINDOW


def test_page_step_is_one_voxel_along_the_normal():
    assert slice_gestures.page_step((0.0, 0.0, 1.0), (1.0, 0.9, 0.8)) == pytest.approx(0.8)
    assert slice_gestures.page_step((1.0, 0.0, 0.0), (1.0, 0.9, 0.8)) == pytest.approx(1.0)
    # oblique: the step whose displacement, counted in voxels, is one voxel long
    normal = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    for spacing in ((2.0, 2.0, 2.0), (1.0, 2.0, 3.0)):
        step = slice_gestures.page_step(normal, spacing)
        assert np.linalg.norm(step * normal / np.array(spacing)) == pytest.approx(1.0)
    assert slice_gestures.page_step(normal, (2.0, 2.0, 2.0)) == pytest.approx(2.0)


def test_an_auto_window_drags_from_the_whole_value_range(mpr, qtbot):
    network = mpr.workspace.network
    assert network.get("axial.window") is None            # auto: the volume's value range,
    mpr.workspace.set_property("source.window", "full")   # here the data's min .. max
    settle(mpr, qtbot)
    axial = mpr.canvases.views["axial_canvas"]
    data = np.asarray(nifti().dataobj)
    low, span = float(data.min()), float(data.max() - data.min())
    height = axial.image_rect().height()
    right_drag(axial, (-12, 8))
    centre, width = network.get("axial.window")
    np.testing.assert_allclose(width, span - 12 * span / height, rtol=1e-4)
    np.testing.assert_allclose(centre, low + span / 2 - 8 * span / height, rtol=1e-4)


# --- the crosshair and readouts drawn on screen (slice_overlay.py) ------------------------------

class _Network:
    """What the overlay reads of a network: the viewers' ids and properties."""
    def __init__(self, properties):
        self.properties = properties
        self.processors = {key.split(".")[0]: None for key in properties}

    def get(self, address):
        return self.properties.get(address)


def _planes(cursor, size=(64, 64)):
    from vgraph.slicing import slice_plane
    return {f"{name}.slice_plane": slice_plane(name, None, cursor, 1.0, (0.0, 0.0, 0.0), (1.0, 1.0, 2.0),
                                               (64, 64, 32), size)
            for name in ("axial", "coronal", "sagittal")}


def _painted(viewer, cameras, side=256):
    """The overlay of ``viewer`` painted over black at side x side screen pixels: (H, W, 3)."""
    from PySide6.QtCore import QRectF
    from PySide6.QtGui import QImage, QPainter
    from vgraph.gui.slice_overlay import draw_slice_overlay
    network = _Network({f"{n}.{key}": value for n in ("axial", "coronal", "sagittal")
                        for key, value in (("orientation", n), ("cursor", CURSOR), ("mapping", "window"),
                                           ("window", (100.0, 50.0)))})
    image = QImage(side, side, QImage.Format_RGBA8888)
    image.fill(0xFF000000)
    painter = QPainter(image)
    draw_slice_overlay(painter, viewer, network, cameras, QRectF(0, 0, side, side))
    painter.end()
    return np.frombuffer(image.constBits(), np.uint8).reshape(side, side, 4)[..., :3].astype(int)


CURSOR = (20.0, 30.0, 40.0)
SLICER = {"axial": (243, 74, 51), "sagittal": (237, 213, 76), "coronal": (110, 176, 75)}


def _line_pixels(pixels, colour, tolerance=40):
    return np.abs(pixels - np.array(colour)).max(axis=-1) <= tolerance


@pytest.mark.parametrize("viewer, across, along", [("axial", "coronal", "sagittal"),
                                                   ("coronal", "axial", "sagittal"),
                                                   ("sagittal", "axial", "coronal")])
def test_the_crosshair_lines_take_the_colour_of_the_plane_they_mark(qapp, viewer, across, along):
    """In each view the other two planes cross at the cursor, 2 screen pixels wide at 4x the
    frame's resolution, in Slicer's colours: ``across`` is the horizontal line, ``along`` the
    vertical one."""
    side = 256
    cameras = _planes(CURSOR)
    pixels = _painted(viewer, cameras, side)
    u, v = cameras[f"{viewer}.slice_plane"].uv_of(CURSOR)
    column, row = u * side, (1.0 - v) * side
    horizontal, vertical = _line_pixels(pixels, SLICER[across]), _line_pixels(pixels, SLICER[along])
    # along a column away from the crossing the horizontal line is >= 2 px thick, at the cursor's row
    x = int(column + 40) % side
    rows = np.nonzero(horizontal[:, x])[0]
    assert len(rows) >= 2 and abs(rows.mean() - row) <= 1.0, (viewer, rows, row)
    y = int(row + 40) % side
    columns = np.nonzero(vertical[y, :])[0]
    assert len(columns) >= 2 and abs(columns.mean() - column) <= 1.0, (viewer, columns, column)
    # the view's own colour marks no line inside the image (only its outline at the box's edge)
    own = _line_pixels(pixels, SLICER[viewer])
    assert not own[int(row) + 10: int(row) + 20, int(column) + 10: int(column) + 20].any()


def test_the_intersection_of_two_planes_in_image_coordinates():
    from vgraph.gui.slice_overlay import clipped_to_image, intersection_uv
    cameras = _planes(CURSOR)
    axial, coronal = cameras["axial.slice_plane"], cameras["coronal.slice_plane"]
    point, direction = intersection_uv(axial, coronal)
    np.testing.assert_allclose(axial.world_at(*point)[1], CURSOR[1], atol=1e-9)  # on y = cursor's y
    assert abs(direction[1]) < 1e-12                                               # horizontal
    start, end = clipped_to_image(point, direction)
    np.testing.assert_allclose(sorted([start[0], end[0]]), [0.0, 1.0])
    assert intersection_uv(axial, axial) is None                                   # parallel
    assert clipped_to_image(np.array([0.5, 1.5]), np.array([1.0, 0.0])) is None    # misses the image


def test_the_readouts_give_the_slice_position_and_the_window():
    from vgraph.gui.slice_overlay import readouts
    from vgraph.live.slice_clicks import SliceVolume
    cameras = _planes(CURSOR)
    cameras["axial.slice_volume"] = SliceVolume((1.0, 1.0, 2.0), (0.0, 1000.0))
    network = _Network({"axial.orientation": "axial", "axial.cursor": CURSOR,
                        "axial.mapping": "window", "axial.window": (100.0, 50.0)})
    # z = 40 world units with 2 per voxel: index 20, the 21st of 32 slices
    assert readouts("axial", network, cameras) == ["Axial  S 40.0  slice 21/32", "W 50  L 100"]
    network.properties["axial.window"] = None  # auto: the whole value range
    assert readouts("axial", network, cameras)[1] == "W 1000  L 500"
    network.properties["axial.slab_thickness"] = 10.0
    assert readouts("axial", network, cameras)[0] == "Axial  S 40.0  slice 21/32  MIP slab 10"
    # RAS letters: +x is the patient's right, +y anterior; the number is the distance from 0
    from vgraph.gui.slice_overlay import position_text
    assert position_text("sagittal", cameras["sagittal.slice_plane"], (-7.0, 30.0, 40.0)).startswith("Sagittal  L 7.0")
    assert position_text("sagittal", cameras["sagittal.slice_plane"], (7.0, 30.0, 40.0)).startswith("Sagittal  R 7.0")
    assert position_text("coronal", cameras["coronal.slice_plane"], (7.0, -3.0, 40.0)).startswith("Coronal  P 3.0")


def test_the_mpr_views_draw_the_crosshair_on_screen_not_into_the_frame(mpr, qtbot):
    """The shipped MPR network draws no crosshair into its images; the views draw the other
    planes' lines over them at screen resolution, and the Slices toggle hides them."""
    axial = mpr.canvases.views["axial_canvas"]
    axial.resize(300, 300)
    qtbot.waitUntil(lambda: axial.width() == 300)
    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    u, v = plane.uv_of(plane.centre)  # the cursor is automatic: the volume's centre
    rect = axial.image_rect()
    shown = axial.grab().toImage().convertToFormat(axial.grab().toImage().Format.Format_RGBA8888)
    pixels = np.frombuffer(shown.constBits(), np.uint8).reshape(shown.height(), shown.width(), 4)
    ratio = shown.width() / axial.width()
    x = int((rect.left() + 0.1 * rect.width()) * ratio)
    row = (rect.top() + (1.0 - v) * rect.height()) * ratio
    green = np.nonzero(_line_pixels(pixels[..., :3].astype(int), SLICER["coronal"])[:, x])[0]
    assert len(green) >= 2 and abs(green.mean() - row) <= 1.5 * ratio, (green, row)
    frame_pixels = frame(mpr, "axial_canvas")[..., :3].astype(int)
    assert not _line_pixels(frame_pixels, SLICER["coronal"], 20).any()  # not in the image
    axial.set_slices_visible(False)
    hidden = axial.grab().toImage().convertToFormat(shown.format())
    bare = np.frombuffer(hidden.constBits(), np.uint8).reshape(hidden.height(), hidden.width(), 4)
    assert not _line_pixels(bare[..., :3].astype(int), SLICER["coronal"])[:, x].any()


def left_drag(view, start, end, steps=4, modifiers=Qt.NoModifier, button=Qt.LeftButton):
    send_mouse(view, QEvent.MouseButtonPress, start, button, button, modifiers)
    for i in range(1, steps + 1):
        pos = (start[0] + (end[0] - start[0]) * i / steps, start[1] + (end[1] - start[1]) * i / steps)
        send_mouse(view, QEvent.MouseMove, pos, Qt.NoButton, button, modifiers)
    send_mouse(view, QEvent.MouseButtonRelease, end, button, Qt.NoButton, modifiers)


def test_a_left_drag_in_a_slice_moves_the_cursor_and_the_other_slices_follow(mpr, qtbot):
    network, undo = mpr.workspace.network, mpr.workspace.undo_stack
    axial = mpr.canvases.views["axial_canvas"]
    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    depth = undo.count()
    start, end = widget_point(axial, 0.3, 0.7), widget_point(axial, 0.6, 0.4)
    left_drag(axial, (start.x(), start.y()), (end.x(), end.y()))
    assert axial.message() == ""  # no "no camera upstream of this canvas"
    rect = axial.image_rect()
    u, v = (end.x() - rect.left()) / rect.width(), 1.0 - (end.y() - rect.top()) / rect.height()
    np.testing.assert_allclose(network.get("axial.cursor"), plane.world_at(u, v), atol=1e-9)
    assert network.get("coronal.cursor") == network.get("sagittal.cursor") == network.get("axial.cursor")
    assert undo.count() == depth + 1  # the whole drag is one step
    settle(mpr, qtbot)
    for viewer in ("coronal", "sagittal"):
        moved = mpr.evaluation.view_cameras[f"{viewer}.slice_plane"]
        np.testing.assert_allclose(np.dot(np.array(network.get("axial.cursor")) - moved.centre,
                                          moved.normal), 0.0, atol=1e-6)
    # dragged beyond the image the cursor stays on its edge
    far = (rect.right() + 50, rect.center().y())
    left_drag(axial, (end.x(), end.y()), far)
    np.testing.assert_allclose(mpr.evaluation.view_cameras["axial.slice_plane"].uv_of(
        network.get("axial.cursor"))[0], 1.0, atol=1e-9)


def test_ctrl_wheel_zooms_and_a_middle_drag_pans_all_slice_views_together(mpr, qtbot):
    network, undo = mpr.workspace.network, mpr.workspace.undo_stack
    axial = mpr.canvases.views["axial_canvas"]
    depth = undo.count()
    wheel(axial, 2, Qt.ControlModifier)
    wheel(axial, 1, Qt.ControlModifier)
    end_wheel_burst(axial, qtbot)
    np.testing.assert_allclose(network.get("axial.zoom"), 1.1 ** 3)
    assert network.get("coronal.zoom") == network.get("sagittal.zoom") == network.get("axial.zoom")
    assert network.get("axial.cursor") is None  # Ctrl + wheel zooms, it does not page
    assert undo.count() == depth + 1
    settle(mpr, qtbot)

    plane = mpr.evaluation.view_cameras["axial.slice_plane"]
    rect = axial.image_rect()
    start = (rect.center().x(), rect.center().y())
    left_drag(axial, start, (start[0] + 20, start[1] - 10), button=Qt.MiddleButton)
    # the image follows the mouse: its centre moves 20 px left and 10 px down in the world
    expected = (-20 / rect.width() * np.array(plane.right) - 10 / rect.height() * np.array(plane.up))
    np.testing.assert_allclose(network.get("axial.pan"), expected, atol=1e-9)
    assert network.get("coronal.pan") == network.get("sagittal.pan") == network.get("axial.pan")
    assert network.get("axial.cursor") is None  # panning moves no cursor
    settle(mpr, qtbot)
    moved = mpr.evaluation.view_cameras["axial.slice_plane"]
    np.testing.assert_allclose(np.subtract(moved.centre, plane.centre), expected, atol=1e-6)
    # the coronal view (right -x, up +z) pans by the same world vector's x part
    coronal = mpr.evaluation.view_cameras["coronal.slice_plane"]
    assert abs(expected[0]) > 1.0
    np.testing.assert_allclose(coronal.centre[0], moved.centre[0], atol=1e-6)
    # Shift + left drag pans too; one undo step each
    depth = undo.count()
    left_drag(axial, start, (start[0] - 15, start[1]), modifiers=Qt.ShiftModifier)
    assert undo.count() == depth + 1 and network.get("axial.cursor") is None
    undo.undo()
    np.testing.assert_allclose(network.get("axial.pan"), expected, atol=1e-9)


def test_the_lines_go_through_the_cursor_the_network_holds_before_the_frames_arrive(qapp):
    """During a drag the other planes' reported frames lag; the lines follow the network's cursor."""
    from vgraph.gui.slice_overlay import intersection_uv
    cameras = _planes(CURSOR)
    axial, coronal = cameras["axial.slice_plane"], cameras["coronal.slice_plane"]
    moved = (CURSOR[0], CURSOR[1] + 6.0, CURSOR[2])
    point, _ = intersection_uv(axial, coronal, moved)
    np.testing.assert_allclose(axial.world_at(*point)[1], moved[1], atol=1e-9)
