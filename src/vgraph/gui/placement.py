"""Editing that follows the data flow (no Qt): where a processor added after another goes, and
which of its inports connect to that one's outports.

Conventions:
- The *anchor* is the processor the new one follows: the selected one, else the last added.
- The new processor connects to the anchor only where that is unambiguous: exactly one pair
  (anchor outport, new inport) whose types fit; or, when several fit, the pairs whose ports have
  the same name (EntryExitPoints' entry and exit into a RayCaster's entry and exit).
- A processor that takes the anchor's data goes below it (data flows downwards); one that does
  not goes to its right (a sibling). The scene then moves it to the nearest free spot.
"""

from __future__ import annotations

from vgraph.network import Connection, Network
from vgraph.processor import Processor

GAP_BELOW = 56.0    # room between a node and the one fed by it: the connection's stubs fit
GAP_RIGHT = 40.0


def matching_connections(network: Network, anchor_id: str, processor: Processor) -> list[Connection]:
    """The connections from ``anchor_id`` into the new ``processor`` that are unambiguous."""
    anchor = network[anchor_id]
    fitting = [(out, inp) for inp in processor.inports for out in anchor.outports if inp.accepts(out)]
    if len(fitting) > 1:
        fitting = [(out, inp) for out, inp in fitting if out.name == inp.name]
    return [Connection(anchor_id, out.name, processor.id, inp.name) for out, inp in fitting]


def feeds(anchor: Processor, cls: type[Processor]) -> bool:
    """Does some outport of ``anchor`` fit some inport of a ``cls`` processor?"""
    return any(inp.accepts(out) for inp in cls.inports for out in anchor.outports)


def spot_after(anchor_position: tuple[float, float], size: tuple[float, float], fed: bool) -> tuple[float, float]:
    """The top-left corner a new node of ``size`` asks for next to the anchor's: below it when it is
    ``fed`` by the anchor, to its right otherwise."""
    x, y = anchor_position
    width, height = size
    return (x, y + height + GAP_BELOW) if fed else (x + width + GAP_RIGHT, y)
