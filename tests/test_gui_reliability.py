"""The GUI survives long use and a render process that hangs or dies.

PySide6-Essentials 6.12.0 on Python 3.11 dropped one reference to ``None`` on every
``QPainter.fillRect`` / ``drawRoundedRect`` call; after a few thousand calls Python freed ``None``
and aborted ("Fatal Python error: none_dealloc"), minutes into a session. These tests paint a few
thousand shapes through the code paths the window really uses and check that ``None`` keeps its
references. Only a loss is a failure: Python 3.11's ``None`` is freed when its count reaches zero,
while extra references are harmless (6.11 adds a few per QPainter opened on a new paint device).
"""

import os
import signal
import sys

import numpy as np
import pytest
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QImage, QPainter

from helpers.paths import REPO

# Qt's own bookkeeping may release a handful of references while the loops run; the broken
# binding lost one per call, thousands here.
SLACK = 50


def none_references_lost(paint, times: int) -> int:
    """References to None lost over ``times`` paints; stops as soon as the loss passes SLACK,
    so a broken binding fails the test instead of aborting the whole test run."""
    paint()  # first paints fill caches (fonts, glyphs) that are not what is measured
    before = sys.getrefcount(None)
    for _ in range(times):
        paint()
        if before - sys.getrefcount(None) >= SLACK:
            break
    return before - sys.getrefcount(None)


def open_evaluated(window, name: str) -> None:
    assert window.open_network(REPO / "networks" / name)
    window.evaluation.run(wait=True)
    assert not window.log.messages("error")


def test_painting_the_network_editor_keeps_none_alive(window):
    open_evaluated(window, "curvature_torus.json")
    nodes = len(window.scene.nodes)
    image = QImage(1000, 800, QImage.Format_ARGB32_Premultiplied)

    def render_scene():
        painter = QPainter(image)
        window.scene.render(painter)   # each node: drawRoundedRect, drawEllipse, three drawText
        painter.end()

    times = 500
    assert nodes * times >= 2000
    assert none_references_lost(render_scene, times) < SLACK


def test_painting_the_transfer_function_editor_with_its_histogram_keeps_none_alive(window):
    open_evaluated(window, "raycast_sphere.json")
    window.scene.select_processor("rc")
    plot = window.inspector.editors["transfer_function"].plot
    assert plot.counts is not None
    bars = int(np.count_nonzero(plot.histogram_heights()))   # one fillRect per non-empty bin

    times = 40
    assert bars * times >= 2000
    assert none_references_lost(plot.grab, times) < SLACK
    plot.set_log_scale(True)   # other heights, the same calls
    assert none_references_lost(plot.grab, times) < SLACK


def test_painting_the_canvas_keeps_none_alive(window):
    open_evaluated(window, "raycast_sphere.json")
    canvas = window.canvases.views["canvas"]
    assert canvas.frame() is not None
    canvas.set_message("refining...")   # the message box is a second fillRect per paint

    assert none_references_lost(canvas.grab, 1500) < SLACK


def test_the_painter_calls_themselves_keep_none_alive(qtbot):
    """The two calls that broke, alone: a regression in the binding shows here first."""
    calls = 3000
    image = QImage(64, 64, QImage.Format_ARGB32_Premultiplied)
    painter = QPainter(image)
    try:
        assert none_references_lost(lambda: painter.fillRect(QRectF(1, 1, 9, 9), QColor(9, 9, 9)), calls) < SLACK
        assert none_references_lost(lambda: painter.drawRoundedRect(QRectF(1, 1, 9, 9), 3, 3), calls) < SLACK
    finally:
        painter.end()


def test_a_few_hundred_scripted_user_actions_leave_the_window_working(window):
    """The loop of bench/gui_soak.py, bounded: edits, drags, reconnections with undo/redo,
    trackball drags and TF point drags, with the render process catching up now and then."""
    from vgraph.fileformat import network_document
    from scripted_user import ScriptedUser
    open_evaluated(window, "raycast_sphere.json")
    original = network_document(window.workspace.network)
    user = ScriptedUser(window)
    before = sys.getrefcount(None)

    for _ in range(200):
        user.do_next()
        if user.actions_done % 20 == 0:
            assert user.settle()
    assert user.settle()

    assert window.log.messages("error") == [] and window.log.messages("warning") == []
    assert before - sys.getrefcount(None) < SLACK
    assert user.frames >= 10
    assert window.canvases.views["canvas"].is_final
    document = network_document(window.workspace.network)
    assert document["connections"] == original["connections"]   # the loop puts back what it takes
    assert document["links"] == original["links"]
    window.workspace.undo_stack.undo()                           # and the undo history still works
    assert window.evaluation.run(wait=True) is not None


# --- the render-process watchdog ------------------------------------------------------------------
@pytest.fixture
def lone_window(qtbot, tmp_path):
    """A window with a render process of its own: these tests stop and kill it."""
    from PySide6.QtCore import QSettings
    from vgraph.gui.app import MainWindow
    from vgraph.live.render_process import RenderProcess
    renderer = RenderProcess()
    main = MainWindow(QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat), renderer)
    main.show()
    qtbot.waitExposed(main)
    open_evaluated(main, "raycast_sphere.json")
    main.workspace.set_property("canvas.size", [64, 64])   # quick frames
    main.evaluation.run(wait=True)
    yield main
    main.workspace.undo_stack.setClean()
    main.close()
    renderer.stop()   # kills it even when stopped (SIGSTOP)


def process_exists(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def log_has(window, level: str, text: str) -> bool:
    return any(text in message for message in window.log.messages(level))


def renders_a_frame_after_a_change(window, qtbot, rate: float) -> None:
    with qtbot.waitSignal(window.evaluation.frames, timeout=60000):
        window.workspace.set_property("rc.sampling_rate", rate)
    window.evaluation.run(wait=True)
    assert window.evaluation.last_result.error is None
    assert window.canvases.views["canvas"].frame().shape == (64, 64, 4)


def test_a_stuck_render_process_is_reported_and_cancel_replaces_it(lone_window, qtbot):
    window, evaluation = lone_window, lone_window.evaluation
    evaluation.stall_min_seconds, evaluation.stall_factor = 0.3, 3.0
    assert evaluation.stall_limit() == max(0.3, 3.0 * evaluation.renderer.typical_seconds())
    stuck = evaluation.renderer.pid
    os.kill(stuck, signal.SIGSTOP)   # as a hung driver would: alive, silent
    window.workspace.set_property("rc.sampling_rate", 2.0)

    qtbot.waitUntil(lambda: log_has(window, "warning", "working on one frame for"), timeout=30000)
    assert "Network > Cancel Rendering" in window.log.messages("warning")[0]
    assert window.cancel_button.isVisible() and window.cancel_action.isEnabled()
    assert "rendering for" in window.statusBar().currentMessage()

    qtbot.mouseClick(window.cancel_button, Qt.LeftButton)
    assert log_has(window, "warning", "cancelled a frame after") and log_has(window, "warning", f"(pid {stuck})")
    assert log_has(window, "info", f"started a new render process (pid {evaluation.renderer.pid})")
    assert evaluation.renderer.pid != stuck and not process_exists(stuck)
    assert not window.cancel_button.isVisible() and evaluation.idle()
    renders_a_frame_after_a_change(window, qtbot, 1.5)
    assert window.log.messages("error") == []


def test_a_render_process_killed_while_idle_is_reported_and_replaced(lone_window, qtbot):
    window = lone_window
    killed = window.evaluation.renderer.pid
    os.kill(killed, signal.SIGKILL)

    qtbot.waitUntil(lambda: log_has(window, "error", "stopped unexpectedly while idle"), timeout=10000)
    assert log_has(window, "error", "exit code -9 (SIGKILL)")
    new = window.evaluation.renderer.pid
    assert new != killed and log_has(window, "info", f"started a new render process (pid {new})")
    renders_a_frame_after_a_change(window, qtbot, 1.5)
    assert len(window.log.messages("error")) == 1


def test_a_render_process_that_dies_with_a_job_is_reported_and_replaced(lone_window, qtbot):
    window = lone_window
    dying = window.evaluation.renderer.pid
    os.kill(dying, signal.SIGSTOP)   # so the job is surely in flight when it dies
    window.workspace.set_property("rc.sampling_rate", 2.0)
    qtbot.waitUntil(lambda: window.evaluation.renderer.busy, timeout=5000)
    os.kill(dying, signal.SIGKILL)

    qtbot.waitUntil(lambda: log_has(window, "error", "stopped unexpectedly (exit code -9 (SIGKILL))"),
                    timeout=10000)
    assert log_has(window, "info", f"started a new render process (pid {window.evaluation.renderer.pid})")
    renders_a_frame_after_a_change(window, qtbot, 1.5)


def test_a_long_drag_is_one_undo_step_and_frees_what_each_move_made(window, qtbot):
    """PySide6 keeps every undo command that QUndoStack.push merges away alive forever: each
    mouse move of a drag leaked one, with its transfer function (80 KB per drag in the soak)."""
    import gc
    from vgraph.gui.commands import EditCommand
    open_evaluated(window, "raycast_sphere.json")
    window.scene.select_processor("rc")
    plot = window.inspector.editors["transfer_function"].plot
    stack, original = window.workspace.undo_stack, window.workspace.network.get("rc.transfer_function")
    steps = stack.count()
    position, *_, opacity = plot.points[1]
    start = plot.to_pixel(position, opacity)
    qtbot.mousePress(plot, Qt.LeftButton, pos=start.toPoint())
    for i in range(1, 301):
        qtbot.mouseMove(plot, (start + QPointF(0, -(i % 50))).toPoint())
        if i == 150:
            assert window.autosave.write_if_needed() is not None
    assert window.autosave._dirty          # moves merged after the autosave still count as changes
    qtbot.mouseRelease(plot, Qt.LeftButton, pos=(start + QPointF(0, -20)).toPoint())

    assert stack.count() == steps + 1      # the whole drag: one undo step
    gc.collect()
    network = window.workspace.network   # (other tests' windows may still be alive)
    assert sum(isinstance(o, EditCommand) and o.network is network for o in gc.get_objects()) <= stack.count()
    stack.undo()
    assert window.workspace.network.get("rc.transfer_function") == original


def test_the_undo_history_keeps_the_last_steps_only(qtbot, tmp_path):
    """A long session must not grow without bound: the oldest steps are dropped."""
    from PySide6.QtCore import QSettings
    from vgraph.gui.workspace import UNDO_LIMIT, Workspace
    workspace = Workspace(QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat))
    workspace.add_processor("Number", (0, 0), id="n")
    workspace.undo_stack.setClean()
    edits = UNDO_LIMIT + 5
    for i in range(1, edits + 1):
        workspace.set_property("n.value", i / 100)
    stack = workspace.undo_stack
    assert stack.count() == UNDO_LIMIT
    while stack.canUndo():
        stack.undo()
    assert workspace.network.get("n.value") == 5 / 100   # back to before the oldest step kept
    assert workspace.is_modified()                       # the saved state is out of reach


def test_an_empty_frame_of_visible_content_is_a_warning_in_the_log_once(window):
    from helpers.paths import REPO
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.evaluation.run(wait=True)
    assert not [m for m in window.log.messages("warning") if "empty image" in m]
    away = {**window.workspace.network.get("eep.camera").model_dump(), "focus": [0.0, 0.0, 50.0],
            "position": [0.0, 0.0, 40.0]}
    window.workspace.set_property("eep.camera", away)
    window.evaluation.run(wait=True)
    window.evaluation.run(wait=True)
    warnings = [m for m in window.log.messages("warning") if "empty image" in m]
    assert len(warnings) == 1 and warnings[0].startswith("rc (RayCaster) rendered an empty image")
