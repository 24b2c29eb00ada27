"""The placement steps of bench/bench_gui_session.py: the user saves (Ctrl+S), starts a new network
(Ctrl+N) and double-clicks VolumeSource, EntryExitPoints, RayCaster and Canvas in the processor
palette, one after the other. Each new processor must go below the one before (it takes that one's
data: gui/placement.py) and connect to it (EntryExitPoints' entry and exit both into the RayCaster),
else the session fails; the wait is from the double-click to the new node in the editor."""

from __future__ import annotations

import time

from PySide6.QtCore import QPointF, Qt

from gui_session_log import Wait

CHAIN = ("VolumeSource", "EntryExitPoints", "RayCaster", "Canvas")
PORTS = {"EntryExitPoints": {("volume", "volume")}, "RayCaster": {("entry", "entry"), ("exit", "exit")},
         "Canvas": {("image", "image")}}   # (the one before's outport, the new one's inport)


def placement_steps(window, user, waits: list[Wait]):
    view = window.view
    yield from user.click(view.viewport(), QPointF(8, 8))
    yield from user.keys(view.viewport(), "ctrl+s")   # no "save changes?" question on Ctrl+N
    yield lambda: window.workspace.undo_stack.isClean()
    yield from user.keys(view.viewport(), "ctrl+n")
    yield lambda: not window.workspace.network.processors
    added: list[str] = []
    for type_name in CHAIN:
        mark = time.monotonic()
        new = yield from _double_click(window, user, type_name)
        seconds = round(time.monotonic() - mark, 3)
        if new not in window.scene.nodes:
            raise RuntimeError(f"{new} is in the network but not in the editor")
        detail = _check_place(window.workspace.network, added[-1] if added else None, new, type_name)
        waits.append(Wait(f"double-click {type_name}", "placed" + (" and connected" if added else ""),
                          seconds, detail))
        added.append(new)


def _double_click(window, user, type_name: str):
    """Double-click ``type_name`` in the palette; the new processor's id."""
    tree = window.palette.tree
    item = tree.findItems(type_name, Qt.MatchExactly | Qt.MatchRecursive, 0)[0]
    tree.scrollToItem(item)
    before = set(window.workspace.network.processors)
    yield from user.double_click(tree.viewport(), QPointF(tree.visualItemRect(item).center()))
    yield lambda: len(window.workspace.network.processors) > len(before)
    return (set(window.workspace.network.processors) - before).pop()


def _check_place(network, previous: str | None, new: str, type_name: str) -> str:
    """Where ``new`` went and what connects it, after ``previous``; fails the session if it is not
    below ``previous`` or not connected to it as PORTS says."""
    if previous is None:
        return f"at {tuple(round(c) for c in network[new].position)}"
    (x0, y0), (x, y) = network[previous].position, network[new].position
    if not (y > y0 and abs(x - x0) < 1):
        raise RuntimeError(f"{new} went to {(x, y)}, not below {previous} at {(x0, y0)}")
    pairs = {(c.outport, c.inport) for c in network.connections
             if c.source == previous and c.target == new}
    if pairs != PORTS[type_name]:
        raise RuntimeError(f"{new} is connected to {previous} by {sorted(pairs)}, not {sorted(PORTS[type_name])}")
    return f"below {previous} ({y - y0:.0f} px lower), connected " + ", ".join(f"{a}->{b}" for a, b in sorted(pairs))
