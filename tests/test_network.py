"""The network model: typed connections, cycles, properties, links, listeners."""

import pytest

import vgraph
from vgraph import CycleError, Network, PortError, PropertyError, VGraphError
from vgraph.image import Image
from vgraph.volume import Volume

from helpers import toy_processors
from helpers.toy_processors import Collect


@pytest.fixture
def net():
    network = Network()
    network.add("Number", id="a", value=2.0)
    network.add("Number", id="b", value=3.0)
    network.add("Sum", id="sum")
    network.add("Collect", id="out")
    network.connect("a.value", "sum.values")
    network.connect("b.value", "sum.values")
    network.connect("sum.value", "out.value")
    return network


def test_multiple_inport_receives_connections_in_order(net):
    net.update()
    assert net.output("out") == 5.0
    assert [c.source for c in net.inputs_of("sum", "values")] == ["a", "b"]


def test_incompatible_data_types_are_refused_and_nothing_changes(net):
    net.add("Text", id="t")
    before = net.connections
    with pytest.raises(PortError, match=r"t.text carries str but sum.offset takes float"):
        net.connect("t.text", "sum.offset")
    assert net.connections == before


def test_builtin_image_and_volume_ports_do_not_mix():
    network = Network()
    network.add("ImageSource", id="src")
    network.add("Canvas", id="canvas")
    network.connect("src.image", "canvas.image")
    assert Image.__name__ == "Image" and Volume.__name__ == "Volume"
    with pytest.raises(PortError, match="already connected"):
        network.connect("src.image", "canvas.image")


def test_subtype_is_accepted_by_its_base_type():
    class SpecialNumber(float):
        pass

    class Special(vgraph.Processor):
        outports = [vgraph.Outport("value", SpecialNumber)]

        def process(self):
            return SpecialNumber(4.0)

    network = Network()
    network.add(Special, id="s")
    network.add(Collect, id="c")
    network.connect("s.value", "c.value")
    network.update()
    assert network.output("c") == 4.0


def test_unknown_ports_name_the_existing_ones(net):
    with pytest.raises(PortError, match=r"a \(Number\) has no outport 'nope' \(outports: value\)"):
        net.connect("a.nope", "sum.offset")
    with pytest.raises(PortError, match=r"has no inport 'nope' \(inports: values, offset\)"):
        net.connect("a.value", "sum.nope")


def test_single_inport_takes_one_connection(net):
    net.add("Number", id="c")
    with pytest.raises(PortError, match="out.value is already connected to sum.value"):
        net.connect("c.value", "out.value")


def test_cycles_are_rejected(net):
    net.add("Sum", id="second")
    net.connect("sum.value", "second.values")
    with pytest.raises(CycleError, match="cycle"):
        net.connect("second.value", "sum.offset")
    with pytest.raises(CycleError):
        net.connect("sum.value", "sum.offset")
    assert len(net.connections) == 4


def test_disconnect_and_remove(net):
    net.disconnect("b.value", "sum.values")
    net.update()
    assert net.output("out") == 2.0
    net.remove("a")
    assert "a" not in net and all("a" not in (c.source, c.target) for c in net.connections)
    with pytest.raises(PortError, match="is not connected"):
        net.disconnect("b.value", "sum.values")


def test_duplicate_and_bad_ids(net):
    with pytest.raises(VGraphError, match="already exists"):
        net.add("Number", id="a")
    with pytest.raises(VGraphError, match="contain no '.'"):
        net.add("Number", id="x.y")
    assert net.add("Number").id == "number"
    assert net.add("Number").id == "number1"


@pytest.mark.parametrize("value, message", [
    (101.0, "less than or equal to 100"),
    ("high", "valid number"),
    (True, "not a boolean"),
    (float("nan"), "finite number"),
])
def test_property_validation_names_processor_and_property(net, value, message):
    with pytest.raises(PropertyError, match=rf"a\.value: invalid value .*{message}"):
        net.set("a.value", value)
    assert net.get("a.value") == 2.0


def test_unknown_property_lists_the_known_ones(net):
    with pytest.raises(PropertyError, match=r"a\.colour: Number has no property 'colour' \(its properties: value, mode\)"):
        net.set("a.colour", 1)


@pytest.mark.parametrize("prop, good, bad", [
    (vgraph.IntProperty(3, min=1, max=5), 4, 2.5),
    (vgraph.IntProperty(26, choices=(6, 18, 26)), 18, 20),
    (vgraph.BoolProperty(False), True, 1),
    (vgraph.OptionProperty("mip", choices=["mip", "dvr"]), "dvr", "iso"),
    (vgraph.ColorProperty((0, 0, 0)), (1, 0.5, 0), (2, 0, 0)),
    (vgraph.VectorProperty((1.0, 2.0, 3.0), min=0.0), [4, 5, 6], [1, 2]),
    (vgraph.TransferFunctionProperty({"points": [[0, 0, 0, 0, 0]]}), {"points": [[0.5, 1, 1, 1, 1]]},
     {"points": [[0.5, 1, 1, 1]]}),
    (vgraph.CameraProperty({}), {"projection": "orthographic"}, {"projection": "fisheye"}),
])
def test_property_kinds_accept_and_reject(prop, good, bad):
    prop.validate(good, "p.x")
    with pytest.raises(PropertyError, match=r"^p\.x: invalid value"):
        prop.validate(bad, "p.x")


def test_links_propagate_one_way(net):
    net.link("a.value", "b.value")
    assert net.get("b.value") == 2.0  # the follower takes the value at once
    net.set("a.value", 7.0)
    assert net.get("b.value") == 7.0
    net.set("b.value", 1.0)
    assert net.get("a.value") == 7.0


def test_links_propagate_both_ways_and_through_chains(net):
    net.add("Number", id="c")
    net.link("a.value", "b.value", bidirectional=True)
    net.link("b.value", "c.value")
    net.set("b.value", 9.0)
    assert (net.get("a.value"), net.get("c.value")) == (9.0, 9.0)
    net.set("a.value", -1.0)
    assert net.get("c.value") == -1.0


def test_links_between_different_kinds_are_refused(net):
    with pytest.raises(PropertyError, match="cannot link a float property"):
        net.link("a.value", "a.mode")


def test_listeners_hear_every_edit(net):
    events = []
    net.subscribe(lambda event, **details: events.append(event))
    net.set("a.value", 4.0)
    net.add("Number", id="z")
    net.connect("z.value", "sum.offset")
    net.remove("z")
    assert events == ["property_changed", "processor_added", "connected", "disconnected",
                      "processor_removed"]


def test_unsubscribe_stops_the_events_and_tolerates_a_second_call(net):
    events = []
    listener = lambda event, **details: events.append(event)  # noqa: E731
    net.subscribe(listener)
    net.set("a.value", 4.0)
    net.unsubscribe(listener)
    net.unsubscribe(listener)          # a view may detach twice (network replaced, window closed)
    net.set("a.value", 5.0)
    assert events == ["property_changed"]


def test_move_emits_moved_once_per_change_and_refuses_nonfinite_positions(net):
    events = []
    net.subscribe(lambda event, **details: events.append((event, details.get("position"))))
    net.move("a", (10, 20))
    net.move("a", (10.0, 20.0))        # no change, no event
    assert events == [("moved", (10.0, 20.0))] and net["a"].position == (10.0, 20.0)
    with pytest.raises(VGraphError, match="finite"):
        net.move("a", (float("nan"), 0.0))


def test_the_processors_mapping_and_the_lists_are_the_models_not_copies_to_edit(net):
    with pytest.raises(TypeError):
        net.processors["x"] = net["a"]  # noqa  (read-only: edits go through add/insert/remove)
    net.links.append("not a link")      # a copy: the network's own list is untouched
    assert net.links == []


def order_of(network):
    """Everything whose order the file format or the scheduler keeps."""
    import networkx as nx
    return (list(network.processors), network.connections, network.links,
            list(nx.topological_sort(network.graph)), {pid: p.position for pid, p in network.processors.items()})


def test_remove_then_restore_puts_processor_connections_and_links_back_at_their_places(net):
    net.add("Number", id="c", value=4.0)
    net.connect("c.value", "sum.values")
    net.connect("b.value", "sum.offset")
    net.link("a.value", "c.value")
    net.link("c.mode", "b.mode", bidirectional=True)
    net.link("a.mode", "b.mode")
    before = order_of(net)
    removal = net.remove("b")
    assert "b" not in net and [c.source for c in net.inputs_of("sum", "values")] == ["a", "c"]
    assert net.links == [vgraph.network.Link("a.value", "c.value")]
    net.restore(removal)
    assert order_of(net) == before
    assert [c.source for c in net.inputs_of("sum", "values")] == ["a", "b", "c"]
    assert net.update().ids == ["a", "b", "c", "sum", "out"] and net.output("out") == 10.0  # 2 + 3 + 2 (c follows a), offset 3


def test_connect_and_link_at_an_index(net):
    net.add("Number", id="c")
    net.connect("c.value", "sum.values", index=0)
    assert [c.source for c in net.inputs_of("sum", "values")] == ["c", "a", "b"]
    assert net.connections[0].source == "c"
    net.link("a.value", "b.value")
    first = net.link("a.mode", "b.mode", index=0)
    assert net.links[0] == first
    with pytest.raises(VGraphError, match="outside"):
        net.connect("c.value", "sum.offset", index=9)
    assert not net.inputs_of("sum", "offset")


def test_insert_places_a_processor_in_the_order(net):
    processor = toy_processors.Number(id="first")
    net.insert(0, processor)
    assert list(net.processors)[:2] == ["first", "a"] and processor.network is net
    assert list(net.graph.nodes)[0] == "first"   # the scheduler's order follows


def test_importing_the_model_imports_neither_the_scheduler_nor_the_file_format():
    import subprocess
    import sys
    code = ("import sys, vgraph.network\n"
            "loaded = [m for m in ('vgraph.scheduler', 'vgraph.fileformat', 'vgraph.services') if m in sys.modules]\n"
            "assert not loaded, loaded\n"
            "net = vgraph.network.Network()\n"
            "net.add('Grayscale', id='g')\n"
            "assert 'vgraph.scheduler' not in sys.modules\n"
            "net.update()\n"                     # the bound services import the scheduler on first use
            "assert 'vgraph.scheduler' in sys.modules\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
