"""Undo commands: every edit the GUI makes to a Network is one of these.

Conventions:
- Commands act on the Network model only (its public methods); the scene and the inspector follow
  through the network's events, never through the commands.
- ``Workspace.execute`` applies a command once itself (``apply()``, which raises VGraphError and
  changes nothing when the network refuses the edit) and only then pushes it; QUndoStack's first
  ``redo()`` after that push is therefore skipped. So a refused edit never reaches the stack.
- Undo restores what the edit disturbed exactly, including orders that the file format keeps:
  the processors' order, the links' order and the order of connections into a ``multiple`` inport.
- Node positions are ``Processor.position``; the network emits no event for them, so the scene
  re-reads positions whenever the undo stack's index changes.
"""

from __future__ import annotations

import itertools

from PySide6.QtGui import QUndoCommand

from vgraph.network import Connection, Link, Network
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


def _address(processor_id: str, name: str) -> str:
    return f"{processor_id}.{name}"


def restore_inport_order(network: Network, target: str, inport: str, order: list[Connection]) -> None:
    """Put the connections into ``target.inport`` back in their recorded ``order`` (a ``multiple``
    inport gives its inputs to process() in this order). Recorded connections not present now are
    left out: undoing several disconnections restores them one by one."""
    current = network.inputs_of(target, inport)
    wanted = [c for c in order if c in current] + [c for c in current if c not in order]
    if current == wanted:
        return
    for connection in current:
        network.disconnect(connection)
    for c in wanted:
        network.connect(_address(c.source, c.outport), _address(c.target, c.inport))


def restore_link_order(network: Network, order: list[Link]) -> None:
    """Sort the network's links back into a recorded order (links not recorded go last)."""
    rank = {link: i for i, link in enumerate(order)}
    network.links.sort(key=lambda link: rank.get(link, len(rank)))


class AddProcessor(NetworkCommand):
    def __init__(self, network: Network, processor: Processor, parent=None):
        super().__init__(network, f"Add {processor.id} ({processor.type_name})", parent)
        self.processor = processor

    def apply(self):
        self.network.add(self.processor)

    def revert(self):
        self.network.remove(self.processor.id)


class RemoveProcessor(NetworkCommand):
    """Removes a processor; child commands first remove its links and connections, so undo puts
    them back (and the processor keeps its place in the processor order)."""

    def __init__(self, network: Network, processor_id: str, parent=None):
        processor = network[processor_id]
        super().__init__(network, f"Remove {processor_id} ({processor.type_name})", parent)
        self.processor = processor
        self.order = list(network.processors)
        # Kept as plain Python parts (not Qt child commands) so their Python state survives.
        self.parts: list[NetworkCommand] = [
            *(Unlink(network, link) for link in network.links
              if processor_id in (link.source.split(".")[0], link.target.split(".")[0])),
            *(Disconnect(network, c) for c in network.connections_of(processor_id))]

    def apply(self):
        for part in self.parts:
            part.apply()
        self.network.remove(self.processor.id)

    def revert(self):
        self.network.add(self.processor)
        processors = self.network.processors
        reordered = {pid: processors[pid] for pid in self.order if pid in processors}
        reordered |= processors  # anything added since keeps its place after them
        processors.clear()
        processors.update(reordered)
        for part in reversed(self.parts):
            part.revert()


class Connect(NetworkCommand):
    def __init__(self, network: Network, connection: Connection, parent=None):
        super().__init__(network, f"Connect {connection}", parent)
        self.connection = connection

    def apply(self):
        c = self.connection
        self.network.connect(_address(c.source, c.outport), _address(c.target, c.inport))

    def revert(self):
        self.network.disconnect(self.connection)


class Disconnect(NetworkCommand):
    def __init__(self, network: Network, connection: Connection, parent=None):
        super().__init__(network, f"Disconnect {connection}", parent)
        self.connection = connection
        self.inport_order = network.inputs_of(connection.target, connection.inport)

    def apply(self):
        self.network.disconnect(self.connection)

    def revert(self):
        c = self.connection
        self.network.connect(_address(c.source, c.outport), _address(c.target, c.inport))
        restore_inport_order(self.network, c.target, c.inport, self.inport_order)


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
            self.network[pid].position = xy

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
        self.order = list(network.links)

    def apply(self):
        self.network.unlink(self.link.source, self.link.target)

    def revert(self):
        self.network.link(self.link.source, self.link.target, bidirectional=self.link.bidirectional)
        restore_link_order(self.network, self.order)
