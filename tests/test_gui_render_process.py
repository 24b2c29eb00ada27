"""The render process and the mirror that keeps its network in step with the GUI's (no Qt here)."""

import os
import signal

import numpy as np
import pytest

import vgraph
from vgraph.errors import NetworkFileError
from vgraph.fileformat import network_document
from vgraph.edits import SetProperty
from vgraph.live.changes import append_change, apply_changes, change_of
from vgraph.live.mirror import mirror
from vgraph.live.render_messages import RenderJob, plugin_modules
from vgraph.live.render_process import RenderProcess
from vgraph.live.render_server import RenderServer
from vgraph.network import Network

from helpers.paths import REPO


def summing_network() -> Network:
    network = Network()
    for pid, value in (("a", 1.0), ("b", 2.0), ("c", 4.0)):
        network.add("Number", id=pid, value=value)
    network.add("Sum", id="sum")
    network.add("Collect", id="sink")
    for pid in "ab":
        network.connect(f"{pid}.value", "sum.values")
    network.connect("sum.value", "sink.value")
    return network


def test_mirror_applies_a_document_as_the_smallest_change():
    gui = summing_network()
    copy = mirror(None, network_document(gui))
    copy.update()
    kept = {pid: copy[pid] for pid in copy.processors}

    gui.set("b.value", 3.0)
    gui.connect("c.value", "sum.values")
    gui.add("Number", id="d")
    gui.link("a.value", "d.value")
    mirror(copy, network_document(gui))
    assert network_document(copy) == network_document(gui)
    assert all(copy[pid] is processor for pid, processor in kept.items())  # same objects
    report = copy.update()
    assert report.ids == ["b", "c", "sum", "sink"]   # a stayed valid: only what changed runs again
    assert copy["sum"].outputs["value"] == 8.0

    gui.remove("c")
    gui.remove("d")
    mirror(copy, network_document(gui))
    assert network_document(copy) == network_document(gui) and "c" not in copy


def test_mirror_keeps_the_order_of_connections_into_one_inport():
    gui = summing_network()
    copy = mirror(None, network_document(gui))
    gui.disconnect("a.value", "sum.values")
    gui.connect("a.value", "sum.values")   # now b first, then a
    mirror(copy, network_document(gui))
    assert [c.source for c in copy.inputs_of("sum", "values")] == ["b", "a"]


def test_a_type_change_replaces_the_processor_and_problems_name_the_field():
    gui = summing_network()
    copy = mirror(None, network_document(gui))
    document = network_document(gui)
    document["processors"][0]["type"] = "Fragile"     # same id, another type
    document["processors"][1]["properties"]["value"] = 1e9
    with pytest.raises(NetworkFileError) as error:
        mirror(copy, document)
    assert "processors[1].properties.value" in str(error.value)
    assert type(copy["a"]).__name__ == "Fragile"


def test_the_server_renders_frames_statuses_and_histograms():
    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    server = RenderServer()
    document, base = network_document(network), str(network.base_dir)
    full = server.handle(RenderJob(1, document, base, plugin_modules(network)))
    assert full.error is None and full.outcome.ran == ["source", "eep", "rc", "canvas"]
    width, height = network.get("canvas.size")
    assert full.outcome.frames["canvas"].shape == (height, width, 4)
    np.testing.assert_array_equal(full.outcome.frames["canvas"],
                                  vgraph.imagefile.to_uint8(network.evaluate("canvas")))
    assert full.statuses["rc"].state == "evaluated"
    assert full.histograms["rc"].sum() == np.prod(server.network["source"].outputs["volume"].data.shape)

    coarse = server.handle(RenderJob(2, document, base, scale=0.25))
    assert coarse.outcome.frames["canvas"].shape == (height // 4, width // 4, 4)
    assert coarse.outcome.ran == ["eep", "rc", "canvas"]             # the volume stays loaded


def test_plugins_are_imported_by_module_and_main_modules_are_refused():
    network = summing_network()
    assert plugin_modules(network) == ("helpers.toy_processors",)
    assert plugin_modules(vgraph.load(REPO / "networks" / "raycast_sphere.json")) == ()
    result = RenderServer().handle(RenderJob(1, network_document(network), plugins=("__main__",)))
    assert "cannot be used by the render process" in result.error
    result = RenderServer().handle(RenderJob(1, network_document(network), plugins=("no_such_module_x",)))
    assert "no_such_module_x" in result.error


def test_a_render_process_that_dies_mid_job_is_reported_and_replaced():
    # A process of its own, so the other tests keep the shared, warm one.
    renderer = RenderProcess()
    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    job = lambda version: RenderJob(version, network_document(network), str(network.base_dir), fresh=True)
    renderer.submit(job(1))
    assert renderer.wait().error is None
    renderer.submit(job(2))                       # loads the volume again and renders: ~0.1 s or more
    os.kill(renderer._process.pid, signal.SIGKILL)
    crashed = renderer.wait()
    assert crashed.version == 2 and "the render process stopped unexpectedly" in crashed.error
    renderer.submit(job(3))
    assert renderer.wait().outcome.frames["canvas"].shape[:2] == (512, 512)   # a new one took over
    renderer.stop()


def test_the_server_reports_warnings_value_scales_and_the_cameras_it_framed(tmp_path):
    """A 1-slice volume ray cast warns (the GUI logs it); a fitting camera's frame is sent back
    (zooming starts from it) with the value scale a TF in data units is edited over."""
    import nrrd
    from vgraph.file_kind import FileKind
    from vgraph.volume_network import volume_network
    nrrd.write(str(tmp_path / "slice.nrrd"), np.arange(48, dtype=np.uint16).reshape(6, 8, 1))
    # ray cast although it is a slice (vgraph.load would show it in a SliceViewer)
    network = volume_network(tmp_path / "slice.nrrd", kind=FileKind("volume", "", ""))
    server = RenderServer()
    result = server.handle(RenderJob(1, network_document(network), str(tmp_path)))
    assert result.error is None
    assert any("one voxel thick" in warning for warning in result.outcome.warnings)
    shown = result.view_cameras["eep.camera"]
    assert not shown.fit_to_data and shown.near is not None and result.view_cameras["rc.camera"] == shown
    assert result.value_scales["rc"].value_range == (0.0, 47.0)


# --- changes instead of documents ---------------------------------------------------------------
def recorder(network) -> list:
    """The changes the GUI would send for the edits made on ``network`` from now on."""
    changes = []
    network.subscribe(lambda event, **details: (change := change_of(network, event, details))
                      and append_change(changes, change))
    return changes


def without_positions(document: dict) -> dict:
    return {**document, "processors": [{k: v for k, v in p.items() if k != "position"}
                                       for p in document["processors"]]}


def test_replayed_changes_give_the_network_a_document_gives():
    gui = summing_network()
    copy = mirror(None, network_document(gui))
    changes = recorder(gui)
    gui.set("b.value", 3.0)
    gui.connect("c.value", "sum.values", index=0)
    gui.add("Number", id="d", value=9.0)
    gui.link("a.value", "d.value", bidirectional=True)
    gui.set("d.value", 5.0)                   # follows the link back to a
    removal = gui.remove("b")
    gui.restore(removal)                      # an undo: b back at its place, with its connection
    gui.disconnect("a.value", "sum.values")
    count = len(changes)
    gui.move("c", (3.0, 4.0))                 # not sent: nothing renders positions
    assert len(changes) == count
    apply_changes(copy, changes)
    assert without_positions(network_document(copy)) == without_positions(network_document(gui))
    assert list(copy.graph.nodes) == list(gui.graph.nodes)
    copy.update()
    assert copy["sum"].outputs["value"] == 4.0 + 3.0


def test_a_slider_drag_sends_its_last_value_but_link_steps_stay_in_order():
    gui = summing_network()
    changes = recorder(gui)
    for value in (1.5, 2.5, 3.5):
        gui.set("a.value", value)
    assert changes == [SetProperty("a.value", 3.5)]
    gui.link("a.value", "b.value")
    gui.set("a.value", 7.0)
    assert [type(c).__name__ for c in changes[1:]] == ["SetProperty", "LinkProperties", "SetProperty", "SetProperty"]


def test_changes_reach_the_server_and_render_what_the_document_renders():
    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    base = str(network.base_dir)
    server = RenderServer()
    assert server.handle(RenderJob(1, network_document(network), base, stamp=("gui", 1))).error is None
    changes = recorder(network)
    network.set("rc.sampling_rate", 1.5)
    network.set("eep.camera", network.get("eep.camera").rotate(20.0, 10.0))
    by_changes = server.handle(RenderJob(2, None, base, changes=tuple(changes), stamp=("gui", 2), since=("gui", 1)))
    assert by_changes.error is None and not by_changes.needs_document
    assert "source" not in by_changes.outcome.ran                  # the volume stayed loaded
    by_document = RenderServer().handle(RenderJob(1, network_document(network), base))
    np.testing.assert_array_equal(by_changes.outcome.frames["canvas"], by_document.outcome.frames["canvas"])


def test_the_server_asks_for_a_document_when_changes_cannot_apply():
    gui = summing_network()
    server = RenderServer()
    change = (SetProperty("a.value", 2.0),)
    assert server.handle(RenderJob(1, None, changes=change)).needs_document          # no network yet
    assert server.handle(RenderJob(2, network_document(gui), stamp=("gui", 2))).error is None
    stale = server.handle(RenderJob(3, None, changes=change, stamp=("gui", 3), since=("other", 7)))
    assert stale.needs_document and server.network is not None   # another sender's changes: untouched
    failing = server.handle(RenderJob(3, None, changes=(SetProperty("zz.value", 1.0),),
                                      stamp=("gui", 3), since=("gui", 2)))
    assert failing.needs_document and failing.error is None and server.network is None


# --- coarse first: bricked frames refine job by job -------------------------------------------------
def bricked_network():
    """A 96^3 ball with 16^3 bricks (GivenVolume: built here, not sent as a document) -> Canvas."""
    from vgraph.camera import Camera
    from vgraph.testing import ray_caster_network
    from vgraph.volume import Volume
    z, y, x = np.mgrid[-1:1:96j, -1:1:96j, -1:1:96j]
    volume = Volume(np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1).astype(np.float32))
    camera = Camera.looking_at_box((0, 0, 0), (95, 95, 95), direction=(-0.5, -0.3, -1.0))
    network = ray_caster_network(volume, camera, "BrickedRayCaster", compositing="mip", brick_size=16,
                                 lod_bias=-16.0)
    network.add("Canvas", id="canvas", size=(64, 48))
    network.connect("rc.image", "canvas.image")
    return network


def test_the_server_draws_bricked_frames_coarse_first_and_refines_to_the_scripts_frame():
    """Under a load limit the first frame is coarser and ``refining``; the same state rendered
    again (empty changes) reads more bricks each time and ends at the frame a script renders."""
    from vgraph.bricks.cache import LoadLimit
    from vgraph.imagefile import to_uint8
    script = to_uint8(bricked_network().evaluate("canvas"))
    server = RenderServer()
    server.network = bricked_network()  # as if mirrored (a GivenVolume cannot travel as a document)
    limit = LoadLimit(bricks=40)
    results = [server.handle(RenderJob(1, None, load_limit=limit))]
    rc = server.network["rc"]
    assert results[0].error is None and results[0].refining and results[0].bricks_read == 40
    assert min(rc.last_frame["levels"]) >= 1 and rc.last_frame["planned_floor_level"] == 0
    assert np.abs(results[0].outcome.frames["canvas"].astype(int) - script).max() > 0
    while results[-1].refining and len(results) < 20:
        results.append(server.handle(RenderJob(1, None, load_limit=limit)))
        assert results[-1].outcome.ran == ["rc", "canvas"]      # only the refining frame is drawn again
    assert 3 <= len(results) < 20 and not results[-1].refining and rc.last_frame["complete"]
    assert all(r.bricks_read > 0 for r in results[:-1])           # every incomplete frame read bricks
    np.testing.assert_array_equal(results[-1].outcome.frames["canvas"], script)
    again = server.handle(RenderJob(1, None, load_limit=limit))   # complete: nothing to draw again
    assert not again.refining and "rc" not in again.outcome.ran


def test_jobs_without_a_load_limit_and_writer_runs_draw_the_planned_frame_at_once():
    from vgraph.imagefile import to_uint8
    script = to_uint8(bricked_network().evaluate("canvas"))
    for job in (RenderJob(1, None, load_limit=None), RenderJob(1, None, include_writers=True)):
        server = RenderServer()
        server.network = bricked_network()
        result = server.handle(job)
        assert not result.refining and server.network["rc"].last_frame["complete"]
        np.testing.assert_array_equal(result.outcome.frames["canvas"], script)
