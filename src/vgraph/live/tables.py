"""The tables the network's processors output, sent from the render process to the window (its
Tables dock, vgraph.gui.table_dock; docs/guide/measuring.md, "The Tables dock").

Conventions:
- ``table_outputs``: 'id.port' -> the Table of every table outport of a processor that ran and is
  up to date (no error, not invalidated since): the window holds no data, so the tables travel.
- A table can be large (a profile of a million samples is 40 MB), and a frame is sent for every
  step of a drag: ``TableSender`` sends a table only when it is a new object (its processor ran
  again), and every job's list of addresses, so the window drops the tables that are gone. It
  forgets what it sent when the window sends its whole network (a new render process, a file
  opened, a resync after an error): the window then gets every table again.
"""

from __future__ import annotations

from vgraph.network import Network
from vgraph.properties import Invalidation
from vgraph.table import Table


def table_outputs(network: Network) -> dict[str, Table]:
    return {f"{pid}.{name}": data for pid, processor in network.processors.items()
            if not processor.last_error and processor.invalid_level == Invalidation.VALID
            for name, data in processor.outputs.items() if isinstance(data, Table)}


class TableSender:
    """What a result carries: the tables new since the last result, and every table's address."""

    def __init__(self):
        self.sent: dict[str, Table] = {}

    def forget(self) -> None:
        self.sent = {}

    def changes(self, network: Network) -> tuple[dict[str, Table], tuple[str, ...]]:
        current = table_outputs(network)
        new = {address: table for address, table in current.items() if self.sent.get(address) is not table}
        self.sent = current
        return new, tuple(current)


def merged_tables(held: dict[str, Table], new: dict[str, Table], addresses: tuple[str, ...]) -> dict[str, Table]:
    """The window's side: the tables it holds after a result (``TableSender.changes``)."""
    return {address: new[address] if address in new else held[address]
            for address in addresses if address in new or address in held}
