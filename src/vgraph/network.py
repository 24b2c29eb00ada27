"""The network: processors (unique ids), typed connections and property links.

The model keeps three orders, because the file format keeps them and a ``multiple`` inport gives
its inputs to ``process()`` in connection order: the processors' order, the connections' order and
the links' order. Every edit has an ordered form (``insert``, ``connect(..., index=)``,
``link(..., index=)``) and ``remove`` returns a ``Removal`` that ``restore`` puts back exactly, so
an undo can restore the network without reaching inside it.

Edits validate before they change anything. A changed property invalidates its processor and
everything downstream; links carry the value to the properties that follow it. Listeners (the GUI)
are told of every change as ``callback(event, **details)``: processor_added, processor_removed,
connected, disconnected, linked, unlinked, property_changed, moved, and evaluated (the scheduler).

Questions about the graph alone (descendants, the scheduler's order) are answered once per shape
of the graph (``graph_query``): a camera drag asks them every frame, and networkx on graph views
costs far more than the answer.

Evaluation and saving are not the model's business: ``update``, ``output``, ``evaluate``, ``pick``,
``save`` and ``_repr_png_`` come from ``vgraph.network_services.ServiceMethods``, which forwards them
to the services the vgraph package binds, so this module imports neither the scheduler nor the file
format.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Callable, Mapping

import networkx as nx

from vgraph.errors import CycleError, PortError, PropertyError, VGraphError
from vgraph.network_services import ServiceMethods
from vgraph.processor import Processor
from vgraph.properties import Invalidation
from vgraph.registry import registry


@dataclass(frozen=True)
class Connection:
    source: str
    outport: str
    target: str
    inport: str

    def __str__(self) -> str:
        return f"{self.source}.{self.outport} -> {self.target}.{self.inport}"

    @property
    def ends(self) -> tuple[str, str]:
        """('source.outport', 'target.inport'): the arguments of ``Network.connect``."""
        return f"{self.source}.{self.outport}", f"{self.target}.{self.inport}"


@dataclass(frozen=True)
class Link:
    source: str  # "id.property"
    target: str
    bidirectional: bool = False

    def touches(self, processor_id: str) -> bool:
        return processor_id in (self.source.split(".")[0], self.target.split(".")[0])


@dataclass(frozen=True)
class Removal:
    """What ``Network.remove`` took out, each part with its index in its order at that time."""
    processor: Processor
    index: int
    connections: tuple[tuple[int, Connection], ...]
    links: tuple[tuple[int, Link], ...]


def split_address(address: str, what: str = "port") -> tuple[str, str]:
    """'id.name' -> ('id', 'name')."""
    owner, dot, name = str(address).rpartition(".")
    if not dot or not owner or not name:
        raise VGraphError(f"'{address}' is not a {what} address of the form ID.NAME")
    return owner, name


def _checked_index(index: int | None, length: int) -> int:
    """An insertion index (None: at the end); out-of-range indices are refused, not clamped,
    because a wrong index means the caller's record no longer fits the network."""
    if index is None:
        return length
    if not 0 <= index <= length:
        raise VGraphError(f"index {index} is outside 0..{length}")
    return index


class Network(ServiceMethods):
    def __init__(self, base_dir: str | Path | None = None):
        self.graph = nx.MultiDiGraph()  # for the scheduler's graph queries; edges keyed (outport, inport)
        self._processors: dict[str, Processor] = {}
        self._connections: list[Connection] = []
        self._links: list[Link] = []
        self._listeners: list[Callable] = []
        self.base_dir = Path(base_dir) if base_dir is not None else None
        self.description = ""
        # Keyframe tracks (vgraph.tracks.Track), saved with the network; only the timeline reads them
        self.tracks: tuple = ()
        self.last_evaluation = None  # an EvaluationReport, set by the scheduler
        # Where the writer paths read from a file may write, re-checked as they write
        # (vgraph.write_paths.Confinement); None: a network built in Python, not from a file
        self.write_confinement = None
        self._graph_answers: dict = {}  # graph_query's answers, dropped whenever the graph changes

    @property
    def processors(self) -> Mapping[str, Processor]:
        """The processors by id, in order (read-only: edit through add/insert/remove)."""
        return MappingProxyType(self._processors)

    @property
    def connections(self) -> list[Connection]:
        """All connections in their order (a copy)."""
        return list(self._connections)

    @property
    def links(self) -> list[Link]:
        """All property links in their order (a copy)."""
        return list(self._links)

    # --- processors -----------------------------------------------------------------------------
    def add(self, processor: str | type[Processor] | Processor, id: str | None = None,
            **properties) -> Processor:
        """Add a processor by type name, class or instance, with property values, at the end."""
        if isinstance(processor, str):
            processor = registry.get(processor)
        if isinstance(processor, type):
            processor = processor(id=id or self._free_id(processor.type_name), **properties)
        elif properties or id:
            raise VGraphError("pass properties and id when adding by type, not with an instance")
        return self.insert(len(self._processors), processor)

    def insert(self, index: int, processor: Processor) -> Processor:
        """Add a processor instance at ``index`` in the processor order."""
        index = _checked_index(index, len(self._processors))
        if "." in processor.id or not processor.id:
            raise VGraphError(f"processor id '{processor.id}' must be non-empty and contain no '.'")
        if processor.id in self._processors:
            raise VGraphError(f"a processor with id '{processor.id}' already exists")
        processor.network = self
        if index == len(self._processors):
            self._processors[processor.id] = processor
            self.graph.add_node(processor.id)
            self._graph_answers.clear()
        else:
            items = list(self._processors.items())
            items.insert(index, (processor.id, processor))
            self._processors = dict(items)
            self._rebuild_graph()
        self._emit("processor_added", processor=processor)
        return processor

    def remove(self, processor_id: str) -> Removal:
        """Remove a processor with its connections and links; ``restore`` puts all back."""
        processor = self[processor_id]
        removal = Removal(processor, list(self._processors).index(processor_id),
                          tuple((i, c) for i, c in enumerate(self._connections)
                                if processor_id in (c.source, c.target)),
                          tuple((i, l) for i, l in enumerate(self._links) if l.touches(processor_id)))
        for _, connection in removal.connections:
            self.disconnect(connection)
        for _, link in removal.links:
            self.unlink(link.source, link.target)
        self.graph.remove_node(processor_id)
        self._graph_answers.clear()
        del self._processors[processor_id]
        processor.network = None
        self._emit("processor_removed", processor=processor)
        return removal

    def restore(self, removal: Removal) -> Processor:
        """Undo a ``remove``: the processor, its connections and its links at their old places
        (in ascending index order, so each lands where it was)."""
        self.insert(removal.index, removal.processor)
        for index, connection in removal.connections:
            self.connect(*connection.ends, index=index)
        for index, link in removal.links:
            self.link(link.source, link.target, link.bidirectional, index=index)
        return removal.processor

    def move(self, processor_id: str, position: tuple[float, float]) -> None:
        """Place a processor in the editor; emits ``moved`` when the position changes."""
        x, y = (float(v) for v in position)
        if not (math.isfinite(x) and math.isfinite(y)):
            raise VGraphError(f"position of '{processor_id}' must be finite, got {position!r}")
        processor = self[processor_id]
        if tuple(processor.position) != (x, y):
            processor.position = (x, y)
            self._emit("moved", processor=processor, position=(x, y))

    def __getitem__(self, processor_id: str) -> Processor:
        try:
            return self._processors[processor_id]
        except KeyError:
            known = ", ".join(self._processors) or "none"
            raise VGraphError(f"no processor with id '{processor_id}' (ids: {known})") from None

    def __contains__(self, processor_id: str) -> bool:
        return processor_id in self._processors

    def _free_id(self, type_name: str) -> str:
        stem = type_name[0].lower() + type_name[1:]
        return next(f"{stem}{i or ''}" for i in itertools.count() if f"{stem}{i or ''}" not in self._processors)

    def _rebuild_graph(self) -> None:
        """networkx orders nodes and edges by insertion and topological sorts follow that order:
        after an insertion in the middle (an undo) the graph follows the model's orders again, so
        the scheduler runs independent processors in the order it did before."""
        graph = nx.MultiDiGraph()
        graph.add_nodes_from(self._processors)
        graph.add_edges_from((c.source, c.target, (c.outport, c.inport)) for c in self._connections)
        self.graph = graph
        self._graph_answers.clear()

    def graph_query(self, key, compute: Callable[[], object]):
        """``compute()``, an answer that depends on the graph (processors, connections) alone,
        kept under ``key`` until the graph changes. Answers are shared: return immutable ones."""
        try:
            return self._graph_answers[key]
        except KeyError:
            answer = self._graph_answers[key] = compute()
            return answer

    # --- connections ----------------------------------------------------------------------------
    def connect(self, source: str, target: str, index: int | None = None) -> Connection:
        """Connect outport 'a.out' to inport 'b.in', at ``index`` in the connection order (default:
        last); refused (nothing changes) when the ports are unknown, their data types
        incompatible, a single inport is taken, or a cycle would close."""
        src_id, out_name = split_address(source)
        dst_id, in_name = split_address(target)
        connection = Connection(src_id, out_name, dst_id, in_name)
        self.check_connection(connection)
        index = _checked_index(index, len(self._connections))
        self._connections.insert(index, connection)
        if index == len(self._connections) - 1:
            self.graph.add_edge(src_id, dst_id, key=(out_name, in_name))
            self._graph_answers.clear()
        else:
            self._rebuild_graph()
        self.invalidate_downstream(dst_id)
        self._emit("connected", connection=connection)
        return connection

    def check_connection(self, c: Connection, replacing: bool = False) -> None:
        """Raises why ``c`` cannot be made; ``replacing``: a taken single inport is no reason
        (the caller disconnects it first; the cycle test does not depend on that connection)."""
        outport = self[c.source].outport(c.outport)
        if outport is None:
            raise PortError(f"{c.source} ({self[c.source].type_name}) has no outport '{c.outport}' "
                            f"(outports: {', '.join(p.name for p in self[c.source].outports) or 'none'})")
        inport = self[c.target].inport(c.inport)
        if inport is None:
            raise PortError(f"{c.target} ({self[c.target].type_name}) has no inport '{c.inport}' "
                            f"(inports: {', '.join(p.name for p in self[c.target].inports) or 'none'})")
        if not inport.accepts(outport):
            raise PortError(f"cannot connect {c}: {c.source}.{c.outport} carries {outport.type_name} "
                            f"but {c.target}.{c.inport} takes {inport.type_name}")
        if c in self._connections:
            raise PortError(f"{c} is already connected")
        taken = self.inputs_of(c.target, c.inport)
        if taken and not inport.multiple and not replacing:
            raise PortError(f"inport {c.target}.{c.inport} is already connected to {taken[0].source}."
                            f"{taken[0].outport}; disconnect it first")
        if c.source == c.target or nx.has_path(self.graph, c.target, c.source):
            raise CycleError(f"connecting {c} would create a cycle")

    def disconnect(self, connection: Connection | str, target: str | None = None) -> None:
        if not isinstance(connection, Connection):
            (src, out), (dst, inp) = split_address(connection), split_address(target)
            connection = Connection(src, out, dst, inp)
        if connection not in self._connections:
            raise PortError(f"{connection} is not connected")
        self._connections.remove(connection)
        self.graph.remove_edge(connection.source, connection.target, key=(connection.outport, connection.inport))
        self._graph_answers.clear()
        self.invalidate_downstream(connection.target)
        self._emit("disconnected", connection=connection)

    def inputs_of(self, processor_id: str, inport: str) -> list[Connection]:
        """The connections into one inport, in connection order."""
        return [c for c in self._connections if (c.target, c.inport) == (processor_id, inport)]

    def connections_of(self, processor_id: str) -> list[Connection]:
        return [c for c in self._connections if processor_id in (c.source, c.target)]

    # --- properties and links -------------------------------------------------------------------
    def set(self, address: str, value) -> None:
        """Set 'id.property' (validated; follows links; invalidates downstream)."""
        processor_id, name = split_address(address, "property")
        self[processor_id].set_property(name, value)

    def get(self, address: str):
        self._property(address)  # names the processor's properties if this one does not exist
        processor_id, name = split_address(address, "property")
        return self[processor_id].property_values[name]

    def link(self, source: str, target: str, bidirectional: bool = False, index: int | None = None) -> Link:
        """Make ``target`` follow ``source`` (and the other way round if bidirectional), at
        ``index`` in the link order (default: last). The target takes the source's value at once."""
        src_prop, dst_prop = self._property(source), self._property(target)
        if type(src_prop) is not type(dst_prop):
            raise PropertyError(target, f"cannot link a {src_prop.kind} property ({source}) to a "
                                        f"{dst_prop.kind} property")
        if source == target or any({l.source, l.target} == {source, target} for l in self._links):
            raise PropertyError(target, f"{source} and {target} are already linked (or the same)")
        index = _checked_index(index, len(self._links))
        link = Link(source, target, bidirectional)
        self.set(target, self.get(source))
        self._links.insert(index, link)
        self._emit("linked", link=link)
        return link

    def unlink(self, source: str, target: str) -> None:
        found = [l for l in self._links if (l.source, l.target) == (source, target)]
        if not found:
            raise PropertyError(target, f"no link from {source} to {target}")
        self._links.remove(found[0])
        self._emit("unlinked", source=source, target=target)

    def _property(self, address: str):
        processor_id, name = split_address(address, "property")
        processor = self[processor_id]
        if name not in processor.properties:
            known = ", ".join(processor.properties) or "none"
            raise PropertyError(address, f"{processor.type_name} has no property '{name}' (its properties: {known})")
        return processor.properties[name]

    def property_changed(self, processor: Processor, name: str) -> None:
        """Called by a processor after one of its properties took a new value."""
        processor.invalidate(processor.properties[name].invalidates)
        self.invalidate_downstream(processor.id)
        self._emit("property_changed", processor=processor, name=name)
        address = f"{processor.id}.{name}"
        value = processor.property_values[name]
        for link in list(self._links):
            follower = link.target if link.source == address else \
                link.source if link.bidirectional and link.target == address else None
            if follower is not None and self.get(follower) != value:
                self.set(follower, value)  # the follower's own change carries it further

    def invalidate_downstream(self, processor_id: str, level: Invalidation = Invalidation.OUTPUT) -> None:
        downstream = self.graph_query(("downstream", processor_id),
                                      lambda: (processor_id, *nx.descendants(self.graph, processor_id)))
        for pid in downstream:
            self._processors[pid].invalidate(level)

    def sinks(self) -> list[Processor]:
        return [p for p in self._processors.values() if not p.outports]

    # --- listeners ------------------------------------------------------------------------------
    def subscribe(self, callback: Callable) -> None:
        self._listeners.append(callback)

    def unsubscribe(self, callback: Callable) -> None:
        """Stop telling ``callback``; nothing happens if it was not subscribed (a view may detach
        both when its network is replaced and when its window closes)."""
        if callback in self._listeners:
            self._listeners.remove(callback)

    def processor_evaluated(self, processor: Processor) -> None:
        """Tell the listeners that ``processor`` ran (or failed: its last_error says); the
        evaluator calls this, so views can show times and errors without knowing the scheduler."""
        self._emit("evaluated", processor=processor)

    def _emit(self, event: str, **details) -> None:
        for callback in list(self._listeners):
            callback(event, **details)
