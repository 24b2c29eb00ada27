"""Interaction: drags on a slider, a TF point or the canvas render coarse frames while they last and
the full frame on release; stale jobs are skipped, not rendered; property changes travel as
changes; and a camera frame of a cached network asks the graph nothing new (the per-frame Python
overhead cannot creep back unnoticed)."""

import networkx
import numpy as np
import pytest
from PySide6.QtCore import QEvent, Qt

import vgraph
from vgraph.errors import VGraphError
from vgraph.fileformat import network_document
from vgraph.edits import SetProperty
from vgraph.gui.live_evaluation import INTERACTIVE_SCALE, LiveEvaluation
from vgraph.live.render_messages import RenderJob, RenderResult
from vgraph.live.render_server import RenderServer, serve
from vgraph.live.evaluator import EvaluationOutcome
from scripted_user import send_mouse

from helpers.paths import REPO

SIZE = 64  # canvas side: coarse frames are SIZE * INTERACTIVE_SCALE


@pytest.fixture
def shown(window):
    """(width, final) of every frame the canvas is given."""
    frames = []
    window.evaluation.frames.connect(
        lambda frames_, final: frames.append((frames_["canvas"].shape[1], final)) if "canvas" in frames_ else None)
    return frames


def open_sphere(window):
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.workspace.set_property("canvas.size", [SIZE, SIZE])
    window.evaluation.run(wait=True)
    window.scene.select_processor("rc")


def document_frame(window) -> np.ndarray:
    network = window.workspace.network
    result = RenderServer().handle(RenderJob(1, network_document(network), str(network.base_dir)))
    return result.outcome.frames["canvas"]


def settle(window, qtbot):
    qtbot.waitUntil(lambda: window.evaluation.idle() and window.canvases.views["canvas"].is_final,
                    timeout=60000)


def test_a_slider_drag_renders_coarse_changes_and_refines_on_release(window, jobs, shown, qtbot):
    open_sphere(window)
    del jobs[:], shown[:]
    slider = window.inspector.editors["diffuse"].slider
    coarse = round(SIZE * INTERACTIVE_SCALE)
    with qtbot.waitSignal(window.inspector.interacting, check_params_cb=lambda on: on):
        slider.setSliderDown(True)
    assert window.evaluation.scale == INTERACTIVE_SCALE
    for step in range(400, 800, 40):
        slider.setValue(step)
        qtbot.wait(16)
    qtbot.waitUntil(lambda: (coarse, False) in shown, timeout=20000)  # frames while the drag lasts
    during = list(jobs)
    with qtbot.waitSignal(window.inspector.interacting, check_params_cb=lambda on: not on):
        slider.setSliderDown(False)
    settle(window, qtbot)
    assert during and all(job.scale == INTERACTIVE_SCALE and job.document is None for job in during)
    assert all(isinstance(change, SetProperty) and change.address == "rc.diffuse"
               for job in during for change in job.changes)
    assert jobs[-1].scale == 1.0 and jobs[-1].document is None
    assert all(width == coarse for width, final in shown[:-1] if not final)
    assert shown[-1] == (SIZE, True)
    assert window.workspace.network.get("rc.diffuse") == pytest.approx(0.76)
    np.testing.assert_array_equal(window.canvases.views["canvas"].frame(), document_frame(window))
    assert window.workspace.undo_stack.count() == 1 + 1  # canvas size, then the whole drag


def test_a_tf_point_drag_is_interactive_while_the_button_is_down(window, jobs, qtbot):
    open_sphere(window)
    plot = window.inspector.editors["transfer_function"].plot
    index = len(plot.points) // 2
    position, *_, opacity = plot.points[index]
    start = plot.to_pixel(position, opacity)
    del jobs[:]
    send_mouse(plot, QEvent.MouseButtonPress, start, Qt.LeftButton, Qt.LeftButton)
    assert window.evaluation.scale == INTERACTIVE_SCALE
    for i in range(1, 6):
        send_mouse(plot, QEvent.MouseMove, plot.to_pixel(position, opacity * (1 - 0.1 * i)), Qt.NoButton, Qt.LeftButton)
        qtbot.wait(16)
    send_mouse(plot, QEvent.MouseButtonRelease, plot.to_pixel(position, opacity / 2), Qt.LeftButton, Qt.NoButton)
    assert window.evaluation.scale == 1.0
    settle(window, qtbot)
    assert jobs[0].scale == INTERACTIVE_SCALE and jobs[-1].scale == 1.0
    assert all(job.document is None for job in jobs)
    assert window.canvases.views["canvas"].frame().shape[:2] == (SIZE, SIZE)


def test_clicks_that_change_nothing_render_nothing(window, jobs, qtbot):
    """A click on empty plot space is no drag; a click on a point is a drag that moved nothing,
    so its release asks for no frame."""
    open_sphere(window)
    plot = window.inspector.editors["transfer_function"].plot
    with qtbot.assertNotEmitted(window.inspector.interacting):
        send_mouse(plot, QEvent.MouseButtonPress, plot.to_pixel(0.5, 0.97), Qt.LeftButton, Qt.LeftButton)
        send_mouse(plot, QEvent.MouseButtonRelease, plot.to_pixel(0.5, 0.97), Qt.LeftButton, Qt.NoButton)
    position, *_, opacity = plot.points[len(plot.points) // 2]
    del jobs[:]
    send_mouse(plot, QEvent.MouseButtonPress, plot.to_pixel(position, opacity), Qt.LeftButton, Qt.LeftButton)
    send_mouse(plot, QEvent.MouseButtonRelease, plot.to_pixel(position, opacity), Qt.LeftButton, Qt.NoButton)
    qtbot.wait(100)
    assert jobs == [] and window.evaluation.idle()


class FakeConnection:
    """The render process's end of the pipe, with jobs already waiting in it."""

    def __init__(self, jobs):
        self.waiting, self.sent = list(jobs), []

    def poll(self, timeout=None):
        return bool(self.waiting)

    def recv(self):
        if not self.waiting:
            raise EOFError
        return self.waiting.pop(0)

    def send(self, message):
        if isinstance(message, RenderResult):  # (not the progress messages sent while evaluating)
            self.sent.append(message)


def test_the_render_process_skips_jobs_that_a_newer_one_waits_behind(gl):
    """Jobs waiting together: the newest is rendered, the older ones are answered as skipped
    with their changes applied (the rendered frame is that of all the changes)."""
    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    network.set("canvas.size", [32, 32])
    base_dir = str(network.base_dir)
    first = RenderJob(1, network_document(network), base_dir, stamp=("w", 1), fresh=True)
    second = RenderJob(2, None, base_dir, scale=INTERACTIVE_SCALE, stamp=("w", 2), since=("w", 1),
                       changes=(SetProperty("rc.sampling_rate", 1.5),))
    third = RenderJob(3, None, base_dir, scale=INTERACTIVE_SCALE, stamp=("w", 3), since=("w", 2),
                      changes=(SetProperty("rc.diffuse", 0.4),))
    connection = FakeConnection([first, second, third])
    serve(connection)
    assert [(r.version, r.skipped) for r in connection.sent] == [(1, True), (2, True), (3, False)]
    assert all(not r.outcome.frames for r in connection.sent[:2])
    network.set("rc.sampling_rate", 1.5)
    network.set("rc.diffuse", 0.4)
    expected = RenderServer().handle(RenderJob(1, network_document(network), base_dir, scale=INTERACTIVE_SCALE))
    np.testing.assert_array_equal(connection.sent[-1].outcome.frames["canvas"], expected.outcome.frames["canvas"])


def test_writers_are_never_skipped(gl, tmp_path):
    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    network.set("canvas.size", [16, 16])
    job = RenderJob(1, network_document(network), str(network.base_dir), stamp=("w", 1), include_writers=True)
    newer = RenderJob(2, None, str(network.base_dir), stamp=("w", 2), since=("w", 1))
    connection = FakeConnection([job, newer])
    serve(connection)
    assert [(r.version, r.skipped) for r in connection.sent] == [(1, False), (2, False)]


class QueueRenderer:
    """A render process stand-in whose results arrive when the test says so."""

    def __init__(self):
        self.jobs, self.ready, self.pid, self.progress = [], [], 1, None

    busy = property(lambda self: bool(self.jobs))
    in_flight = property(lambda self: len(self.jobs))

    def submit(self, job):
        self.jobs.append(job)

    def poll(self):
        if not self.ready:
            return None
        self.jobs.pop(0)
        return self.ready.pop(0)

    def died(self):
        return None

    def typical_seconds(self):
        return None

    def elapsed(self):
        return 0.0

    def wait(self, timeout=None):
        raise VGraphError("no render process here")

    def cancel(self):
        self.jobs.clear()


def test_while_dragging_changes_queue_up_and_results_arriving_together_show_the_newest(qtbot, tmp_path):
    from PySide6.QtCore import QSettings
    from vgraph.gui.workspace import Workspace
    workspace = Workspace(QSettings(str(tmp_path / "s.ini"), QSettings.IniFormat))
    workspace.network.add("Canvas", id="canvas")
    renderer = QueueRenderer()
    evaluation = LiveEvaluation(workspace, renderer)
    evaluation.run()
    assert len(renderer.jobs) == 1                       # the document
    workspace.set_property("canvas.size", [40, 40])
    assert len(renderer.jobs) == 1                       # not dragging: waits for the result
    evaluation.interactive(True)
    for side in (41, 42, 43, 44, 45, 46):
        workspace.set_property("canvas.size", [side, side], merge="drag")
    assert len(renderer.jobs) == 4                       # queued, up to MAX_IN_FLIGHT
    assert all(job.document is None and job.scale == INTERACTIVE_SCALE for job in renderer.jobs[1:])
    shown = []
    evaluation.frames.connect(lambda frames, final: shown.append(frames["canvas"].shape))
    frame = lambda side: EvaluationOutcome(frames={"canvas": np.zeros((side, side, 4), np.uint8)})  # noqa: E731
    renderer.ready = [RenderResult(job.version, job.scale, outcome=frame(side))
                      for job, side in zip(renderer.jobs[:3], (10, 11, 12))]
    renderer.ready[1].skipped = True                     # the render process skipped the second
    evaluation._poll()
    assert shown == [(12, 12, 4)] and evaluation.frames_dropped == 1
    assert list(renderer.jobs[-1].changes[-1].value) == [46, 46]  # what waited went out
    evaluation.interactive(False)
    assert renderer.jobs[-1].scale == 1.0                # the refined frame, queued behind the coarse
    evaluation.shutdown()


def camera_frames(network, count):
    camera = network.get("rc.camera")
    for i in range(count):
        network.set("rc.camera", camera.rotate(0.01 * (i + 1), 0.0))
        network.update("canvas", size=(8, 8))


def test_a_camera_frame_of_a_cached_network_asks_the_graph_nothing(gl, monkeypatch):
    """After the first frame, the scheduler's plan and the downstream sets come from the
    network's answers; each frame resolves its camera once (not once per processor) and the
    uniforms written per frame do not grow with the number of frames."""
    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    camera_frames(network, 2)
    calls = {"graph": 0, "resolved": 0, "writes": 0}

    def counting(module, name, key):
        original = getattr(module, name)

        def wrapper(*args, **kwargs):
            calls[key] += 1
            return original(*args, **kwargs)
        monkeypatch.setattr(module, name, wrapper)
    for name in ("topological_sort", "ancestors", "descendants"):
        counting(networkx, name, "graph")
    from vgraph.camera import Camera
    counting(Camera, "resolved", "resolved")
    import _moderngl
    counting(_moderngl.Uniform, "write", "writes")
    camera_frames(network, 3)
    assert calls["graph"] == 0 and calls["resolved"] == 3
    per_frame = calls["writes"] / 3
    camera_frames(network, 6)
    assert calls["writes"] - 3 * per_frame == 6 * per_frame
    assert network["rc"].evaluation_count == network["eep"].evaluation_count


def test_graph_answers_follow_every_change_of_the_graph():
    network = vgraph.Network()
    for pid in ("a", "b", "c"):
        network.add("Grayscale", id=pid)
    downstream = lambda: network.graph_query(("down", "a"), lambda: frozenset(networkx.descendants(network.graph, "a")))  # noqa: E731
    assert downstream() == frozenset()
    connection = network.connect("a.image", "b.image")
    assert downstream() == {"b"}
    network.connect("b.image", "c.image", index=0)          # an insertion rebuilds the graph
    assert downstream() == {"b", "c"}
    network.disconnect(connection)
    assert downstream() == frozenset()
    removal = network.remove("b")
    network.restore(removal)
    assert downstream() == frozenset()
    network.connect("a.image", "b.image")
    assert downstream() == {"b", "c"}
