"""Undo and redo of every command restore the network exactly: the processors' order, the
connections' order (and so each inport's), the links, property values, positions and the order
the scheduler would run in. No window: the workspace and its undo stack alone."""

import networkx as nx
import pytest
from PySide6.QtCore import QSettings

from vgraph.fileformat import network_document
from vgraph.gui.workspace import Workspace
from vgraph.network import Connection, Link


@pytest.fixture
def ws(qtbot, tmp_path):
    """a, b, c -> total.values (in that order), total -> out; three links."""
    workspace = Workspace(QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat))
    for i, pid in enumerate("abc"):
        workspace.add_processor("Number", (200.0 * i, 0.0), id=pid)
    workspace.add_processor("Sum", (200.0, 150.0), id="total")
    workspace.add_processor("Collect", (200.0, 300.0), id="out")
    for pid in "abc":
        workspace.connect(f"{pid}.value", "total.values")
    workspace.connect("total.value", "out.value")
    workspace.link("a.value", "b.value")
    workspace.link("b.mode", "c.mode", bidirectional=True)
    workspace.link("a.mode", "c.mode")
    workspace.undo_stack.clear()
    return workspace


def state(network):
    return (network_document(network), list(nx.topological_sort(network.graph)),
            {pid: network.inputs_of(pid, "values") for pid in network.processors})


def check_undo_redo(ws, edit):
    before = state(ws.network)
    edit()
    after = state(ws.network)
    assert after != before
    ws.undo_stack.undo()
    assert state(ws.network) == before
    ws.undo_stack.redo()
    assert state(ws.network) == after
    ws.undo_stack.undo()
    assert state(ws.network) == before


EDITS = {
    "add": lambda ws: ws.add_processor("Number", (5.0, 5.0), id="d"),
    "remove a processor with connections and links": lambda ws: ws.remove(["b"]),
    "remove a selection": lambda ws: ws.remove(["a", "c"], [Connection("total", "value", "out", "value")],
                                               [Link("b.mode", "c.mode", True)]),
    "connect": lambda ws: ws.connect("c.value", "total.offset"),
    "disconnect the middle input": lambda ws: ws.disconnect(Connection("b", "value", "total", "values")),
    "set": lambda ws: ws.set_property("a.value", 7.0),
    "a merged slider drag": lambda ws: [ws.set_property("c.value", v, merge="drag") for v in (2.0, 3.0, 4.0)],
    "move": lambda ws: ws.move({"a": (40.0, 50.0), "total": (1.0, 2.0)}),
    "link": lambda ws: ws.link("a.value", "c.value"),
    "unlink the middle link": lambda ws: ws.unlink(Link("b.mode", "c.mode", True)),
}


@pytest.mark.parametrize("name", EDITS)
def test_undo_and_redo_restore_the_network_exactly(ws, name):
    check_undo_redo(ws, lambda: EDITS[name](ws))


def test_a_long_history_undone_to_the_start_gives_the_first_network(ws):
    start = state(ws.network)
    removals = [name for name in EDITS if name.startswith("remove")]
    for name in [name for name in EDITS if name not in removals] + removals:  # removals last
        EDITS[name](ws)
    while ws.undo_stack.canUndo():
        ws.undo_stack.undo()
    assert state(ws.network) == start


def test_moves_and_their_undo_reach_listeners_as_moved_events(ws):
    events = []
    ws.network.subscribe(lambda event, **details: events.append((event, details["processor"].id, details["position"]))
                         if event == "moved" else None)
    ws.move({"a": (40.0, 50.0)})
    ws.undo_stack.undo()
    ws.undo_stack.redo()
    assert events == [("moved", "a", (40.0, 50.0)), ("moved", "a", (0.0, 0.0)), ("moved", "a", (40.0, 50.0))]
