"""The render process's copy of the GUI's network, kept in step with version-1 documents.

``mirror(network, document, base_dir)`` changes ``network`` as little as needed to match the
document: processors whose id and type are unchanged are kept (with their uploaded textures,
compiled shaders and cached outputs); only properties whose values differ are set, so only what
they invalidate runs again. A slider drag therefore costs one re-render, not a reload of the volume.
The difference is a sequence of edits (``vgraph.edits``, ``document_edits``), the vocabulary of the
undo stack and of the changes the GUI sends: processors, connections and links that are gone are
removed before new ones are added.

Conventions:
- ``None`` as the network builds a fresh one (``fileformat.build_network``).
- The connections into one inport keep the document's order (it matters for multiple inports).
- Errors are those of building a network from a file: ``NetworkFileError`` naming each problem.
"""

from __future__ import annotations

from collections.abc import Iterator

from vgraph.edits import (AddProcessor, Connect, Disconnect, Edit, LinkProperties, MoveProcessors,
                          RemoveProcessor, SetProperty, UnlinkProperties)
from vgraph.errors import NetworkFileError, VGraphError
from vgraph.fileformat import build_network, parse_document
from vgraph.network import Connection, Link, Network, split_address


def mirror(network: Network | None, document: dict, base_dir=None, file: str = "<gui>") -> Network:
    parsed = parse_document(document, file)
    if network is None:
        return build_network(parsed, file, base_dir)
    network.base_dir = base_dir
    network.description = parsed.description
    problems: list[tuple[str, str]] = []
    for where, edit in document_edits(network, parsed):
        try:
            edit.apply(network)
        except VGraphError as error:
            problems.append((where, getattr(error, "reason", str(error)) if isinstance(edit, SetProperty)
                             else str(error)))
    if problems:
        raise NetworkFileError(file, problems)
    return network


def document_edits(network: Network, parsed) -> Iterator[tuple[str, Edit]]:
    """The edits that turn ``network`` into the parsed document, each with the document's field it
    comes from. Each is worked out from the network as the edits before it left it, so they must be
    applied as they come (one that fails is skipped, and what depends on it is not asked for)."""
    wanted = {entry.id: entry for entry in parsed.processors}
    for pid in [pid for pid, p in network.processors.items()
                if pid not in wanted or wanted[pid].type != p.type_name]:
        yield f"processors.{pid}", RemoveProcessor(pid)
    yield from _stale_links(network, parsed.links)
    yield from _stale_connections(network, parsed.connections)
    for i, entry in enumerate(parsed.processors):
        if entry.id not in network:
            yield f"processors[{i}].type", AddProcessor(entry.id, entry.type, None, {}, tuple(entry.position))
            if entry.id not in network:   # an unknown type: nothing more to say about it
                continue
        processor = network[entry.id]
        if tuple(processor.position) != tuple(map(float, entry.position)):
            yield f"processors[{i}].position", MoveProcessors({entry.id: tuple(entry.position)})
        for name, value in entry.properties.items():
            prop = processor.properties.get(name)
            if prop is None or prop.to_json(processor.property_values[name]) != value:
                yield f"processors[{i}].properties.{name}", SetProperty(f"{entry.id}.{name}", value)
    yield from _missing(network, parsed)


def _connection(entry) -> Connection:
    (source, outport), (target, inport) = split_address(entry.source), split_address(entry.target)
    return Connection(source, outport, target, inport)


def _stale_connections(network: Network, entries) -> Iterator[tuple[str, Edit]]:
    wanted = [_connection(e) for e in entries]
    for connection in network.connections:
        into_same_inport = [c for c in wanted if (c.target, c.inport) == (connection.target, connection.inport)]
        present = network.inputs_of(connection.target, connection.inport)
        if connection not in wanted or present != into_same_inport[:len(present)]:
            yield f"connections.{connection}", Disconnect(connection)


def _stale_links(network: Network, entries) -> Iterator[tuple[str, Edit]]:
    wanted = {(e.source, e.target, e.bidirectional) for e in entries}
    for link in list(network.links):
        if (link.source, link.target, link.bidirectional) not in wanted:
            yield f"links.{link.source}", UnlinkProperties(link.source, link.target)


def _missing(network: Network, parsed) -> Iterator[tuple[str, Edit]]:
    present = set(network.connections)
    for i, entry in enumerate(parsed.connections):
        connection = _connection(entry)
        if connection not in present:
            yield f"connections[{i}]", Connect(connection)
    linked = {(l.source, l.target) for l in network.links}
    for i, entry in enumerate(parsed.links):
        if (entry.source, entry.target) not in linked:
            yield f"links[{i}]", LinkProperties(Link(entry.source, entry.target, entry.bidirectional))
