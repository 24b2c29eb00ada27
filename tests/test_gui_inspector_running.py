"""Issue #17: the inspector says that the selected processor runs now and how far it is, and
after the frame how long it took and which share of the frame that was.

The slow processor (helpers.slow_source.SlowSource) waits half-way for a gate file the test
creates, so the test looks at the inspector while the work is under way for certain.
"""

import json
import re

import pytest

from helpers.paths import REPO
import helpers.slow_source
from helpers.slow_source import slow_network
from vgraph.live.evaluator import ProcessorStatus
from vgraph.gui.inspector import running_text, timing_text
from vgraph.progress import Progress

slow_source = helpers.slow_source.slow_source  # a fixture these tests take

TOOK = re.compile(r"took ([0-9.]+) (ms|s) \((\d+) % of the frame\)")




def seconds_of(match) -> float:
    value, unit = float(match.group(1)), match.group(2)
    return value / 1000 if unit == "ms" else value


def test_the_selected_processor_shows_running_then_its_time_and_share_of_the_frame(
        slow_source, window, jobs, qtbot, tmp_path):
    gate = tmp_path / "gate"
    gate.touch()
    assert window.open_network(slow_network(tmp_path, gate))
    window.evaluation.run(wait=True)
    window.scene.select_processor("source")
    inspector = window.inspector
    assert TOOK.fullmatch(inspector.timing.text()), inspector.timing.text()

    gate.unlink()                                   # the next evaluation stops half-way
    window.workspace.set_property("source.resolution", 40)
    qtbot.waitUntil(lambda: inspector.timing.text().startswith("running"), timeout=20000)
    assert inspector.timing.text() == "running: waiting for the gate 50%"
    assert inspector.timing.isVisible()

    gate.touch()
    qtbot.waitUntil(window.evaluation.idle, timeout=20000)
    qtbot.waitUntil(lambda: TOOK.fullmatch(inspector.timing.text()) is not None, timeout=5000)
    match = TOOK.fullmatch(inspector.timing.text())
    status = window.evaluation.status_of("source")
    frame = window.evaluation.last_result.seconds
    assert "source" in window.evaluation.last_outcome.ran
    assert seconds_of(match) == pytest.approx(status.seconds, abs=0.0006)   # shown to 0.1 ms
    assert int(match.group(3)) == round(100 * status.seconds / frame)
    assert status.seconds > 0.0 and 0 < int(match.group(3)) <= 100


def test_a_processor_the_last_frame_did_not_run_says_so(slow_source, window, jobs, qtbot, tmp_path):
    gate = tmp_path / "gate"
    gate.touch()
    assert window.open_network(slow_network(tmp_path, gate))
    window.evaluation.run(wait=True)
    window.scene.select_processor("source")
    before = window.evaluation.status_of("source").seconds
    window.workspace.set_property("rc.sampling_rate", 2.0)   # the ray caster runs, not the source
    window.evaluation.run(wait=True)
    assert "source" not in window.evaluation.last_outcome.ran and "rc" in window.evaluation.last_outcome.ran
    text = window.inspector.timing.text()
    assert text.endswith("when it last ran (the last frame reused its output)"), text
    assert window.evaluation.status_of("source").seconds == before

    window.scene.select_processor("rc")                      # it ran: its share of that frame
    assert TOOK.fullmatch(window.inspector.timing.text()), window.inspector.timing.text()


def test_reports_of_other_processors_or_before_the_delay_do_not_show(window, jobs, monkeypatch):
    ws = window.workspace
    ws.add_processor("FunctionSelector", (0, 0), id="f")
    window.evaluation.run(wait=True)
    window.scene.select_processor("f")
    inspector = window.inspector
    shown = inspector.timing.text()
    monkeypatch.setattr(window.evaluation.renderer, "elapsed", lambda: 5.0)   # a long job
    inspector._progress(Progress("other", "VolumeSource", "reading", 1, 4))
    assert inspector.timing.text() == shown                  # not the selected processor
    inspector._progress(Progress("f", "FunctionSelector", "sampling", 1, 4))
    assert inspector.timing.text() == "running: sampling 25%"
    inspector._progress(None)                                # the job was answered
    assert inspector.timing.text() == shown

    monkeypatch.setattr(window.evaluation.renderer, "elapsed", lambda: 0.0)   # a job just started
    inspector._progress(Progress("f", "FunctionSelector", "sampling", 1, 4))
    assert inspector.timing.text() == shown and inspector.running_timer.isActive()
    inspector._progress(None)
    assert not inspector.running_timer.isActive() and inspector.timing.text() == shown


def test_timing_lines():
    status = ProcessorStatus("evaluated", "", "", seconds=0.12)
    assert timing_text(status, True, 0.12 / 0.38) == "took 120.0 ms (38 % of the frame)"
    assert timing_text(status, True, None) == "took 120.0 ms"
    assert timing_text(status, False, 0.5) == "took 120.0 ms when it last ran (the last frame reused its output)"
    assert timing_text(ProcessorStatus("invalid", "", ""), True, 0.5) == ""
    assert running_text(Progress("src", "VolumeSource", "reading head.raw", 45, 100)) == "running: reading head.raw 45%"
    assert running_text(Progress("src", "VolumeSource")) == "running now"
    assert running_text(Progress("src", "VolumeSource", "", 1, 2)) == "running: 50%"


# --- the camera editor's automatic planes show the planes of the last frame ------------------------
def auto_plane_network(tmp_path):
    """raycast_sphere.json with automatic near/far planes (its cameras are linked)."""
    document = json.loads((REPO / "networks" / "raycast_sphere.json").read_text())
    for processor in document["processors"]:
        if "camera" in processor["properties"]:
            processor["properties"]["camera"].update(near=None, far=None)
        if processor["id"] == "canvas":
            processor["properties"]["size"] = [64, 64]
    path = tmp_path / "auto_planes.json"
    path.write_text(json.dumps(document))
    return path


def test_automatic_near_far_boxes_show_the_planes_the_last_frame_used(window, jobs, tmp_path):
    from PySide6.QtGui import QPalette
    from vgraph.gui.camera_editor import plane_text
    assert window.open_network(auto_plane_network(tmp_path))
    window.evaluation.run(wait=True)
    window.scene.select_processor("rc")
    editor = window.inspector.editors["camera"]
    used = window.evaluation.view_cameras["rc.camera"]
    distance = sum((p - f) ** 2 for p, f in zip(used.position, used.focus)) ** 0.5
    assert 0 < used.near < distance < used.far                # planes around the data at the focus
    near, far = editor.planes["near"], editor.planes["far"]
    assert near.lineEdit().text() == f"auto ({plane_text(used.near)})"
    assert far.lineEdit().text() == f"auto ({plane_text(used.far)})"
    assert f"near {used.near:.4g}, far {used.far:.4g}" in near.toolTip()
    grey = editor.palette().color(QPalette.PlaceholderText)
    assert near.lineEdit().palette().color(QPalette.Text) == grey

    camera = window.workspace.network.get("rc.camera")        # twice as far: the planes move out
    window.workspace.set_property("rc.camera", camera.model_dump() | {
        "position": tuple(2 * c for c in camera.position)})
    window.evaluation.run(wait=True)
    moved = window.evaluation.view_cameras["rc.camera"]
    assert moved.far > used.far
    assert far.lineEdit().text() == f"auto ({plane_text(moved.far)})"

    window.workspace.set_property("rc.camera", window.workspace.network.get("rc.camera").model_dump()
                                  | {"near": 1.5})           # an explicit plane is a number, not grey
    assert near.value() == 1.5 and near.lineEdit().text() == "1.5000"
    assert near.lineEdit().palette().color(QPalette.Text) != grey
    assert far.lineEdit().text().startswith("auto (")


def test_plane_text_is_short():
    from vgraph.gui.camera_editor import plane_text
    assert [plane_text(v) for v in (0.123456, 3.4, 12.345, 4321.5, 2.5e6)] == \
        ["0.123", "3.4", "12.3", "4322", "2.5e+06"]
