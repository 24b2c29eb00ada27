"""vgraph.progress: which processor runs and how far its steps are (issue #17 item 2), as the
scheduler, the readers, the prefilter and the render process's forwarding report it."""

import numpy as np
import pytest

import vgraph
from vgraph import progress
from vgraph.errors import ProcessorError
from vgraph.live.progress_messages import ProcessorProgress, ProgressForwarder
from vgraph.network import Network
from vgraph.progress import Progress, Steps, listening, report
from vgraph.scheduler import evaluate
from vgraph.volume import Volume

from helpers.toy_processors import Collect, Fragile, Number


class Counter(vgraph.Processor):
    """Reports ``steps`` steps of counting and outputs the count."""
    category = "Test"
    outports = [vgraph.Outport("value", float)]
    steps = vgraph.IntProperty(4, min=1, max=100)

    def process(self):
        for step in range(self.steps):
            self.report_progress(step + 1, self.steps, "counting")
        return float(self.steps)


def network_of(*processors, connections=()):
    network = Network()
    for processor in processors:
        network.add(processor)
    for source, target in connections:
        network.connect(source, target)
    return network


def test_nothing_listens_by_default_and_a_report_outside_an_evaluation_is_ignored():
    assert not progress.is_listened() and progress.current() is None
    report(1, 2, "reading")  # a reader called from a script: no processor, no listener, no error
    heard = []
    with listening(heard.append):
        report(1, 2, "reading")  # a listener, but no processor runs: nothing to say whose it is
    assert heard == [] and not progress.is_listened()


def test_the_scheduler_announces_each_processor_and_passes_on_its_steps():
    network = network_of(Counter(id="count", steps=3), Collect(id="sink"),
                         connections=[("count.value", "sink.value")])
    heard: list[Progress] = []
    with listening(heard.append):
        evaluate(network)
    assert [(p.processor, p.type_name, p.what, p.done, p.total) for p in heard] == [
        ("count", "Counter", "", 0, 0),
        ("count", "Counter", "counting", 1, 3), ("count", "Counter", "counting", 2, 3),
        ("count", "Counter", "counting", 3, 3),
        ("sink", "Collect", "", 0, 0)]
    assert [p.fraction for p in heard] == [None, pytest.approx(1 / 3), pytest.approx(2 / 3), 1.0, None]
    assert heard[1].describe() == "count (Counter): counting 33%"
    assert Progress("", "", "histograms").describe() == "histograms"  # work of no processor
    assert heard[0].started == heard[3].started   # one start per processor run
    assert progress.current() is None             # nothing runs after the evaluation


def test_a_failing_processor_leaves_nothing_running():
    network = network_of(Number(id="n"), Fragile(id="f", fail=1), connections=[("n.value", "f.value")])
    heard = []
    with listening(heard.append), pytest.raises(ProcessorError):
        evaluate(network, ["f.value"])
    assert [p.processor for p in heard] == ["n", "f"] and progress.current() is None


def test_steps_count_for_the_listener_whether_or_not_a_terminal_bar_shows():
    heard = []
    with listening(heard.append), progress.running("p", "Test"):
        with Steps(4, "slabs", show=False) as bar:
            bar.update()
            bar.set(3)
        list(progress.steps(range(2), "items", show=False))
    assert [(p.what, p.done, p.total) for p in heard[1:]] == [
        ("slabs", 0, 4), ("slabs", 1, 4), ("slabs", 3, 4), ("items", 0, 2), ("items", 1, 2), ("items", 2, 2)]


def test_a_volume_source_reports_the_bytes_it_reads(tmp_path):
    data = np.arange(40 * 30 * 20, dtype=np.uint16).reshape(20, 30, 40)
    path = tmp_path / "counts.raw"
    data.tofile(path)
    network = Network()
    network.add("VolumeSource", id="src", path=str(path), raw_dims=[40, 30, 20], raw_dtype="uint16")
    heard = []
    with listening(heard.append):
        network.update("src.volume")
    reads = [p for p in heard if p.what == "reading counts.raw"]
    assert reads[0].done == 0 and reads[-1].done == reads[-1].total == data.nbytes
    assert {p.processor for p in heard} == {"src"}
    np.testing.assert_array_equal(network.output("src.volume").data, data)


def test_the_prefilter_reports_its_share_done(tmp_path):
    network = Network()
    volume = Volume(np.random.default_rng(1).random((16, 16, 16), dtype=np.float32))
    from vgraph.testing import GivenVolume
    network.add(GivenVolume(id="src", volume=volume))
    network.add("CubicSplineProcessor", id="spline")
    network.connect("src.volume", "spline.volume")
    heard = []
    with listening(heard.append):
        network.update("spline.volume")
    steps = [p for p in heard if p.processor == "spline" and p.what == "B-spline prefilter"]
    assert steps[0].fraction == 0.0 and steps[-1].fraction == 1.0
    assert [p.done for p in steps] == sorted(p.done for p in steps)  # never backwards


def test_the_forwarder_sends_starts_new_work_and_last_steps_at_once_and_thins_the_rest():
    sent = []
    forward = ProgressForwarder(sent.append, version=7, interval=3600.0)  # no step is due by time
    forward(Progress("a", "A"))
    for done in range(11):
        forward(Progress("a", "A", "reading", done, 10))
    forward(Progress("a", "A", "sorting", 0, 3))
    forward(Progress("b", "B"))
    assert all(isinstance(m, ProcessorProgress) and m.version == 7 for m in sent)
    assert [(m.progress.processor, m.progress.what, m.progress.done) for m in sent] == [
        ("a", "", 0), ("a", "reading", 0), ("a", "reading", 10), ("a", "sorting", 0), ("b", "", 0)]
    every = []
    forward = ProgressForwarder(every.append, version=1, interval=0.0)  # every step is due
    for done in range(4):
        forward(Progress("a", "A", "reading", done, 10))
    assert len(every) == 4


def test_a_compressed_volume_reports_its_decompression(tmp_path):
    import nibabel
    data = np.arange(24 * 20 * 16, dtype=np.int16).reshape(16, 20, 24)
    path = tmp_path / "counts.nii.gz"
    nibabel.save(nibabel.Nifti1Image(data.transpose(2, 1, 0), np.eye(4)), path)
    network = Network()
    network.add("VolumeSource", id="src", path=str(path))
    heard = []
    with listening(heard.append):
        network.update("src.volume")
    steps = [p for p in heard if p.what == "decompressing counts.nii.gz"]
    assert steps and steps[-1].done == steps[-1].total and steps[-1].fraction == 1.0
    np.testing.assert_array_equal(network.output("src.volume").data, data)
