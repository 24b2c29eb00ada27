"""Truthful state (issue 32, item 5): the watchdog compares a frame with the same network's frames
and says what runs."""

import time

from PySide6.QtCore import QSettings

from vgraph.gui.live_evaluation import LiveEvaluation
from vgraph.gui.render_watchdog import STALL_FIRST_SECONDS
from vgraph.gui.workspace import Workspace
from vgraph.live.render_messages import RenderJob, RenderResult
from vgraph.live.render_process import RenderProcess
from vgraph.progress import Progress


class AlivePipe:
    """Stands for the render process and its pipe: answers each job when the test says so."""

    pid = 1

    def __init__(self):
        self.results = []

    def is_alive(self):
        return True

    def send(self, job):
        pass

    def poll(self, timeout=None):
        return bool(self.results)

    def recv(self):
        return self.results.pop(0)


def render_process_with(pipe) -> RenderProcess:
    renderer = RenderProcess()
    renderer._process = renderer._connection = pipe
    return renderer


def answer(renderer, pipe, seconds: float):
    """The job in flight answered after ``seconds``."""
    renderer.job_started -= seconds
    pipe.results.append(RenderResult(version=renderer.job.version))
    return renderer.poll()


def test_frame_times_count_for_their_own_network_only():
    pipe = AlivePipe()
    renderer = render_process_with(pipe)
    for version in (1, 2):                       # the first network: 5 s frames
        renderer.submit(RenderJob(version, None))
        answer(renderer, pipe, 5.0)
    assert 5.0 <= renderer.typical_seconds() < 5.5
    renderer.submit(RenderJob(3, None))          # still rendering the first network ...
    renderer.submit(RenderJob(4, {}, fresh=True))  # ... when another is opened
    assert renderer.typical_seconds() is None    # nothing known of the new network yet
    answer(renderer, pipe, 5.0)                  # the old network's frame: not the new one's history
    assert renderer.typical_seconds() is None
    answer(renderer, pipe, 0.2)
    assert 0.2 <= renderer.typical_seconds() < 0.7


class StandIn:
    """A render process working on one job for ``elapsed_seconds``, with a processor running."""

    pid, progress, in_flight = 7, None, 1

    def __init__(self, typical, running=None):
        self.typical, self.running, self.elapsed_seconds = typical, running, 0.0

    busy = property(lambda self: True)

    def elapsed(self):
        return self.elapsed_seconds

    def typical_seconds(self):
        return self.typical

    def submit(self, job):
        pass

    def poll(self):
        return None

    def died(self):
        return None


def evaluation_with(qtbot, tmp_path, renderer):
    workspace = Workspace(QSettings(str(tmp_path / "s.ini"), QSettings.IniFormat))
    evaluation = LiveEvaluation(workspace, renderer)
    evaluation.watchdog.stop()
    warnings = []
    evaluation.warning.connect(warnings.append)
    return evaluation, warnings


def test_a_first_frame_is_not_called_stuck_by_the_last_networks_frame_times(qtbot, tmp_path):
    """Opening tets_bonsai after raycast_head: a 20 s first frame was 'may be stuck' (the head's
    frames took 0.2 s). With nothing of its own to compare, a first frame gets a minute."""
    renderer = StandIn(typical=None, running=Progress("mesh", "MeshSource", "reading tets_bonsai.vtu"))
    evaluation, warnings = evaluation_with(qtbot, tmp_path, renderer)
    assert evaluation.stall_limit() == STALL_FIRST_SECONDS
    renderer.elapsed_seconds = 20.0
    evaluation.check_renderer()
    assert warnings == []
    renderer.elapsed_seconds = STALL_FIRST_SECONDS + 1
    evaluation.check_renderer()
    assert len(warnings) == 1
    assert "(running mesh (MeshSource): reading tets_bonsai.vtu)" in warnings[0]
    assert "the first frame of this network" in warnings[0]


def test_a_frame_far_slower_than_this_networks_frames_is_reported_with_what_runs(qtbot, tmp_path):
    renderer = StandIn(typical=2.0, running=Progress("rc", "RayCaster", "", 0, 0, time.monotonic()))
    evaluation, warnings = evaluation_with(qtbot, tmp_path, renderer)
    assert evaluation.stall_limit() == 20.0
    renderer.elapsed_seconds = 19.0
    evaluation.check_renderer()
    assert warnings == []
    renderer.elapsed_seconds = 21.0
    evaluation.check_renderer()
    assert "(running rc (RayCaster))" in warnings[0] and "this network's recent frames took 2" in warnings[0]


def test_a_new_volume_source_without_a_file_is_neutral_and_says_it_needs_one(window):
    window.palette.processor_chosen.emit("VolumeSource")
    outcome = window.evaluation.run(wait=True)
    assert "volumeSource" not in outcome.failed
    assert window.log.messages("error") == []
    status = window.scene.nodes["volumeSource"].status
    assert status.state == "not_ready" and status.text == "needs a volume file"
    assert "path" in status.detail


def test_vgraph_run_still_refuses_a_volume_source_without_a_file():
    import pytest
    import vgraph
    from vgraph.errors import VGraphError
    network = vgraph.Network()
    network.add("VolumeSource", id="source")
    with pytest.raises(VGraphError, match="source.path: no volume file chosen"):
        network.evaluate("source")


RAW_FIELDS = ("raw_dims", "raw_dtype", "raw_endianness", "raw_offset")


def test_auto_fields_show_the_values_in_use_and_raw_fields_hide_for_a_nifti_file(window, tmp_path):
    import nibabel
    import numpy as np
    from vgraph.io import read_volume
    path = tmp_path / "small.nii.gz"
    nibabel.save(nibabel.Nifti1Image(np.arange(120, dtype=np.int16).reshape(4, 5, 6),
                                     np.diag([0.5, 0.75, 2.0, 1.0])), path)
    expected = read_volume(path)
    workspace, inspector = window.workspace, window.inspector
    workspace.add_processor("VolumeSource", (0, 0), id="source")
    workspace.set_property("source.path", str(path))
    window.evaluation.run(wait=True)
    window.scene.select_processor("source")
    for name, used in (("spacing", expected.spacing), ("origin", expected.origin),
                       ("value_range", expected.value_range)):
        editor = inspector.editors[name]
        assert editor.auto.isChecked() and not any(spin.isEnabled() for spin in editor.spins)  # greyed
        assert np.allclose([spin.value() for spin in editor.spins], used, atol=1e-4), name
    assert tuple(expected.spacing) != (1.0, 1.0, 1.0)   # not the old placeholder
    for name in RAW_FIELDS + ("memory_budget",):   # a NIfTI file has its header; it is no store
        assert not inspector.form.isRowVisible(inspector.editors[name]), name
    assert inspector.form.isRowVisible(inspector.editors["spacing"])
    # Unchecking auto starts from the value in use, not from 1.
    inspector.editors["spacing"].auto.setChecked(False)
    assert np.allclose(workspace.network.get("source.spacing"), expected.spacing)
    # A headerless raw file needs them: they show again.
    workspace.set_property("source.path", str(tmp_path / "data.raw"))
    for name in RAW_FIELDS:
        assert inspector.form.isRowVisible(inspector.editors[name]), name


def test_an_image_emptied_by_a_clip_plane_or_the_crop_box_says_so_in_the_log(window):
    """The empty-image warning the window logs names the cut that emptied the image, not the
    camera or the value range."""
    from helpers.paths import REPO
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.evaluation.run(wait=True)
    assert window.blank_warnings == {}
    window.workspace.set_property("eep.clip_planes", [{"normal": [1, 0, 0], "point": [500, 0, 0]}])
    window.evaluation.run(wait=True)
    warning = window.blank_warnings["canvas"]
    assert "eep.clip_planes[0] removes every voxel" in warning and "camera" not in warning
    assert any("eep.clip_planes[0]" in message for message in window.log.messages("warning"))
    window.workspace.set_property("eep.clip_planes", [])
    window.workspace.set_property("eep.crop_box", [400, 400, 400, 500, 500, 500])
    window.evaluation.run(wait=True)
    warning = window.blank_warnings["canvas"]
    assert "eep.crop_box holds no voxel" in warning and "camera" not in warning
