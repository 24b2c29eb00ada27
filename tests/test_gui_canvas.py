"""The canvas view: frames drawn to fit with their aspect kept, mouse gestures turned into camera
edits exactly as the Camera methods predict (one undo step per gesture), PNG export."""

import math

import numpy as np
import PIL.Image
import pytest
from PySide6.QtCore import QEvent, QPoint, QPointF, QSettings, Qt
from PySide6.QtGui import QImage, QWheelEvent
from PySide6.QtWidgets import QApplication

from vgraph.camera import Camera
from vgraph.gui import canvas_mouse, canvas_view
from vgraph.gui.canvas_view import CanvasView, camera_property_for
from vgraph.network import Network

from vgraph.gui.workspace import Workspace

from helpers.canvas import SIZE, drag, make_view
from helpers.gui import open_and_compare_with_run, send_mouse
from helpers.networks import bricked_sphere_network
from helpers.paths import REPO

@pytest.fixture
def ws(qtbot, tmp_path):
    """A workspace alone (the view needs nothing else), with its own settings file."""
    return Workspace(QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat))


STORED = Camera(position=(0.5, 0.4, 4.0), near=0.5, far=10.0)


def build_raycasting(ws):
    """EntryExitPoints -> RayCaster -> Canvas; adding the caster links its camera to eep's."""
    ws.add_processor("EntryExitPoints", (0, 0), id="eep")
    ws.add_processor("RayCaster", (0, 120), id="rc")
    ws.add_processor("Canvas", (0, 240), id="canvas")
    ws.connect("eep.entry", "rc.entry")
    ws.connect("eep.exit", "rc.exit")
    ws.connect("rc.image", "canvas.image")


def wheel(view, delta):
    point = QPointF(100, 80)
    event = QWheelEvent(point, view.mapToGlobal(point), QPoint(0, 0), QPoint(0, delta),
                        Qt.NoButton, Qt.NoModifier, Qt.NoScrollPhase, False)
    QApplication.sendEvent(view, event)


def grab_rgba(view) -> np.ndarray:
    image = view.grab().toImage().convertToFormat(QImage.Format_RGBA8888)
    array = np.frombuffer(image.constBits(), np.uint8).reshape(image.height(), image.bytesPerLine())
    return array[:, : 4 * image.width()].reshape(image.height(), image.width(), 4).copy()


def assert_camera(actual, expected):
    for field in ("position", "focus", "up"):
        np.testing.assert_allclose(getattr(actual, field), getattr(expected, field), atol=1e-9)
    assert actual.near == pytest.approx(expected.near) and actual.far == pytest.approx(expected.far)


def test_nearest_upstream_camera_is_found_breadth_first():
    net = Network()
    net.add("Canvas", id="canvas")
    assert camera_property_for(net, "canvas") is None
    assert camera_property_for(net, "missing") is None
    net.add("EntryExitPoints", id="eep")
    net.add("RayCaster", id="rc")
    net.add("Grayscale", id="gray")
    net.connect("eep.entry", "rc.entry")
    net.connect("rc.image", "gray.image")
    net.connect("gray.image", "canvas.image")
    assert camera_property_for(net, "canvas") == "rc.camera"   # nearer than eep's
    net.disconnect("rc.image", "gray.image")
    assert camera_property_for(net, "canvas") is None


def test_frame_is_scaled_to_fit_with_its_aspect_kept(ws, qtbot):
    view = make_view(qtbot, ws)
    frame = np.zeros((32, 64, 4), np.uint8)
    frame[..., 0] = np.linspace(0, 255, 64).round().astype(np.uint8)[None, :]   # red ramp
    frame[:16, :, 1] = 200                                                      # green top half
    frame[..., 3] = 255
    view.show_frame(frame, final=True)
    assert view.frame() is not None and np.array_equal(view.frame(), frame)
    pixels = grab_rgba(view)
    # 64x32 into 200x160: scale 200/64, drawn 200 x 100 at rows 30..130; rows above/below are bars.
    background = canvas_view.BACKGROUND
    bar = [background.red(), background.green(), background.blue()]
    assert (pixels[:29, :, :3] == bar).all() and (pixels[131:, :, :3] == bar).all()
    assert view.image_rect().getRect() == (0.0, 30.0, 200.0, 100.0)
    for row, col in ((40, 5), (60, 100), (120, 190), (100, 50)):
        source = frame[int((row - 30) * 32 / 100), int(col * 64 / 200)]
        np.testing.assert_allclose(pixels[row, col, :3], source[:3], atol=12)
    with pytest.raises(ValueError, match=r"uint8 \(H, W, 4\)"):
        view.show_frame(np.zeros((8, 8, 3), np.uint8), final=True)


def test_left_drag_rotates_the_linked_cameras_in_one_undo_step(ws, qtbot):
    build_raycasting(ws)
    view = make_view(qtbot, ws)
    original = ws.network.get("rc.camera")
    count = ws.undo_stack.count()
    states = []
    view.interacting.connect(states.append)

    drag(view, (50, 40), (90, 10))
    expected = original.rotate(math.pi * 40 / SIZE[1], -math.pi * -30 / SIZE[1])
    assert_camera(ws.network.get("rc.camera"), expected)
    assert ws.network.get("eep.camera") == ws.network.get("rc.camera")   # the link followed
    assert states == [True, False]
    assert ws.undo_stack.count() == count + 1

    drag(view, (50, 40), (40, 40))    # the next drag is its own step
    assert_camera(ws.network.get("rc.camera"), expected.rotate(math.pi * -10 / SIZE[1], 0.0))
    assert ws.undo_stack.count() == count + 2
    ws.undo_stack.undo()
    assert_camera(ws.network.get("rc.camera"), expected)
    ws.undo_stack.undo()
    assert ws.network.get("rc.camera") == original == ws.network.get("eep.camera")


def test_right_drag_and_wheel_zoom(ws, qtbot):
    build_raycasting(ws)
    view = make_view(qtbot, ws)
    original = ws.network.get("rc.camera")
    count = ws.undo_stack.count()

    drag(view, (100, 100), (100, 50), button=Qt.RightButton)   # up 50 px: zoom in
    expected = original.zoom(math.exp(canvas_mouse.ZOOM_PER_PIXEL * 50))
    assert_camera(ws.network.get("rc.camera"), expected)
    assert ws.network.get("rc.camera").distance < original.distance
    assert ws.undo_stack.count() == count + 1

    states = []
    view.interacting.connect(states.append)
    with qtbot.waitSignal(view.interacting, timeout=3000, check_params_cb=lambda on: not on):
        wheel(view, 120)
        wheel(view, 120)
        wheel(view, -120)
        wheel(view, 240)
    assert states == [True, False]
    zoomed = ws.network.get("rc.camera")
    assert zoomed.distance == pytest.approx(expected.distance / 1.1 ** 3, rel=1e-12)
    assert ws.undo_stack.count() == count + 2   # the whole burst is one step
    ws.undo_stack.undo()
    assert_camera(ws.network.get("rc.camera"), expected)


def test_middle_and_shift_left_drag_pan_with_the_scene_following_the_mouse(ws, qtbot):
    build_raycasting(ws)
    view = make_view(qtbot, ws)
    view.show_frame(np.full((50, 100, 4), 255, np.uint8), final=True)  # drawn 200 x 100
    ws.set_property("rc.camera", STORED)
    original = ws.network.get("rc.camera")

    drag(view, (100, 80), (130, 60), button=Qt.MiddleButton)
    expected = original.pan(30 / 100, 20 / 100)   # h = height of the drawn frame
    assert_camera(ws.network.get("rc.camera"), expected)
    # The focus point moved with the mouse: it now projects 30 px right / 20 px up of the centre.
    clip = expected.view_projection(2.0) @ np.array([*original.focus, 1.0])
    np.testing.assert_allclose(clip[:2] / clip[3] * [100, 50], [30, 20], atol=1e-9)

    drag(view, (100, 80), (90, 80), modifiers=Qt.ShiftModifier)
    assert_camera(ws.network.get("rc.camera"), expected.pan(-10 / 100, 0.0))


def test_a_camera_fitting_the_data_rotates_fitting_and_zooms_from_the_last_frame(ws, qtbot):
    build_raycasting(ws)
    fitting = ws.network.get("rc.camera")
    assert fitting.fit_to_data
    shown = fitting.resolved([0, 0, 0], [200, 200, 100], 2.0)  # what the render process framed
    view = CanvasView(ws, "canvas", view_cameras=lambda: {"rc.camera": shown, "eep.camera": shown})
    qtbot.addWidget(view)
    view.resize(*SIZE)
    view.show_frame(np.full((50, 100, 4), 255, np.uint8), final=True)
    drag(view, (100, 80), (130, 80))
    assert_camera(ws.network.get("rc.camera"), fitting.rotate(math.pi * 30 / 100, 0.0))
    assert ws.network.get("rc.camera").fit_to_data    # it keeps fitting whatever arrives
    drag(view, (100, 80), (100, 40), button=Qt.RightButton)
    zoomed = ws.network.get("rc.camera")
    assert not zoomed.fit_to_data and zoomed.near is None      # stored now, planes still automatic
    assert zoomed.distance == pytest.approx(shown.distance / math.exp(canvas_mouse.ZOOM_PER_PIXEL * 40))
    view.set_view("top")
    assert ws.network.get("rc.camera") == zoomed.viewed_from("top")
    view.fit_to_data()
    assert ws.network.get("rc.camera").fit_to_data


def test_a_canvas_without_camera_only_says_so(ws, qtbot):
    ws.add_processor("Canvas", (0, 0), id="canvas")
    view = make_view(qtbot, ws)
    states = []
    view.interacting.connect(states.append)
    count = ws.undo_stack.count()
    drag(view, (50, 50), (80, 80))
    wheel(view, 120)
    assert view.message() == canvas_mouse.NO_CAMERA
    assert states == [] and ws.undo_stack.count() == count


def test_a_refused_camera_edit_is_shown_not_raised(ws, qtbot):
    build_raycasting(ws)
    view = make_view(qtbot, ws)
    states = []
    view.interacting.connect(states.append)
    send_mouse(view, QEvent.MouseButtonPress, (50, 50), Qt.LeftButton, Qt.LeftButton)
    ws.remove(["rc"])   # the camera's processor disappears mid-drag (e.g. undone by a shortcut)
    count = ws.undo_stack.count()
    send_mouse(view, QEvent.MouseMove, (70, 50), Qt.NoButton, Qt.LeftButton)
    send_mouse(view, QEvent.MouseButtonRelease, (70, 50), Qt.LeftButton, Qt.NoButton)
    assert view.message().startswith("rc.camera: no processor with id 'rc'")
    assert ws.undo_stack.count() == count and states == [True, False]
    drag(view, (50, 50), (60, 60))   # nothing upstream any more
    assert view.message() == canvas_mouse.NO_CAMERA and ws.undo_stack.count() == count
    ws.undo_stack.undo()             # rc and its connections are back
    before = ws.network.get("rc.camera")
    drag(view, (50, 50), (60, 50))   # a good edit clears the complaint
    assert view.message() == ""
    assert_camera(ws.network.get("rc.camera"), before.rotate(math.pi * 10 / SIZE[1], 0.0))


def test_save_image_writes_the_frame_as_png(ws, qtbot, tmp_path, monkeypatch):
    view = make_view(qtbot, ws)
    problems = []
    view.problem.connect(problems.append)
    assert view.save_image(tmp_path / "none.png") is None and problems == ["no image to save yet"]

    rng = np.random.default_rng(7)
    frame = rng.integers(0, 256, size=(24, 40, 4), dtype=np.uint8)
    view.show_frame(frame, final=False)
    monkeypatch.setattr(view, "ask_save_path", lambda: str(tmp_path / "shot"))
    menu = view.context_menu()
    [action] = [a for a in menu.actions() if a.text() == "Save Image..."]
    action.trigger()
    saved = tmp_path / "shot.png"
    with PIL.Image.open(saved) as image:
        assert image.mode == "RGBA" and np.array_equal(np.asarray(image), frame)

    assert view.save_image(tmp_path / "no-such-dir" / "x.png") is None
    assert problems[-1].startswith("could not save") and view.message() == problems[-1]
    monkeypatch.setattr(view, "ask_save_path", lambda: "")
    assert view.save_image() is None


# --- in the main window, with the render process ---------------------------------------------------


def test_the_window_renders_coarse_while_dragging_and_refines_on_release(window, qtbot):
    """A canvas dock per Canvas; a drag re-renders at a quarter of the size while the mouse moves,
    and at full size with the new camera once it is released; the frame equals `vgraph run`'s."""
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.evaluation.run(wait=True)
    view = window.canvases.views["canvas"]
    width, height = window.workspace.network.get("canvas.size")
    before, camera = view.frame().copy(), window.workspace.network.get("eep.camera")
    assert before.shape == (height, width, 4) and view.is_final
    reference = window.workspace.network  # the GUI's copy was never evaluated ...
    assert reference["rc"].evaluation_count == 0                       # ... the render process did it

    sizes = []
    window.evaluation.frames.connect(lambda frames, final: sizes.append((frames["canvas"].shape[:2], final)))
    center = (view.width() / 2, view.height() / 2)
    send_mouse(view, QEvent.MouseButtonPress, center, Qt.LeftButton, Qt.LeftButton)
    with qtbot.waitSignal(window.evaluation.frames, timeout=20000):
        send_mouse(view, QEvent.MouseMove, (center[0] + 40, center[1]), Qt.NoButton, Qt.LeftButton)
    with qtbot.waitSignal(window.evaluation.frames, timeout=20000,
                          check_params_cb=lambda frames, final: final):
        send_mouse(view, QEvent.MouseButtonRelease, (center[0] + 40, center[1]), Qt.LeftButton, Qt.NoButton)
    assert sizes[0] == ((height // 4, width // 4), False)              # coarse while dragging
    assert sizes[-1] == ((height, width), True)                        # refined when released
    assert window.workspace.network.get("eep.camera") != camera
    assert window.workspace.network.get("rc.camera") == window.workspace.network.get("eep.camera")
    assert np.abs(view.frame().astype(int) - before).max() > 0

    saved = REPO / "networks" / "raycast_sphere.json"
    rendered = window.workspace.network  # the CLI renders the same camera to the same pixels
    from vgraph import load
    network = load(saved)
    network.set("eep.camera", rendered.get("eep.camera"))
    from vgraph.imagefile import to_uint8
    np.testing.assert_array_equal(to_uint8(network.evaluate("canvas")), view.frame())


@pytest.mark.parametrize("name", ["tets_lox_post", "tets_disk_out_ref", "tets_bonsai"])
def test_tetrahedral_networks_render_in_the_window(window, qtbot, data_dir, name):
    """The shipped mesh networks open in the GUI and its render process draws what `vgraph run`
    draws; the transfer-function editor gets the mesh scalar's histogram."""
    frame = open_and_compare_with_run(window, REPO / "networks" / f"{name}.json")
    assert frame[..., :3].max() > 50  # the mesh is there, not only the background
    renderer = next(p.id for p in window.workspace.network.processors.values()
                    if p.type_name == "ProjectedTetrahedra")
    assert window.inspector.histograms[renderer].sum() > 0


def test_a_bricked_frame_refines_in_the_window_until_complete_without_input(window, qtbot, tmp_path):
    """Coarse first: the render process reads a new volume's bricks within GUI_LOAD_LIMIT a
    frame, so the first frame comes from the coarsest bricks ("refining...", not final) and the
    window asks for the same state again by itself until the frame is the one `vgraph run` draws."""
    import vgraph
    from vgraph.imagefile import to_uint8
    network = bricked_sphere_network((96, 80))
    path = tmp_path / "bricked.json"
    network.save(path)
    shown = []
    window.evaluation.frames.connect(lambda frames, final: "canvas" in frames and shown.append(
        (final, window.canvases.views["canvas"].message())))
    with qtbot.waitSignal(window.evaluation.frames, timeout=60000,
                          check_params_cb=lambda frames, final: final and "canvas" in frames):
        assert window.open_network(path)    # and nothing else: no run(), no input
    assert shown[0] == (False, "refining...") and shown[-1] == (True, "") and len(shown) >= 2
    qtbot.waitUntil(window.evaluation.idle, timeout=10000)   # refining stopped with the complete frame
    view = window.canvases.views["canvas"]
    assert view.is_final and window.evaluation.last_result.refining is False
    np.testing.assert_array_equal(view.frame(), to_uint8(vgraph.load(path).evaluate("canvas")))
    assert view.frame()[..., :3].max() > 100
