"""The canvas toolbar and File > Export Image (issue #17 item 4): named views turn the camera as
named, fit frames the data box, the saved/exported PNG is the canvas frame pixel for pixel (and
`vgraph run`'s, overlays or not), the dialog starts in the network's folder with a suggested name,
and the overlays (box, axes triad) land where the camera projects the box corners and axes."""

import math
import shutil

import numpy as np
import PIL.Image
import pytest
from PySide6.QtCore import QPointF, QRectF, QSettings, Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QDockWidget

from vgraph.camera import Camera
from vgraph.gui import canvas_view, overlays
from vgraph.gui.canvas_toolbar import STILL_REFINING, CanvasPane
from vgraph.gui.canvas_view import CanvasView
from vgraph.gui.image_export import suggested_image_path
from vgraph.gui.overlays import ViewGeometry
from helpers.gui import raycast_workspace

from helpers.widget_pixels import grab_rgba, near_colour, rgb, widget_points
from helpers.paths import REPO

BOX = ((0.0, 0.0, 0.0), (200.0, 200.0, 100.0))
# (viewing direction = focus - position, up) of each named view, as docs/explanations/conventions.md and
# docs/explanations/ray-casting.md define them: x right, y to the front, z up; "top" looks down -z with +y up.
EXPECTED_VIEWS = {
    "front": ((0, -1, 0), (0, 0, 1)), "back": ((0, 1, 0), (0, 0, 1)),
    "left": ((1, 0, 0), (0, 0, 1)), "right": ((-1, 0, 0), (0, 0, 1)),
    "top": ((0, 0, -1), (0, 1, 0)), "bottom": ((0, 0, 1), (0, 1, 0)),
    # iso: from (1, 1, 1) towards the data, z up as far as the direction allows
    "iso": ((-1 / math.sqrt(3),) * 3, (-1 / math.sqrt(6), -1 / math.sqrt(6), 2 / math.sqrt(6))),
}


@pytest.fixture
def settings(tmp_path):
    return QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)


@pytest.fixture
def ws(qtbot, settings):
    return raycast_workspace(settings)


def make_pane(qtbot, ws, settings, canvas_id="canvas", size=(240, 200)) -> CanvasPane:
    pane = CanvasPane(CanvasView(ws, canvas_id), settings)
    qtbot.addWidget(pane)
    pane.resize(*size)
    pane.show()
    qtbot.waitExposed(pane)
    return pane


# --- camera actions -------------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(EXPECTED_VIEWS))
def test_each_named_view_turns_the_camera_as_named_in_one_undo_step(ws, qtbot, settings, name):
    pane = make_pane(qtbot, ws, settings)
    count = ws.undo_stack.count()
    pane.toolbar.view_actions[name].trigger()
    camera = ws.network.get("rc.camera")
    assert camera.fit_to_data and camera.near is None and camera.far is None
    assert ws.network.get("eep.camera") == camera          # the linked camera follows
    assert ws.undo_stack.count() == count + 1
    framed = camera.resolved(*BOX, 1.0)
    right, up, forward = framed.basis()
    direction, expected_up = EXPECTED_VIEWS[name]
    np.testing.assert_allclose(forward, direction, atol=1e-12)
    np.testing.assert_allclose(up, expected_up, atol=1e-12)
    np.testing.assert_allclose(framed.focus, np.mean(BOX, axis=0), atol=1e-9)  # looks at the data


def test_fit_frames_the_data_box_after_zooming_and_panning(ws, qtbot, settings):
    pane = make_pane(qtbot, ws, settings)
    stored = Camera(position=(900.0, 50.0, 40.0), focus=(300.0, 10.0, 0.0), up=(0, 0, 1), near=1.0, far=2000.0)
    ws.set_property("rc.camera", stored)
    pane.toolbar.fit_action.trigger()
    camera = ws.network.get("rc.camera")
    assert camera.fit_to_data and camera.near is None and camera.far is None
    for aspect in (1.0, 2.0, 0.5):
        framed = camera.resolved(*BOX, aspect)
        np.testing.assert_allclose(framed.basis()[2], stored.basis()[2], atol=1e-12)  # direction kept
        centre, radius = np.mean(BOX, axis=0), np.linalg.norm(np.subtract(BOX[1], BOX[0])) / 2
        np.testing.assert_allclose(framed.focus, centre, atol=1e-9)
        # The box's bounding sphere touches the narrower side of the view: every corner is
        # inside, and the sphere's angular radius is the narrower half field of view.
        clip = np.c_[ViewGeometry(framed, *BOX).corners(), np.ones(8)] @ framed.view_projection(aspect).T
        ndc = clip[:, :3] / clip[:, 3:]
        assert np.all(np.abs(ndc) <= 1.0)
        half = math.radians(framed.fov) / 2
        narrow = min(half, math.atan(aspect * math.tan(half)))
        assert math.asin(radius / framed.distance) == pytest.approx(narrow)


def test_keys_work_once_the_canvas_has_the_focus(ws, qtbot, settings):
    pane = make_pane(qtbot, ws, settings)
    pane.activateWindow()
    pane.view.setFocus()
    qtbot.waitUntil(pane.view.hasFocus)
    QTest.keyClick(pane.view, Qt.Key_7)
    qtbot.waitUntil(lambda: np.allclose(ws.network.get("rc.camera").resolved(*BOX).basis()[2], (0, 0, -1)))
    QTest.keyClick(pane.view, Qt.Key_1, Qt.ControlModifier)
    qtbot.waitUntil(lambda: np.allclose(ws.network.get("rc.camera").resolved(*BOX).basis()[2], (0, 1, 0)))
    QTest.keyClick(pane.view, Qt.Key_B)
    assert pane.view.overlays()["box"] and pane.toolbar.box_action.isChecked()
    tips = {action.toolTip() for action in pane.toolbar.keyboard_actions()}
    assert any(tip.endswith("(7)") and "top" in tip for tip in tips)   # tooltips name the keys


# --- saving ---------------------------------------------------------------------------------------


def test_suggested_image_path_is_in_the_networks_folder_and_never_overwrites(tmp_path, monkeypatch):
    folder = tmp_path / "nets"
    folder.mkdir()
    network = folder / "head.json"
    assert suggested_image_path(network, "canvas") == folder / "head_canvas.png"
    (folder / "head_canvas.png").write_bytes(b"")
    assert suggested_image_path(network, "canvas") == folder / "head_canvas_2.png"
    (folder / "head_canvas_2.png").write_bytes(b"")
    assert suggested_image_path(network, "canvas") == folder / "head_canvas_3.png"
    assert suggested_image_path(network, "left") == folder / "head_left.png"
    monkeypatch.chdir(tmp_path)
    assert suggested_image_path(None, "canvas") == tmp_path / "canvas.png"   # untitled: here


def test_the_save_dialog_is_given_the_suggestion(ws, qtbot, settings, tmp_path, monkeypatch):
    ws.save_as(tmp_path / "mine.json")
    pane = make_pane(qtbot, ws, settings)   # kept: the view dies with its pane
    view = pane.view
    asked = []
    monkeypatch.setattr(canvas_view.QFileDialog, "getSaveFileName",
                        lambda parent, title, start, filters: (asked.append(start), ("", ""))[1])
    assert view.save_image() is None and asked == []        # no frame: nothing to ask about
    view.show_frame(np.zeros((4, 4, 4), np.uint8))
    assert view.save_image() is None                         # the dialog was cancelled
    assert asked == [str(tmp_path / "mine_canvas.png")]


def test_toolbar_save_writes_the_frame_not_the_overlays(ws, qtbot, settings, tmp_path, monkeypatch):
    pane = make_pane(qtbot, ws, settings)
    view = pane.view
    frame = np.random.default_rng(3).integers(0, 256, size=(30, 50, 4), dtype=np.uint8)
    camera = Camera.looking_at_box(*BOX, direction=(-1, -1, -1), up=(0, 0, 1), aspect=50 / 30)
    view.set_view_geometry(ViewGeometry(camera, *BOX))
    view.show_frame(frame)
    pane.toolbar.box_action.setChecked(True)
    pane.toolbar.axes_action.setChecked(True)
    monkeypatch.setattr(view, "ask_save_path", lambda: str(tmp_path / "shot"))
    pane.toolbar.save_action.trigger()
    with PIL.Image.open(tmp_path / "shot.png") as image:
        assert image.mode == "RGBA" and np.array_equal(np.asarray(image), frame)


def test_a_coarse_frame_is_not_saved_from_the_toolbar(ws, qtbot, settings, tmp_path, monkeypatch):
    """A frame still refining is not what `vgraph run` writes: the user is told to wait."""
    pane = make_pane(qtbot, ws, settings)
    view, problems = pane.view, []
    view.problem.connect(problems.append)
    monkeypatch.setattr(view, "ask_save_path", lambda: str(tmp_path / "shot.png"))
    view.show_frame(np.zeros((8, 8, 4), np.uint8), final=False)
    pane.toolbar.save_action.trigger()
    assert not (tmp_path / "shot.png").exists()
    assert problems == [STILL_REFINING] and view.message() == STILL_REFINING
    view.show_frame(np.full((8, 8, 4), 9, np.uint8), final=True)
    pane.toolbar.save_action.trigger()
    with PIL.Image.open(tmp_path / "shot.png") as image:
        assert np.array_equal(np.asarray(image), np.full((8, 8, 4), 9, np.uint8))


# --- overlays -------------------------------------------------------------------------------------


def test_box_overlay_lines_run_through_the_projected_corners(ws, qtbot, settings):
    pane = make_pane(qtbot, ws, settings, size=(320, 280))
    view = pane.view
    frame_size = (160, 120)
    frame = np.zeros((frame_size[1], frame_size[0], 4), np.uint8)
    frame[..., :3], frame[..., 3] = 40, 255
    camera = Camera.looking_at_box(*BOX, direction=(-0.6, 0.8, -0.5), up=(0, 0, 1),
                                   aspect=frame_size[0] / frame_size[1])
    view.set_view_geometry(ViewGeometry(camera, *BOX))
    view.show_frame(frame)
    pane.toolbar.axes_action.setChecked(False)
    pane.toolbar.box_action.setChecked(False)
    plain = grab_rgba(view)
    rect = view.image_rect()
    inside = plain[int(rect.center().y()), int(rect.center().x()), :3]
    assert tuple(inside) == (40, 40, 40)                         # only the frame, scaled

    pane.toolbar.box_action.setChecked(True)
    boxed = grab_rgba(view)
    corners = ViewGeometry(camera, *BOX).corners()
    points = widget_points(camera, corners, frame_size, rect)
    assert all(rect.contains(QPointF(*p)) for p in points)    # the framing shows every corner
    colour = rgb(overlays.BOX_COLOUR)
    for point in points:
        assert near_colour(boxed, point, colour), point
    for a, b in overlays.BOX_EDGES:                              # and the middle of every edge
        middle = widget_points(camera, [(corners[a] + corners[b]) / 2], frame_size, rect)[0]
        assert near_colour(boxed, middle, colour), (a, b)
    changed = np.abs(boxed.astype(int) - plain).max(axis=-1) > 0
    far = [(x, y) for x, y in zip(*np.nonzero(changed)[::-1])]
    segments = [(points[a], points[b]) for a, b in overlays.BOX_EDGES]
    # every changed pixel lies on some edge (within the pen's half width and antialiasing)
    for x, y in far[:: max(1, len(far) // 300)]:
        assert min(_distance_to_segment((x + 0.5, y + 0.5), p, q) for p, q in segments) < 2.5


def _distance_to_segment(point, a, b) -> float:
    point, a, b = (np.asarray(v, float) for v in (point, a, b))
    t = np.clip((point - a) @ (b - a) / max((b - a) @ (b - a), 1e-12), 0.0, 1.0)
    return float(np.linalg.norm(point - (a + t * (b - a))))


def test_the_box_is_clipped_at_the_near_plane_when_the_camera_is_inside(ws, qtbot, settings):
    pane = make_pane(qtbot, ws, settings)
    view = pane.view
    inside = Camera(position=(100.0, 100.0, 50.0), focus=(100.0, 300.0, 50.0), up=(0, 0, 1), near=1.0, far=500.0)
    geometry = ViewGeometry(inside, *BOX)
    view.set_view_geometry(geometry)
    view.show_frame(np.zeros((50, 50, 4), np.uint8))
    lines = overlays.box_lines(geometry, view.image_rect())
    # Only the edges of the far face (y = 200) and the 4 edges along y (from the near plane) remain.
    assert len(lines) == 8
    assert all(math.isfinite(v) for line in lines for v in (line.x1(), line.y1(), line.x2(), line.y2()))
    view.set_box_visible(True)
    view.grab()   # paints without error


def test_axes_triad_points_along_the_projected_world_axes(ws, qtbot, settings):
    pane = make_pane(qtbot, ws, settings, size=(320, 280))
    view = pane.view
    frame = np.zeros((120, 160, 4), np.uint8)
    frame[..., 3] = 255
    # Seen from the front (from +y, z up): world x points left on the screen, z up, y at the viewer.
    camera = Camera().viewed_from("front").resolved(*BOX, 160 / 120)
    view.set_view_geometry(ViewGeometry(camera, *BOX))
    view.show_frame(frame)
    pane.toolbar.box_action.setChecked(False)
    pane.toolbar.axes_action.setChecked(True)
    pixels = grab_rgba(view)
    rect = view.image_rect()
    origin, length = overlays.triad_origin(rect), overlays.triad_length(rect)
    assert rect.contains(origin) and rect.contains(origin + QPointF(length, length))
    x_tip = (origin.x() - 0.7 * length, origin.y())
    z_tip = (origin.x(), origin.y() - 0.7 * length)
    assert near_colour(pixels, x_tip, rgb(overlays.AXIS_COLOURS["x"]))
    assert near_colour(pixels, z_tip, rgb(overlays.AXIS_COLOURS["z"]))
    assert not near_colour(pixels, (origin.x() + 0.7 * length, origin.y()), rgb(overlays.AXIS_COLOURS["x"]))
    # Turned to the top (looking down -z, y up): x right, y up.
    view.set_view_geometry(ViewGeometry(Camera().viewed_from("top").resolved(*BOX, 160 / 120), *BOX))
    pixels = grab_rgba(view)
    assert near_colour(pixels, (origin.x() + 0.7 * length, origin.y()), rgb(overlays.AXIS_COLOURS["x"]))
    assert near_colour(pixels, (origin.x(), origin.y() - 0.7 * length), rgb(overlays.AXIS_COLOURS["y"]))


def test_overlay_switches_are_remembered_per_canvas(ws, qtbot, settings):
    first = make_pane(qtbot, ws, settings)
    assert first.view.overlays() == {"axes": True, "box": False}   # the defaults
    first.toolbar.axes_action.setChecked(False)
    first.toolbar.box_action.setChecked(True)
    again = make_pane(qtbot, ws, settings)
    assert again.view.overlays() == {"axes": False, "box": True}
    assert again.toolbar.box_action.isChecked() and not again.toolbar.axes_action.isChecked()
    other = make_pane(qtbot, ws, settings, canvas_id="other")
    assert other.view.overlays() == {"axes": True, "box": False}


# --- in the main window, with the render process ----------------------------------------------------


def test_window_canvas_toolbar_overlays_and_export_image(window, qtbot, tmp_path, monkeypatch):
    """The sphere network copied to tmp: the dock shows the toolbar above the view; the frame
    comes with the camera and box the render process used; the box overlay runs through their
    projected corners; File > Export Image writes the frame, which is `vgraph run`'s, in the
    network's folder; the top view re-renders looking down -z."""
    import vgraph
    from vgraph.imagefile import to_uint8

    path = tmp_path / "sphere.json"
    shutil.copy(REPO / "networks" / "raycast_sphere.json", path)
    assert window.open_network(path)
    window.evaluation.run(wait=True)
    dock = window.canvases.docks["canvas"]
    pane = dock.widget()
    assert isinstance(pane, CanvasPane) and pane.view is window.canvases.views["canvas"]
    view = pane.view
    qtbot.waitUntil(lambda: view.frame() is not None and view.is_final, timeout=60000)
    geometry = view.view_geometry()
    assert geometry is not None and geometry.camera == window.evaluation.view_cameras["rc.camera"]
    # the FunctionSelector's voxel centres span the implicit functions' box [-1, 1]^3
    np.testing.assert_allclose(geometry.box_min, [-1.0] * 3, atol=1e-9)
    np.testing.assert_allclose(geometry.box_max, [1.0] * 3, atol=1e-9)

    pane.toolbar.box_action.setChecked(True)
    pane.toolbar.axes_action.setChecked(True)
    pixels, rect = grab_rgba(view), view.image_rect()
    height, width = view.frame().shape[:2]
    for point in widget_points(geometry.camera, geometry.corners(), (width, height), rect):
        assert near_colour(pixels, point, rgb(overlays.BOX_COLOUR)), point

    expected = to_uint8(vgraph.load(path).evaluate("canvas"))
    assert np.array_equal(view.frame(), expected)
    assert view.suggested_path() == str(tmp_path / "sphere_canvas.png")
    monkeypatch.setattr(view, "ask_save_path", view.suggested_path)   # the user accepts the suggestion
    window.export_image_action.trigger()
    with PIL.Image.open(tmp_path / "sphere_canvas.png") as image:
        assert np.array_equal(np.asarray(image), expected)           # no overlays in the file
    assert "Export Image..." in [a.text().replace("&", "") for a in window.menuBar().actions()[0].menu().actions()]

    with qtbot.waitSignal(window.evaluation.frames, timeout=60000, check_params_cb=lambda f, final: final):
        pane.toolbar.view_actions["top"].trigger()
    qtbot.waitUntil(lambda: window.evaluation.idle() and view.is_final, timeout=60000)
    shown = view.view_geometry().camera
    np.testing.assert_allclose(shown.basis()[2], (0, 0, -1), atol=1e-12)
    np.testing.assert_allclose(shown.basis()[1], (0, 1, 0), atol=1e-12)
    np.testing.assert_allclose(shown.focus, (0, 0, 0), atol=1e-9)


def test_export_image_without_a_canvas_says_so(window):
    assert window.export_image() is None
    assert "no canvas" in window.statusBar().currentMessage()
    assert not [d for d in window.findChildren(QDockWidget) if d.objectName().startswith("canvas:")]


def test_reported_camera_and_box_project_onto_the_rendered_box(gl):
    """What the render process reports for the overlays is what it drew: with a transfer function
    opaque everywhere the RayCaster draws the whole box, whose silhouette spans exactly the
    projected corners (to the pixel)."""
    import vgraph
    from vgraph.live.evaluator import view_cameras
    from vgraph.live.view_boxes import view_boxes
    from vgraph.imagefile import to_uint8

    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    network.set("canvas.size", (96, 64))
    network.set("rc.transfer_function", {"points": [[0, 1, 1, 1, 1], [1, 1, 1, 1, 1]]})
    network.set("rc.shading", "none")   # white everywhere (shaded faces turned away are dark)
    network.set("rc.camera", network.get("rc.camera").model_copy(
        update={"near": None, "far": None, "fit_to_data": True}))
    frame = to_uint8(network.evaluate("canvas"))
    camera, box = view_cameras(network)["rc.camera"], view_boxes(network)["rc.camera"]
    np.testing.assert_allclose(box, [(-1, -1, -1), (1, 1, 1)], atol=1e-9)
    rows, cols = np.nonzero(frame[..., 0] > 127)
    points = widget_points(camera, ViewGeometry(camera, *box).corners(), (96, 64), QRectF(0, 0, 96, 64))
    # pixel c covers [c, c + 1): the silhouette's pixels are those whose centres the hull covers
    assert cols.min() == math.ceil(points[:, 0].min() - 0.5) and cols.max() == math.floor(points[:, 0].max() - 0.5)
    assert rows.min() == math.ceil(points[:, 1].min() - 0.5) and rows.max() == math.floor(points[:, 1].max() - 0.5)


@pytest.mark.parametrize("size", [(1280, 800), (1920, 1080)])
def test_nothing_is_cut_off_at_common_screen_sizes(window, qtbot, data_dir, size):
    """The head network at 1280 x 800 and 1920 x 1080 (docs/guide/gui.md's screenshots): the canvas
    below the palette shows its frame, and the RayCaster's inspector shows the camera editor and
    the transfer-function editor whole, without a horizontal scroll bar."""
    from PySide6.QtWidgets import QScrollArea
    from vgraph.gui import layout
    from vgraph.gui.transfer_function_editor import TransferFunctionEditor

    window.arrange(*size)
    assert window.open_network(REPO / "networks" / "raycast_head.json")
    window.scene.select_processor("rc")
    window.evaluation.run(wait=True)
    qtbot.waitUntil(lambda: window.canvases.views["canvas"].frame() is not None, timeout=60000)
    qtbot.wait(50)
    dock = window.canvases.docks["canvas"]
    assert window.dockWidgetArea(dock) == window.dockWidgetArea(window.palette_dock) == Qt.LeftDockWidgetArea
    assert dock.y() > window.palette_dock.y()
    assert layout.shown_whole(window.canvases.views["canvas"])
    assert window.canvases.views["canvas"].image_rect().width() >= 250
    scroll = window.inspector.findChild(QScrollArea)
    assert not scroll.horizontalScrollBar().isVisible()
    [tf_editor] = window.inspector.findChildren(TransferFunctionEditor)
    assert layout.shown_whole(tf_editor) and layout.shown_whole(window.inspector.editors["camera"])


def test_reset_layout_puts_the_canvases_back_below_the_palette(window, qtbot):
    from vgraph.gui import layout

    window.workspace.add_processor("Canvas", id="canvas")
    window.workspace.add_processor("Canvas", id="second")
    first, second = window.canvases.docks["canvas"], window.canvases.docks["second"]
    assert window.dockWidgetArea(first) == Qt.LeftDockWidgetArea
    assert window.tabifiedDockWidgets(first) == [second]          # the second is tabbed with it
    window.addDockWidget(Qt.RightDockWidgetArea, first)
    second.setFloating(True)
    layout.reset_layout(window)
    qtbot.wait(50)
    for dock in (first, second):
        assert not dock.isFloating() and window.dockWidgetArea(dock) == Qt.LeftDockWidgetArea
    assert second in window.tabifiedDockWidgets(first)
    front = max((first, second), key=lambda dock: dock.y())   # the tab behind is moved out of sight
    assert front.y() > window.palette_dock.y() + window.palette_dock.height() - 8
    assert window.dockWidgetArea(window.properties_dock) == Qt.RightDockWidgetArea


def test_reset_layout_tabs_the_markups_tables_and_timeline_docks_with_the_log_again(window, qtbot):
    from vgraph.gui import layout

    markups, tables, timeline = window.markups_dock, window.table_dock, window.timeline_dock
    markups.show()
    markups.setFloating(True)
    window.addDockWidget(Qt.RightDockWidgetArea, tables)
    tables.show()
    layout.reset_layout(window)
    qtbot.wait(50)
    for dock in (markups, tables, timeline):
        assert not dock.isFloating() and not dock.isVisible()
        assert window.dockWidgetArea(dock) == Qt.BottomDockWidgetArea
        dock.show()                                    # View > Markups: it opens as a tab of the Log
        qtbot.wait(20)
        assert dock in window.tabifiedDockWidgets(window.log_dock)
        dock.hide()
