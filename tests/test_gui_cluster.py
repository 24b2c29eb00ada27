"""The GUI's "Render on Cluster" setting: the render process draws final frames through
vgraph.distributed.render with a client it keeps, reports tiles done / total, keeps drags local and
falls back to a local frame (saying so) when the cluster cannot be reached."""

import numpy as np
import pytest

import vgraph
from vgraph.errors import VGraphError
from vgraph.fileformat import network_document
from vgraph.live.cluster import ClusterSetting
from vgraph.live.render_messages import RenderJob, RenderProgress
from vgraph.live.render_server import RenderServer

from helpers.paths import REPO

SPHERE = REPO / "networks" / "raycast_sphere.json"
SIZE = (64, 48)


@pytest.fixture(scope="module")
def scheduler():
    """The address of a LocalCluster of two single-threaded worker processes (started once)."""
    import warnings

    from distributed import LocalCluster
    with warnings.catch_warnings():  # another cluster on this machine holds the HTTP port: harmless
        warnings.filterwarnings("ignore", message="Port 8787 is already in use", category=UserWarning)
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=None)
    with cluster:
        yield cluster.scheduler_address


def sphere_job(version=1, **options) -> RenderJob:
    network = vgraph.load(SPHERE)
    network.set("canvas.size", SIZE)
    return RenderJob(version, network_document(network), str(SPHERE.parent), fresh=True, **options)


def test_server_on_a_cluster_draws_the_local_frame_with_progress_and_keeps_drags_local(scheduler):
    local = RenderServer().handle(sphere_job())
    server = RenderServer()
    reports = []
    server.progress = reports.append
    setting = ClusterSetting(scheduler, "tiles", (2, 2))
    try:
        result = server.handle(sphere_job(cluster=setting))
        assert result.error is None and not result.outcome.failed, result.outcome.failed
        frame, reference = result.outcome.frames["canvas"], local.outcome.frames["canvas"]
        assert frame.shape == reference.shape == (SIZE[1], SIZE[0], 4)
        assert np.abs(frame.astype(int) - reference.astype(int)).max() <= 1  # float32 rounding
        assert reports and all(isinstance(r, RenderProgress) and r.total == 4 for r in reports)
        assert reports[-1].done == 4
        assert result.statuses["rc"].text.startswith("on cluster")
        assert result.histograms  # the source ran here: the transfer-function editor has its data
        client = server.cluster.client
        assert client is not None and server.cluster.workers == 2

        reports.clear()  # a drag: coarse, here, and the client stays open for the next final frame
        drag = server.handle(RenderJob(2, None, str(SPHERE.parent), scale=0.25, cluster=setting,
                                       changes=(), since=None))
        assert drag.error is None and drag.outcome.frames["canvas"].shape[:2] == (12, 16)
        assert not reports and server.cluster.client is client

        server.handle(RenderJob(3, None, str(SPHERE.parent), cluster=None, changes=(), since=None))
        assert server.cluster.client is None  # the setting cleared: closed
    finally:
        server.close()


def test_unreachable_cluster_falls_back_to_a_local_frame_and_says_so():
    local = RenderServer().handle(sphere_job())
    server = RenderServer()
    result = server.handle(sphere_job(cluster=ClusterSetting("tcp://127.0.0.1:9")))
    assert result.error is None
    assert any("cannot render on cluster tcp://127.0.0.1:9" in w and "rendered locally" in w
               for w in result.outcome.warnings), result.outcome.warnings
    assert np.array_equal(result.outcome.frames["canvas"], local.outcome.frames["canvas"])
    again = server.handle(RenderJob(2, None, str(SPHERE.parent), changes=(), since=None,
                                    cluster=ClusterSetting("tcp://127.0.0.1:9")))
    assert not again.outcome.warnings  # not asked again at once, nor reported for every frame
    server.close()


def test_setting_is_parsed_stored_and_refused_with_a_reason(tmp_path):
    from PySide6.QtCore import QSettings
    from vgraph.gui.cluster_dialog import load_setting, parse_setting, save_setting
    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)
    assert load_setting(settings) is None
    save_setting(settings, parse_setting("local:2", "tiles", "3x1"))
    assert load_setting(settings) == ClusterSetting("local:2", "tiles", (3, 1))
    save_setting(settings, None)
    assert load_setting(settings) is None
    with pytest.raises(VGraphError, match="expected local:N"):
        parse_setting("localhost")
    with pytest.raises(VGraphError, match="COLUMNSxROWS"):
        parse_setting("local:2", "tiles", "four")


def test_window_with_the_cluster_setting_shows_a_frame_drawn_there(window, scheduler, qtbot):
    network = vgraph.load(SPHERE)
    network.set("canvas.size", SIZE)
    path = window.workspace.settings.fileName().rsplit("/", 1)[0] + "/sphere.json"
    network.save(path)
    window.workspace.open(path)
    messages = []
    window.evaluation.progress.connect(lambda done, total: messages.append((done, total)))
    window.set_cluster(ClusterSetting(scheduler, "tiles", (2, 1)))
    assert window.workspace.settings.value("cluster/address") == scheduler
    # As the window does it: the setting schedules a job, the poller shows progress and the frame.
    qtbot.waitUntil(lambda: window.evaluation.idle() and "rc" in window.evaluation.statuses, timeout=60000)
    outcome = window.evaluation.last_outcome
    assert "canvas" in outcome.frames and not outcome.failed and not outcome.warnings
    assert np.ptp(outcome.frames["canvas"][..., :3]) > 0
    assert window.evaluation.statuses["rc"].text.startswith("on cluster")
    assert messages and messages[-1] == (2, 2)
    assert any("on cluster" in m for m in window.log.messages("info"))
    assert "2/2 tiles" in window.statusBar().currentMessage() or messages[-1] == (2, 2)
    window.set_cluster(None)
    window.evaluation.run(wait=True)
    assert window.evaluation.statuses["rc"].text.startswith("evaluated")


def test_local_setting_starts_its_workers_from_the_render_process_and_closes_them():
    """The render process is a daemon; ``local:N`` still starts N worker processes there."""
    import subprocess

    from vgraph.live.render_process import RenderProcess
    process = RenderProcess()
    try:
        process.submit(sphere_job(cluster=ClusterSetting("local:1", "tiles", (2, 1))))
        result = process.wait(timeout=120)
        assert not result.outcome.warnings and result.statuses["rc"].text.startswith("on cluster")
        assert process.progress is not None and process.progress.done == process.progress.total == 2
        pid = process.pid
        workers = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
        assert workers  # the LocalCluster's worker process
    finally:
        process.stop()  # the render process closes its cluster on the way out
    assert all(subprocess.run(["kill", "-0", w], capture_output=True).returncode != 0 for w in workers)
