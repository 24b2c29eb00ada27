"""The render process's copy of the GUI's network, kept in step with version-1 documents.

``mirror(network, document, base_dir)`` changes ``network`` as little as needed to match the
document: processors whose id and type are unchanged are kept (with their uploaded textures,
compiled shaders and cached outputs); only properties whose values differ are set, so only what
they invalidate runs again. A slider drag therefore costs one re-render, not a reload of the volume.
Processors, connections and links that are gone are removed before new ones are added.

Conventions:
- ``None`` as the network builds a fresh one (``fileformat.build_network``).
- The connections into one inport keep the document's order (it matters for multiple inports).
- Errors are those of building a network from a file: ``NetworkFileError`` naming each problem.
"""

from __future__ import annotations

from vgraph.errors import NetworkFileError, VGraphError
from vgraph.fileformat import build_network, parse_document
from vgraph.network import Connection, Network, split_address
from vgraph.registry import registry


def mirror(network: Network | None, document: dict, base_dir=None, file: str = "<gui>") -> Network:
    parsed = parse_document(document, file)
    if network is None:
        return build_network(parsed, file, base_dir)
    network.base_dir = base_dir
    network.description = parsed.description
    wanted = {entry.id: entry for entry in parsed.processors}
    for pid in [pid for pid, p in network.processors.items()
                if pid not in wanted or wanted[pid].type != p.type_name]:
        network.remove(pid)
    _remove_stale_links(network, parsed.links)
    _remove_stale_connections(network, parsed.connections)
    problems: list[tuple[str, str]] = []
    for i, entry in enumerate(parsed.processors):
        try:
            processor = network[entry.id] if entry.id in network else network.add(registry.get(entry.type), id=entry.id)
        except VGraphError as error:
            problems.append((f"processors[{i}].type", str(error)))
            continue
        processor.position = entry.position
        for name, value in entry.properties.items():
            prop = processor.properties.get(name)
            if prop is None or prop.to_json(processor.property_values[name]) != value:
                try:
                    processor.set_property(name, value)
                except VGraphError as error:
                    problems.append((f"processors[{i}].properties.{name}", getattr(error, "reason", str(error))))
    _add_missing(network, parsed, problems)
    if problems:
        raise NetworkFileError(file, problems)
    return network


def _connection(entry) -> Connection:
    (source, outport), (target, inport) = split_address(entry.source), split_address(entry.target)
    return Connection(source, outport, target, inport)


def _remove_stale_connections(network: Network, entries) -> None:
    wanted = [_connection(e) for e in entries]
    for connection in network.connections:
        into_same_inport = [c for c in wanted if (c.target, c.inport) == (connection.target, connection.inport)]
        present = network.inputs_of(connection.target, connection.inport)
        if connection not in wanted or present != into_same_inport[:len(present)]:
            network.disconnect(connection)


def _remove_stale_links(network: Network, entries) -> None:
    wanted = {(e.source, e.target, e.bidirectional) for e in entries}
    for link in list(network.links):
        if (link.source, link.target, link.bidirectional) not in wanted:
            network.unlink(link.source, link.target)


def _add_missing(network: Network, parsed, problems: list) -> None:
    present = set(network.connections)
    for i, entry in enumerate(parsed.connections):
        if _connection(entry) not in present:
            try:
                network.connect(entry.source, entry.target)
            except VGraphError as error:
                problems.append((f"connections[{i}]", str(error)))
    linked = {(l.source, l.target) for l in network.links}
    for i, entry in enumerate(parsed.links):
        if (entry.source, entry.target) not in linked:
            try:
                network.link(entry.source, entry.target, bidirectional=entry.bidirectional)
            except VGraphError as error:
                problems.append((f"links[{i}]", str(error)))
