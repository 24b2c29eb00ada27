"""The edit records (vgraph.edits) that undo, the render process and the document diff share: each
applies itself through the network's methods, its inverse puts back exactly what it disturbed
(the orders included), an edit read from an event replays the event on a copy, and every edit
travels as a pickle. No Qt: the GUI's undo stack is tests/test_gui_undo.py."""

import pickle

import networkx as nx
import pytest

from vgraph.edits import (UNKNOWN, AddProcessor, Connect, Disconnect, LinkProperties, MoveProcessors,
                          NotInvertible, RemoveProcessor, SetProperty, UnlinkProperties, edit_of_event)
from vgraph.errors import PortError, PropertyError
from vgraph.fileformat import network_document, parse_document
from vgraph.live.mirror import document_edits
from vgraph.network import Connection, Link, Network


def wired() -> Network:
    """a, b, c -> total.values (in that order), total -> out; three links."""
    network = Network()
    for i, pid in enumerate("abc"):
        network.add("Number", id=pid, value=float(i + 1))
        network.move(pid, (200.0 * i, 0.0))
    network.add("Sum", id="total")
    network.add("Collect", id="out")
    for pid in "abc":
        network.connect(f"{pid}.value", "total.values")
    network.connect("total.value", "out.value")
    network.link("a.value", "b.value")
    network.link("b.mode", "c.mode", bidirectional=True)
    network.link("a.mode", "c.mode")
    return network


def state(network):
    return (network_document(network), list(nx.topological_sort(network.graph)),
            [c.source for c in network.inputs_of("total", "values")])


EDITS = {
    "set": lambda n: SetProperty.of(n, "c.value", 7.5),
    "move": lambda n: MoveProcessors.of(n, {"a": (40.0, 50.0), "total": (1.0, 2.0)}),
    "add": lambda n: AddProcessor("d", "Number", 1, {"value": 9.0, "mode": "x"}, (5.0, 6.0)),
    "remove with connections and links": lambda n: RemoveProcessor.of(n, "b"),
    "connect": lambda n: Connect(Connection("c", "value", "total", "offset")),
    "connect as the first input": lambda n: Connect(Connection("a", "value", "total", "offset"), 0),
    "disconnect the middle input": lambda n: Disconnect.of(n, Connection("b", "value", "total", "values")),
    "link": lambda n: LinkProperties.of(n, "a.value", "c.value"),
    "unlink the middle link": lambda n: UnlinkProperties.of(n, Link("b.mode", "c.mode", True)),
}


@pytest.mark.parametrize("name", EDITS)
def test_an_edit_and_its_inverse_restore_the_network_exactly(name):
    network = wired()
    before = state(network)
    edit = EDITS[name](network)
    edit.apply(network)
    after = state(network)
    assert after != before
    edit.inverse().apply(network)
    assert state(network) == before
    edit.apply(network)                       # redo
    assert state(network) == after
    assert pickle.loads(pickle.dumps(edit)) == edit   # what the render process receives


def test_the_inverse_of_a_link_gives_the_follower_its_own_value_back():
    network = wired()
    link = LinkProperties.of(network, "a.value", "c.value")
    link.apply(network)
    assert network.get("c.value") == 1.0
    link.inverse().apply(network)
    assert network.get("c.value") == 3.0 and Link("a.value", "c.value") not in network.links


def test_a_refused_edit_changes_nothing_and_names_the_reason():
    network = wired()
    before = state(network)
    with pytest.raises(PortError, match="already connected"):
        Connect(Connection("a", "value", "total", "values")).apply(network)
    with pytest.raises(PropertyError, match="no property 'speed'"):
        SetProperty.of(network, "a.speed", 1.0)
    with pytest.raises(PropertyError, match="a.value"):
        SetProperty("a.value", 1e9).apply(network)
    assert state(network) == before


def replayed(changes_made) -> tuple[Network, list]:
    """A copy of a wired network and the edits its original reported for ``changes_made``."""
    original, copy = wired(), wired()
    edits = []
    original.subscribe(lambda event, **details: edits.append(edit_of_event(original, event, details)))
    changes_made(original)
    for edit in edits:
        if edit is not None:
            edit.apply(copy)
    assert state(copy) == state(original)
    return copy, edits


def test_edits_read_from_events_replay_them_on_a_copy():
    def session(network):
        network.set("b.value", 3.0)
        network.connect("c.value", "total.offset", index=0)
        network.add("Number", id="d", value=9.0)
        network.link("a.value", "d.value", bidirectional=True)
        network.set("d.value", 5.0)          # follows the link back to a (and on to b)
        network.restore(network.remove("b"))  # b back at its place, with its connection and links
        network.disconnect("a.value", "total.values")
        network.move("c", (3.0, 4.0))
    _, edits = replayed(session)
    assert {type(e).__name__ for e in edits if e} >= {"SetProperty", "Connect", "AddProcessor",
                                                      "LinkProperties", "RemoveProcessor",
                                                      "UnlinkProperties", "Disconnect", "MoveProcessors"}


def test_an_edit_read_from_an_event_says_when_it_cannot_be_undone():
    _, edits = replayed(lambda network: (network.set("a.value", 4.0), network.remove("out")))
    setting = next(e for e in edits if isinstance(e, SetProperty))
    assert setting.old is UNKNOWN
    with pytest.raises(NotInvertible, match="does not say the value it replaced"):
        setting.inverse()
    removal = next(e for e in edits if isinstance(e, RemoveProcessor))
    with pytest.raises(NotInvertible, match="does not say what was removed"):
        removal.inverse()


def test_the_mirror_turns_a_document_into_the_edits_that_make_it():
    gui, copy = wired(), wired()
    gui.set("b.value", 3.0)        # b follows a, not the other way round: b alone changes
    gui.remove("c")
    gui.add("Number", id="d")
    gui.move("a", (7.0, 8.0))
    gui.disconnect("a.value", "total.values")
    gui.connect("a.value", "total.values")   # now b, then a
    kept = copy["a"]
    edits = []
    for _, edit in document_edits(copy, parse_document(network_document(gui), "<test>")):
        edit.apply(copy)
        edits.append(edit)
    assert network_document(copy) == network_document(gui) and copy["a"] is kept
    assert edits[0] == RemoveProcessor("c")   # what is gone goes first
    assert SetProperty("b.value", 3.0) in edits and MoveProcessors({"a": (7.0, 8.0)}) in edits
    assert [c.source for c in copy.inputs_of("total", "values")] == ["b", "a"]
