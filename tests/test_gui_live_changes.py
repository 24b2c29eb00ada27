"""The window sends the render process changes, not documents: what is submitted, and that the
frames and the render process's network are what a whole document gives."""

import os
import signal

import numpy as np

from vgraph.fileformat import network_document
from vgraph.edits import SetProperty
from vgraph.live.render_messages import RenderJob
from vgraph.live.render_server import RenderServer

from helpers.networks import bricked_sphere_network
from helpers.paths import REPO


def open_small(window, name="raycast_sphere.json"):
    assert window.open_network(REPO / "networks" / name)
    window.workspace.set_property("canvas.size", [64, 64])   # quick frames
    window.evaluation.run(wait=True)


def document_frame(window) -> np.ndarray:
    """The canvas frame a render process given the whole document renders."""
    network = window.workspace.network
    result = RenderServer().handle(RenderJob(1, network_document(network), str(network.base_dir)))
    assert result.error is None
    return result.outcome.frames["canvas"]


def test_a_property_edit_sends_a_change_and_renders_the_documents_frame(window, jobs):
    open_small(window)
    assert jobs[0].document is not None and jobs[0].fresh          # opening sends the whole network
    del jobs[:]
    window.workspace.set_property("rc.sampling_rate", 1.5)
    window.evaluation.run(wait=True)
    assert [(job.document, job.changes) for job in jobs] == [(None, (SetProperty("rc.sampling_rate", 1.5),))]
    frame = window.canvases.views["canvas"].frame()
    np.testing.assert_array_equal(frame, document_frame(window))


def test_structural_edits_and_their_undo_reach_the_render_process(window, jobs):
    """Replaying what was submitted on a server of our own gives the GUI's network: the render
    process got the same jobs."""
    open_small(window)
    ws = window.workspace
    ws.remove(["eep"])                    # its connections and camera link go with it
    window.evaluation.run(wait=True)
    ws.undo_stack.undo()                  # back at its place, connections and link too
    window.evaluation.run(wait=True)
    ws.disconnect(ws.network.inputs_of("canvas", "image")[0])
    ws.add_processor("Grayscale", id="gray")
    ws.connect("rc.image", "gray.image")
    ws.connect("gray.image", "canvas.image")
    window.evaluation.run(wait=True)
    assert all(job.document is None for job in jobs[1:])
    replay = RenderServer()
    for job in jobs:
        assert not replay.handle(job).needs_document
    positions = lambda document: {**document, "processors": [  # noqa: E731  (moves are not sent)
        {**p, "position": None} for p in document["processors"]]}
    assert positions(network_document(replay.network)) == positions(network_document(ws.network))
    np.testing.assert_array_equal(window.canvases.views["canvas"].frame(), document_frame(window))


def test_a_new_render_process_gets_the_whole_document(window, jobs):
    open_small(window)
    evaluation = window.evaluation
    os.kill(evaluation.renderer.pid, signal.SIGKILL)
    evaluation.renderer._process.join(5)
    del jobs[:]
    window.workspace.set_property("rc.sampling_rate", 1.5)
    evaluation.run(wait=True)
    assert jobs[0].document is not None and jobs[0].fresh
    assert evaluation.last_result.error is None
    window.workspace.set_property("rc.sampling_rate", 2.0)
    evaluation.run(wait=True)
    assert jobs[-1].document is None                          # and changes again afterwards


def test_a_render_process_that_asks_for_the_document_gets_it(window, jobs):
    """A change the render process cannot apply (here: another sender's network) is answered
    with the whole document, without an error in the log."""
    open_small(window)
    renderer = window.evaluation.renderer
    renderer.submit(RenderJob(99, network_document(window.workspace.network), stamp=("another window", 1)))
    renderer.wait()
    del jobs[:]
    window.workspace.set_property("rc.sampling_rate", 1.5)
    window.evaluation.run(wait=True)
    assert [job.document is None for job in jobs] == [True, False]
    assert window.evaluation.last_result.error is None and not window.log.messages("error")
    np.testing.assert_array_equal(window.canvases.views["canvas"].frame(), document_frame(window))


def test_refining_renders_the_same_state_again_and_stops_when_a_frame_reads_nothing(window, jobs, qtbot):
    """A final, refining result is asked for again with no changes; one that read no bricks made
    no progress: refining stops with a warning instead of spinning."""
    from vgraph.live.render_messages import RenderResult
    open_small(window)
    evaluation = window.evaluation
    del jobs[:]
    last = evaluation.last_result
    evaluation._receive(RenderResult(evaluation.version, outcome=last.outcome, refining=True, bricks_read=3))
    assert [(job.document, job.changes, job.version) for job in jobs] == [(None, (), evaluation.version)]
    assert window.canvases.views["canvas"].message() == "refining..."
    qtbot.waitUntil(evaluation.idle, timeout=20000)  # that job's real result is complete: no more jobs
    assert len(jobs) == 1 and window.canvases.views["canvas"].message() == ""
    with qtbot.waitSignal(evaluation.warning) as warned:
        evaluation._receive(RenderResult(evaluation.version, outcome=last.outcome, refining=True, bricks_read=0))
    assert "stopped refining" in warned.args[0] and len(jobs) == 1 and evaluation.idle()


def test_an_edit_while_a_bricked_frame_refines_takes_over(window, jobs, qtbot, tmp_path):
    """Refining renders the state it was asked for; an edit made meanwhile goes out as a change
    (the normal flow) and the window ends at the complete frame of the edited state."""
    from vgraph.imagefile import to_uint8
    network = bricked_sphere_network((64, 48))
    network.save(tmp_path / "bricked.json")
    with qtbot.waitSignal(window.evaluation.frames, timeout=60000,
                          check_params_cb=lambda frames, final: "canvas" in frames and not final):
        assert window.open_network(tmp_path / "bricked.json")
    assert window.evaluation.last_result.refining                  # coarse first: the new volume's first frame
    window.workspace.set_property("rc.sampling_rate", 1.5)
    edit = window.evaluation.version
    qtbot.waitUntil(lambda: window.evaluation.idle() and window.canvases.views["canvas"].is_final, timeout=60000)
    changed = [job for job in jobs if job.changes]
    assert [job.changes for job in changed] == [(SetProperty("rc.sampling_rate", 1.5),)]
    after = jobs[jobs.index(changed[0]):]
    assert all(job.version == edit for job in after)   # nothing more for the state before the edit
    assert not window.evaluation.last_result.refining
    network.set("rc.sampling_rate", 1.5)
    np.testing.assert_array_equal(window.canvases.views["canvas"].frame(), to_uint8(network.evaluate("canvas")))
