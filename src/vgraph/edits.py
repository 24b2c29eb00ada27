"""One vocabulary for an edit of a Network: small frozen records that apply themselves and give
their inverse.

The GUI's undo stack wraps them (redo applies the edit, undo applies its inverse), the render
process replays them on its copy of the network (the edits the GUI's network reported, gathered per
job), and a document reaches the render process's network as the edits that turn it into the
document (``vgraph.live.mirror``). One edit is one of:

    SetProperty, MoveProcessors, AddProcessor, RemoveProcessor, Connect, Disconnect,
    LinkProperties, UnlinkProperties

Conventions:
- Property values are held in their JSON form (``Property.to_json``) and validated again when
  applied, exactly as a document's values are: an edit pickles without the processor's objects,
  and an edit and a document give the same network.
- Orders matter (the scheduler's order, a ``multiple`` inport's inputs, the file's order), so a
  structural edit carries its index in its order; ``None`` means "at the end".
- What only the inverse needs (the value a set replaced, what a removal took out) is read from the
  network *before* the edit by the ``of(...)`` constructors. An edit read from a network event
  (``edit_of_event``, after the fact) carries what applying it needs but not always its inverse;
  ``inverse()`` then raises ``NotInvertible`` rather than guess.
- ``apply`` goes through the network's public methods, so the network's events and refusals (a
  VGraphError that changes nothing) are those of a direct call.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, replace
from typing import Any

from vgraph.errors import VGraphError
from vgraph.network import Connection, Link, Network, split_address
from vgraph.processor import Processor
from vgraph.registry import registry


class NotInvertible(VGraphError):
    """The edit does not carry what undoing it needs (it was read from an event, after the fact)."""


class _Unknown(enum.Enum):
    UNKNOWN = "unknown"   # an enum member: it pickles as itself, so ``is UNKNOWN`` holds across processes


UNKNOWN = _Unknown.UNKNOWN  # a value the edit was not told (no JSON value, None included, is this)


def _known(value, edit, what: str):
    if value is UNKNOWN:
        raise NotInvertible(f"{edit} cannot be undone: it does not say {what}")
    return value


def json_value(network: Network, address: str):
    """The JSON form of the value of 'id.property' (PropertyError when there is no such property)."""
    value = network.get(address)
    processor_id, name = split_address(address, "property")
    return network[processor_id].properties[name].to_json(value)


# --- properties and positions --------------------------------------------------------------------
@dataclass(frozen=True)
class SetProperty:
    address: str        # 'id.property'
    value: Any          # the new value, JSON form
    old: Any = UNKNOWN  # the value it replaces, JSON form

    @classmethod
    def of(cls, network: Network, address: str, value) -> SetProperty:
        """Set ``address`` to ``value`` (any form the property accepts), remembering the old value."""
        old = json_value(network, address)
        processor_id, name = split_address(address, "property")
        prop = network[processor_id].properties[name]
        return cls(address, prop.to_json(prop.validate(value, address, network.base_dir)), old)

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Set {self.address}"

    def apply(self, network: Network) -> None:
        network.set(self.address, self.value)

    def inverse(self) -> SetProperty:
        return SetProperty(self.address, _known(self.old, self, "the value it replaced"), self.value)


@dataclass(frozen=True)
class MoveProcessors:
    """Node positions in the editor (nothing renders them, so the render process is not sent them)."""
    positions: dict[str, tuple[float, float]]
    old: dict[str, tuple[float, float]] = field(default_factory=dict)

    @classmethod
    def of(cls, network: Network, positions: dict) -> MoveProcessors:
        return cls({pid: tuple(map(float, xy)) for pid, xy in positions.items()},
                   {pid: tuple(network[pid].position) for pid in positions})

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Move {', '.join(self.positions)}"

    def apply(self, network: Network) -> None:
        for pid, xy in self.positions.items():
            network.move(pid, xy)

    def inverse(self) -> MoveProcessors:
        if set(self.old) != set(self.positions):
            raise NotInvertible(f"{self} cannot be undone: it does not say where the processors were")
        return MoveProcessors(self.old, self.positions)


# --- processors ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class AddProcessor:
    """A processor of ``type`` with these property values, at ``index`` in the processor order; with
    the connections and links given (each at its index), as the inverse of a removal puts back."""
    id: str
    type: str
    index: int | None
    properties: dict[str, Any]                     # name -> JSON value
    position: tuple[float, float] = (0.0, 0.0)
    connections: tuple[tuple[int, Connection], ...] = ()
    links: tuple[tuple[int, Link], ...] = ()

    @classmethod
    def of(cls, processor: Processor, index: int | None = None) -> AddProcessor:
        """Add (a copy of) ``processor``, not yet in a network: its type, values and position."""
        values = {name: prop.to_json(processor.property_values[name])
                  for name, prop in processor.properties.items()}
        return cls(processor.id, processor.type_name, index, values, tuple(map(float, processor.position)))

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Add {self.id} ({self.type})"

    def apply(self, network: Network) -> None:
        processor = registry.get(self.type)(id=self.id)
        for name, value in self.properties.items():
            processor.set_property(name, value, network.base_dir)
        processor.position = self.position
        network.insert(len(network.processors) if self.index is None else self.index, processor)
        for index, connection in self.connections:  # ascending indices: each lands where it was
            network.connect(*connection.ends, index=index)
        for index, link in self.links:
            network.link(link.source, link.target, link.bidirectional, index=index)

    def inverse(self) -> RemoveProcessor:
        return RemoveProcessor(self.id, was=self)


@dataclass(frozen=True)
class RemoveProcessor:
    """Remove a processor with its connections and links; ``was`` puts all of them back."""
    id: str
    was: AddProcessor | None = None

    @classmethod
    def of(cls, network: Network, processor_id: str) -> RemoveProcessor:
        processor = network[processor_id]
        was = replace(AddProcessor.of(processor, list(network.processors).index(processor_id)),
                      connections=tuple((i, c) for i, c in enumerate(network.connections)
                                        if processor_id in (c.source, c.target)),
                      links=tuple((i, l) for i, l in enumerate(network.links) if l.touches(processor_id)))
        return cls(processor_id, was)

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Remove {self.id} ({self.was.type})" if self.was else f"Remove {self.id}"

    def apply(self, network: Network) -> None:
        network.remove(self.id)

    def inverse(self) -> AddProcessor:
        if self.was is None:
            raise NotInvertible(f"{self} cannot be undone: it does not say what was removed")
        return self.was


# --- connections ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Connect:
    connection: Connection
    index: int | None = None   # in the connection order (and so in the inport's inputs)

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Connect {self.connection}"

    def apply(self, network: Network) -> None:
        network.connect(*self.connection.ends, index=self.index)

    def inverse(self) -> Disconnect:
        return Disconnect(self.connection, self.index)


@dataclass(frozen=True)
class Disconnect:
    connection: Connection
    index: int | None = UNKNOWN  # where it was in the connection order (None: last)

    @classmethod
    def of(cls, network: Network, connection: Connection) -> Disconnect:
        order = network.connections
        return cls(connection, order.index(connection) if connection in order else UNKNOWN)

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Disconnect {self.connection}"

    def apply(self, network: Network) -> None:
        network.disconnect(self.connection)

    def inverse(self) -> Connect:
        return Connect(self.connection, _known(self.index, self, "where the connection was"))


# --- links ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LinkProperties:
    """Link two properties; the follower takes the leader's value at once, so undoing it puts the
    follower's own value back (``follower_before``)."""
    link: Link
    index: int | None = None
    follower_before: Any = UNKNOWN   # JSON form

    @classmethod
    def of(cls, network: Network, source: str, target: str, bidirectional: bool = False) -> LinkProperties:
        return cls(Link(source, target, bidirectional), None, json_value(network, target))

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Link {self.link.source} {'<->' if self.link.bidirectional else '->'} {self.link.target}"

    def apply(self, network: Network) -> None:
        network.link(self.link.source, self.link.target, self.link.bidirectional, index=self.index)

    def inverse(self) -> UnlinkProperties:
        return UnlinkProperties(self.link.source, self.link.target,
                                relink=LinkProperties(self.link, self.index),
                                follower_after=self.follower_before)


@dataclass(frozen=True)
class UnlinkProperties:
    source: str
    target: str
    relink: LinkProperties | None = None      # what puts the link back (its direction and index)
    follower_after: Any = UNKNOWN   # a value to give the follower once unlinked (JSON form)

    @classmethod
    def of(cls, network: Network, link: Link) -> UnlinkProperties:
        order = network.links
        relink = LinkProperties(link, order.index(link)) if link in order else None
        return cls(link.source, link.target, relink)

    def describe(self) -> str:
        """What Edit > Undo names it."""
        return f"Unlink {self.source} -> {self.target}"

    def apply(self, network: Network) -> None:
        network.unlink(self.source, self.target)
        if self.follower_after is not UNKNOWN:
            network.set(self.target, self.follower_after)

    def inverse(self) -> LinkProperties:
        if self.relink is None:
            raise NotInvertible(f"{self} cannot be undone: it does not say how the properties were linked")
        return self.relink


Edit = (SetProperty | MoveProcessors | AddProcessor | RemoveProcessor | Connect | Disconnect | LinkProperties
        | UnlinkProperties)


def edit_of_event(network: Network, event: str, details: dict) -> Edit | None:
    """The edit a network event reports, read from ``network`` as it is right after the event
    (None for events that edit nothing: evaluations). Replaying them in the order of the events on
    a copy gives it the network that sent them."""
    if event == "property_changed":
        processor, name = details["processor"], details["name"]
        value = processor.properties[name].to_json(processor.property_values[name])
        return SetProperty(f"{processor.id}.{name}", value)
    if event == "moved":
        return MoveProcessors({details["processor"].id: details["position"]})
    if event == "processor_added":
        processor = details["processor"]
        return AddProcessor.of(processor, list(network.processors).index(processor.id))
    if event == "processor_removed":
        return RemoveProcessor(details["processor"].id)
    if event == "connected":
        return Connect(details["connection"], network.connections.index(details["connection"]))
    if event == "disconnected":
        return Disconnect(details["connection"])
    if event == "linked":
        return LinkProperties(details["link"], network.links.index(details["link"]))
    if event == "unlinked":
        return UnlinkProperties(details["source"], details["target"])
    return None
