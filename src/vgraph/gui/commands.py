"""Undo commands: every edit the GUI makes to a Network is one of these.

Conventions:
- Commands act on the Network model only (its public methods); the scene and the inspector follow
  through the network's events, never through the commands.
- ``Workspace.execute`` applies a command once itself (``apply()``, which raises VGraphError and
  changes nothing when the network refuses the edit) and only then pushes it; QUndoStack's first
  ``redo()`` after that push is therefore skipped. So a refused edit never reaches the stack.
- Undo restores what the edit disturbed exactly, including the orders the file format keeps (the
  processors', the connections' and with them each inport's, the links'), through the network's
  ordered operations: ``restore`` of a ``remove``, ``connect``/``link`` at an index.
- Node positions change through ``Network.move``, which emits ``moved`` for the scene.
"""

from __future__ import annotations

import itertools

from PySide6.QtGui import QUndoCommand

from vgraph.network import Connection, Link, Network, Removal
from vgraph.processor import Processor

MERGE_PROPERTY_EDITS = 1001  # QUndoCommand.id() of property edits that merge (slider drags)


def free_id(network: Network, type_name: str) -> str:
    """'rayCaster', 'rayCaster1', ... : the first id not taken."""
    stem = type_name[0].lower() + type_name[1:]
    return next(f"{stem}{i or ''}" for i in itertools.count() if f"{stem}{i or ''}" not in network)


class NetworkCommand(QUndoCommand):
    """Base: ``apply``/``revert`` do the work; redo/undo add the skip-once logic."""

    def __init__(self, network: Network, text: str, parent: QUndoCommand | None = None):
        super().__init__(text, parent)
        self.network = network
        self._skip_redo = False

    def apply(self) -> None:
        raise NotImplementedError

    def revert(self) -> None:
        raise NotImplementedError

    def applied_once(self) -> None:
        """Mark the command as already applied (by Workspace.execute) before it is pushed."""
        self._skip_redo = True

    def redo(self) -> None:
        if self._skip_redo:
            self._skip_redo = False
            return
        self.apply()

    def undo(self) -> None:
        self.revert()


class AddProcessor(NetworkCommand):
    def __init__(self, network: Network, processor: Processor, parent=None):
        super().__init__(network, f"Add {processor.id} ({processor.type_name})", parent)
        self.processor = processor

    def apply(self):
        self.network.add(self.processor)

    def revert(self):
        self.network.remove(self.processor.id)


class RemoveProcessor(NetworkCommand):
    """Removes a processor with its connections and links; undo puts all of them back at their
    places (``Network.restore``)."""

    def __init__(self, network: Network, processor_id: str, parent=None):
        processor = network[processor_id]
        super().__init__(network, f"Remove {processor_id} ({processor.type_name})", parent)
        self.processor_id = processor_id
        self.removal: Removal | None = None

    def apply(self):
        self.removal = self.network.remove(self.processor_id)

    def revert(self):
        self.network.restore(self.removal)


class Connect(NetworkCommand):
    def __init__(self, network: Network, connection: Connection, parent=None):
        super().__init__(network, f"Connect {connection}", parent)
        self.connection = connection

    def apply(self):
        self.network.connect(*self.connection.ends)

    def revert(self):
        self.network.disconnect(self.connection)


class Disconnect(NetworkCommand):
    """Undo reconnects at the old place in the connection order, which is also the old place in
    the inport's list (a ``multiple`` inport gives its inputs to process() in that order)."""

    def __init__(self, network: Network, connection: Connection, parent=None):
        super().__init__(network, f"Disconnect {connection}", parent)
        self.connection = connection
        self.index: int | None = None

    def apply(self):
        order = self.network.connections
        self.network.disconnect(self.connection)  # refused (nothing recorded) when not connected
        self.index = order.index(self.connection)

    def revert(self):
        self.network.connect(*self.connection.ends, index=self.index)


class SetProperty(NetworkCommand):
    """Sets 'id.property'. Consecutive edits of one property with the same ``merge`` key (one
    slider drag) become one undo step; ``merge=None`` never merges."""

    def __init__(self, network: Network, address: str, value, merge=None, parent=None):
        super().__init__(network, f"Set {address}", parent)
        self.address = address
        self.old = network.get(address)
        self.new = value
        self.merge = merge

    def apply(self):
        self.network.set(self.address, self.new)

    def revert(self):
        self.network.set(self.address, self.old)

    def id(self) -> int:
        return MERGE_PROPERTY_EDITS if self.merge is not None else -1

    def mergeWith(self, other: QUndoCommand) -> bool:
        if not isinstance(other, SetProperty) or other.merge is None or other.merge != self.merge \
                or other.address != self.address:
            return False
        self.new = other.new
        return True


class MoveProcessors(NetworkCommand):
    def __init__(self, network: Network, positions: dict[str, tuple[float, float]], parent=None):
        names = ", ".join(positions)
        super().__init__(network, f"Move {names}", parent)
        self.new = {pid: tuple(map(float, xy)) for pid, xy in positions.items()}
        self.old = {pid: tuple(network[pid].position) for pid in positions}

    def _place(self, positions):
        for pid, xy in positions.items():
            self.network.move(pid, xy)

    def apply(self):
        self._place(self.new)

    def revert(self):
        self._place(self.old)


class LinkProperties(NetworkCommand):
    """Links two properties; the follower takes the leader's value, so undo restores its own."""

    def __init__(self, network: Network, source: str, target: str, bidirectional: bool = False,
                 parent=None):
        arrow = "<->" if bidirectional else "->"
        super().__init__(network, f"Link {source} {arrow} {target}", parent)
        self.source, self.target, self.bidirectional = source, target, bidirectional
        self.old_target_value = network.get(target)

    def apply(self):
        self.network.link(self.source, self.target, bidirectional=self.bidirectional)

    def revert(self):
        self.network.unlink(self.source, self.target)
        self.network.set(self.target, self.old_target_value)


class Unlink(NetworkCommand):
    def __init__(self, network: Network, link: Link, parent=None):
        super().__init__(network, f"Unlink {link.source} -> {link.target}", parent)
        self.link = link
        self.index: int | None = None

    def apply(self):
        order = self.network.links
        self.network.unlink(self.link.source, self.link.target)  # refused when not linked
        self.index = order.index(self.link)

    def revert(self):
        self.network.link(self.link.source, self.link.target, self.link.bidirectional, index=self.index)
