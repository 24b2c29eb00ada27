"""Issue #17 item 2: an evaluation that takes longer than a moment shows which processor runs,
a progress bar for work with steps, the node running and the old frame marked as being updated;
all of it goes when the frame arrives.

The slow processor (helpers.slow_source.SlowSource) waits half-way for a gate file the test
creates, so the test looks at the window while the work is under way for certain, not after a
guessed sleep.
"""

import numpy as np

import helpers.slow_source
from helpers.slow_source import slow_network
from vgraph.gui.progress_view import STALE_PREFIX
from vgraph.progress import Progress

slow_source = helpers.slow_source.slow_source  # a fixture these tests take




def test_a_slow_source_shows_its_name_steps_node_and_a_stale_frame_until_the_frame_arrives(
        slow_source, window, jobs, qtbot, tmp_path):
    gate = tmp_path / "gate"
    gate.touch()                                    # the first frame runs straight through
    assert window.open_network(slow_network(tmp_path, gate))
    window.evaluation.run(wait=True)
    view, node = window.canvases.views["canvas"], window.scene.nodes["source"]
    old = view.frame().copy()
    assert not window.running.visible and node.status.state == "evaluated"

    gate.unlink()                                   # the next evaluation stops half-way
    window.workspace.set_property("source.resolution", 40)
    running = window.running
    qtbot.waitUntil(lambda: running.visible and running.bar.isVisible(), timeout=20000)
    assert "source (SlowSource)" in running.label.text()
    assert "waiting for the gate" in running.label.text()
    assert running.bar.value() == 500               # step 5 of 10
    assert node.status.state == "running" and node.status.fraction == 0.5
    assert "waiting for the gate 50%" in node.status.text
    downstream = {pid: window.scene.nodes[pid].status for pid in ("eep", "rc", "canvas")}
    assert all(status.state == "invalid" and status.text == "waiting for source"
               for status in downstream.values()), downstream
    assert view.message() == STALE_PREFIX + "source 50%"
    np.testing.assert_array_equal(view.frame(), old)  # the old frame stays up meanwhile

    gate.touch()
    qtbot.waitUntil(window.evaluation.idle, timeout=20000)
    qtbot.waitUntil(lambda: not running.visible, timeout=5000)
    assert not running.bar.isVisible()
    assert all(window.scene.nodes[pid].status.state == "evaluated"
               for pid in ("source", "eep", "rc", "canvas"))
    assert node.status.fraction is None
    assert view.message() == ""
    assert not np.array_equal(view.frame(), old)     # the new sphere, sampled at 40^3


def test_progress_waits_for_the_delay_so_fast_frames_do_not_flicker(window, jobs, monkeypatch):
    running = window.running
    monkeypatch.setattr(window.evaluation.renderer, "elapsed", lambda: 0.0)  # a job just started
    running.update_progress(Progress("source", "SlowSource", "loading", 1, 10))
    assert not running.visible and running.timer.isActive()   # shown only if still running then
    running.update_progress(None)                            # answered before the delay was over
    assert not running.visible and not running.timer.isActive()
