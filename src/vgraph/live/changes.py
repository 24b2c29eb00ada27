"""The edits of the GUI's network that the render process replays on its copy (``vgraph.edits``).

A slider tick used to send the whole network as a document, which the render process parsed with
pydantic and diffed (``mirror``). Now each network event becomes its edit: ``change_of(network,
event, details)`` on the GUI's side, ``apply_changes(network, changes)`` on the render process's
side. Replaying the edits in the order of the events gives the render process the network the GUI
has (node positions aside: moves are not sent, nothing renders them).

Conventions:
- Property values travel in their JSON form and are validated again on arrival, exactly as a
  document's values are, so an edit and a document give the same network.
- Structural edits carry their index in the order they were made at, taken when the event
  happens, so replaying them in order puts everything at the same place (the scheduler's order
  and a ``multiple`` inport's inputs depend on it).
- An edit that cannot be applied raises; the render process then asks for a whole document.
"""

from __future__ import annotations

from vgraph.edits import Edit, MoveProcessors, SetProperty, edit_of_event
from vgraph.network import Network


def change_of(network: Network, event: str, details: dict) -> Edit | None:
    """The edit a network event reports, read from ``network`` right after the event; None for
    events the render process does not need (moves, evaluations)."""
    edit = edit_of_event(network, event, details)
    return None if isinstance(edit, MoveProcessors) else edit


def append_change(changes: list[Edit], change: Edit) -> None:
    """Append ``change``; a new value of the property the last change set replaces it (a slider
    drag sends its last value, not every tick's). Only the last one: merging further back could
    reorder a value with the link propagations between them."""
    if isinstance(change, SetProperty) and changes and isinstance(changes[-1], SetProperty) \
            and changes[-1].address == change.address:
        changes[-1] = change
    else:
        changes.append(change)


def apply_changes(network: Network, changes) -> None:
    for change in changes:
        change.apply(network)
