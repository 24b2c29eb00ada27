"""Edits of the GUI's network as small picklable records the render process replays on its copy.

A slider tick used to send the whole network as a document, which the render process parsed with
pydantic and diffed (``mirror``). Now each network event becomes a change: ``change_of(network,
event, details)`` on the GUI's side, ``change.apply(network)`` on the render process's side.
Replaying the changes in the order of the events gives the render process the network the GUI has
(node positions aside: moves are not sent, nothing renders them).

Conventions:
- Property values travel in their JSON form (``Property.to_json``) and are validated again on
  arrival, exactly as a document's values are, so a change and a document give the same network.
- Structural changes carry their index in the order they were made at, taken when the event
  happens, so replaying them in order puts everything at the same place (the scheduler's order
  and a ``multiple`` inport's inputs depend on it).
- A change that cannot be applied raises; the render process then asks for a whole document.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vgraph.network import Connection, Link, Network
from vgraph.registry import registry


@dataclass(frozen=True)
class PropertySet:
    address: str  # 'id.property'
    value: Any    # its JSON form

    def apply(self, network: Network) -> None:
        network.set(self.address, self.value)


@dataclass(frozen=True)
class ProcessorAdded:
    id: str
    type: str
    index: int
    properties: dict  # name -> JSON value

    def apply(self, network: Network) -> None:
        processor = registry.get(self.type)(id=self.id)
        for name, value in self.properties.items():
            processor.set_property(name, value, network.base_dir)
        network.insert(self.index, processor)


@dataclass(frozen=True)
class ProcessorRemoved:
    id: str

    def apply(self, network: Network) -> None:
        network.remove(self.id)


@dataclass(frozen=True)
class Connected:
    connection: Connection
    index: int

    def apply(self, network: Network) -> None:
        network.connect(*self.connection.ends, index=self.index)


@dataclass(frozen=True)
class Disconnected:
    connection: Connection

    def apply(self, network: Network) -> None:
        network.disconnect(self.connection)


@dataclass(frozen=True)
class Linked:
    link: Link
    index: int

    def apply(self, network: Network) -> None:
        network.link(self.link.source, self.link.target, self.link.bidirectional, index=self.index)


@dataclass(frozen=True)
class Unlinked:
    source: str
    target: str

    def apply(self, network: Network) -> None:
        network.unlink(self.source, self.target)


Change = PropertySet | ProcessorAdded | ProcessorRemoved | Connected | Disconnected | Linked | Unlinked


def change_of(network: Network, event: str, details: dict) -> Change | None:
    """The change a network event stands for, read from ``network`` as it is right after the event
    (None for events that change nothing the render process needs: moves, evaluations)."""
    if event == "property_changed":
        processor, name = details["processor"], details["name"]
        value = processor.properties[name].to_json(processor.property_values[name])
        return PropertySet(f"{processor.id}.{name}", value)
    if event == "processor_added":
        processor = details["processor"]
        values = {name: prop.to_json(processor.property_values[name]) for name, prop in processor.properties.items()}
        return ProcessorAdded(processor.id, processor.type_name, list(network.processors).index(processor.id), values)
    if event == "processor_removed":
        return ProcessorRemoved(details["processor"].id)
    if event == "connected":
        return Connected(details["connection"], network.connections.index(details["connection"]))
    if event == "disconnected":
        return Disconnected(details["connection"])
    if event == "linked":
        return Linked(details["link"], network.links.index(details["link"]))
    if event == "unlinked":
        return Unlinked(details["source"], details["target"])
    return None


def append_change(changes: list[Change], change: Change) -> None:
    """Append ``change``; a new value of the property the last change set replaces it (a slider
    drag sends its last value, not every tick's). Only the last one: merging further back could
    reorder a value with the link propagations between them."""
    if isinstance(change, PropertySet) and changes and isinstance(changes[-1], PropertySet) \
            and changes[-1].address == change.address:
        changes[-1] = change
    else:
        changes.append(change)


def apply_changes(network: Network, changes) -> None:
    for change in changes:
        change.apply(network)

