"""Demand-driven evaluation: only what the targets need, only what is invalid."""

import pytest

import vgraph
from vgraph import Network, ProcessorError


@pytest.fixture
def net():
    """a -> sum -> fragile -> out, with b feeding sum; x and y form a branch nobody asks for."""
    network = Network()
    for pid in ("a", "b", "x"):
        network.add("Number", id=pid)
    network.add("Sum", id="sum")
    network.add("Fragile", id="fragile")
    network.add("Collect", id="out")
    network.add("Collect", id="y")
    network.connect("a.value", "sum.values")
    network.connect("b.value", "sum.values")
    network.connect("sum.value", "fragile.value")
    network.connect("fragile.value", "out.value")
    network.connect("x.value", "y.value")
    return network


def counts(network):
    return {pid: p.evaluation_count for pid, p in network.processors.items()}


def test_only_ancestors_of_the_target_run_in_topological_order(net):
    report = net.update("out")
    assert report.ids[-2:] == ["fragile", "out"] and set(report.ids[:3]) == {"a", "b", "sum"}
    assert report.ids.index("sum") == 2
    assert net["x"].evaluation_count == 0 and not net["x"].initialized
    assert net["y"].evaluation_count == 0


def test_a_port_target_stops_at_that_port(net):
    assert sorted(net.update("sum.value").ids) == ["a", "b", "sum"]
    assert net.output("sum.value") == 2.0


def test_a_property_change_reruns_only_it_and_downstream(net):
    net.update("out")
    before = counts(net)
    net.set("b.value", 5.0)
    report = net.update("out")
    assert report.ids == ["b", "sum", "fragile", "out"]
    after = counts(net)
    assert after["a"] == before["a"] and after["x"] == before["x"] == 0
    assert net.output("out") == 6.0
    assert net.update("out").ids == []  # nothing changed, nothing runs


def test_setting_the_same_value_invalidates_nothing(net):
    net.update("out")
    net.set("a.value", 1.0)
    assert net.update("out").ids == []


def test_initialize_once_and_process_again_after_every_change(net):
    net.update("out")
    a = net["a"]
    assert (a.initialize_count, a.process_count) == (1, 1)
    net.set("a.value", 4.0)
    net.update("out")
    net.set("a.mode", "fancy")
    net.update("out")
    assert (a.initialize_count, a.process_count) == (1, 3)
    net.update("out")
    assert a.process_count == 3  # nothing changed: nothing runs


def test_default_targets_are_all_sinks(net):
    assert set(net.update().ids) == {"a", "b", "sum", "fragile", "out", "x", "y"}


def test_a_failing_processor_is_named_and_the_network_recovers(net):
    net.set("fragile.fail", 1)
    with pytest.raises(ProcessorError, match=r"processor 'fragile' \(Fragile\): ZeroDivisionError: deliberate failure") as caught:
        net.update("out")
    assert caught.value.internal
    assert net["fragile"].last_error.startswith("ZeroDivisionError")
    assert net.last_evaluation.ids == ["a", "b", "sum"]  # what ran before the failure is recorded
    net.set("fragile.fail", 0)
    assert net.update("out").ids == ["fragile", "out"]
    assert net.output("out") == 2.0 and net["fragile"].last_error is None


def test_unconnected_required_inport_is_reported(net):
    net.disconnect("sum.value", "fragile.value")
    with pytest.raises(ProcessorError, match=r"'fragile' \(Fragile\): inport 'value' \(float\) is not connected"):
        net.update("out")


def test_wrong_output_type_is_reported():
    class Liar(vgraph.Processor):
        outports = [vgraph.Outport("value", float)]

        def process(self):
            return "not a number"

    network = Network()
    network.add(Liar, id="liar")
    with pytest.raises(ProcessorError, match="returned str for outport 'value', which carries float"):
        network.update("liar.value")


def test_every_evaluation_records_times(net):
    report = net.update("out")
    assert all(r.seconds >= 0 for r in report.evaluated)
    assert report.total_seconds >= sum(r.seconds for r in report.evaluated) * 0.5
    assert report.to_json()["evaluated"][0].keys() == {"id", "type", "seconds"}


def test_the_report_of_a_failed_evaluation_names_the_failure_and_what_ran_before(net):
    net.set("fragile.fail", 1)
    with pytest.raises(ProcessorError):
        net.update("out")
    report = net.last_evaluation
    assert report.ids == ["a", "b", "sum"]
    failed = report.failed
    assert (failed.id, failed.type, failed.error) == ("fragile", "Fragile", "ZeroDivisionError: deliberate failure")
    assert 0 <= failed.seconds <= report.total_seconds
    assert report.to_json()["failed"] == {"id": "fragile", "type": "Fragile", "seconds": failed.seconds,
                                          "error": "ZeroDivisionError: deliberate failure"}
    net.set("fragile.fail", 0)
    assert net.update("out").failed is None and net.last_evaluation.to_json()["failed"] is None


def test_an_unconnected_inport_is_recorded_as_the_failure(net):
    net.disconnect("sum.value", "fragile.value")
    with pytest.raises(ProcessorError):
        net.update("out")
    assert net.last_evaluation.failed.error == "inport 'value' (float) is not connected"


def test_target_type_is_known_before_evaluating(net):
    from vgraph.image import Image
    from vgraph.scheduler import target_type
    assert target_type(net, "sum.value") is float and target_type(net, "out") is float
    image_net = Network()
    image_net.add("Canvas", id="canvas")
    assert target_type(image_net, "canvas") is Image
    with pytest.raises(vgraph.VGraphError, match="has no outport 'nope'"):
        target_type(net, "sum.nope")


# --- on-demand outports: computed only when something reads them -----------------------------------
@pytest.fixture
def powers():
    network = Network()
    network.add("Number", id="a", value=3.0)
    network.add("Powers", id="p")
    network.add("Collect", id="out")
    network.connect("a.value", "p.value")
    network.connect("p.value", "out.value")
    return network


def test_an_on_demand_outport_is_left_out_when_nothing_reads_it(powers):
    powers.update("out")
    assert powers["p"].squared is False and powers.output("p.square") is None


def test_an_on_demand_outport_asked_for_reruns_its_processor_once(powers):
    powers.update("out")
    assert powers.update("p.square").ids == ["p"] and powers.output("p.square") == 9.0
    assert powers.update("p.square").ids == [] and powers.update("out").ids == []  # still valid


def test_a_connection_reading_an_on_demand_outport_makes_it_computed(powers):
    powers.add("Collect", id="squares")
    powers.connect("p.square", "squares.value")
    powers.update("squares")
    assert powers["p"].squared and powers["squares"].inputs["value"] == 9.0
    powers.update("out")  # does not read the square: p keeps its outputs, nothing reruns
    assert powers["p"].squared and powers.update("squares").ids == []
