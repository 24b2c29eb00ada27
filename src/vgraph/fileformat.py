"""The .json network format: pydantic models, version migrations, load and atomic save.

    {"format": "vgraph-network", "version": 3, "description": "...",
     "processors": [{"id": "src", "type": "FunctionSelector", "properties": {...}, "position": [x, y]}],
     "connections": [{"from": "src.volume", "to": "spline.volume"}],
     "links": [{"from": "eep.camera", "to": "rc.camera", "bidirectional": false}],
     "tracks": [{"property": "rc.camera", "keyframes": [{"time": 0, "value": {...}}, ...]}]}

Loading either returns a complete Network or raises NetworkFileError listing every problem with
its JSON path (``processors[2].properties.iso_level``) and reason; it never changes an existing network.
Older versions are upgraded by the chain in ``MIGRATIONS`` before validation; a migration refuses
fields it does not know, so a mislabelled file is an error rather than an empty network, and a
value given under both its old and its new name, which it could only carry over by dropping one.
A property a file leaves out takes the processor's default; where a version changed a default,
the migration to it writes the old default into older files (``DEFAULTS_BEFORE_VERSION_3``), so
they keep rendering as they did. Saving writes every property's value.

A file is read only if it is a regular file of at most ``MAX_FILE_BYTES`` nested at most
``MAX_NESTING`` deep. Writer paths (``FilePathProperty(writes=True)``) from a file must resolve inside
the file's folder or a folder given in ``allow_write`` (``WritePathError`` otherwise): a network
received from someone else cannot overwrite the user's files.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Annotated, Any, Callable, Literal

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, ValidationError

from vgraph.atomic import write_text_atomic
from vgraph.errors import NetworkFileError, VGraphError
from vgraph.file_names import expanded
from vgraph.json_limits import MAX_NESTING, nesting_depth
from vgraph.mesh_network import is_mesh_path, mesh_network
from vgraph.network import Network
from vgraph.properties import FilePathProperty
from vgraph.registry import registry
from vgraph.tracks import TrackEntry, tracks_from_json, tracks_to_json
from vgraph.volume_network import is_volume_path, volume_network
from vgraph.write_paths import check_write_paths

FORMAT = "vgraph-network"
CURRENT_VERSION = 3
MAX_FILE_BYTES = 64 * 2**20   # the largest shipped network is a few kB

ProcessorId = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")]
Address = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*\.[a-z][a-z0-9_]*$")]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class ProcessorEntry(_Strict):
    id: ProcessorId
    type: str
    properties: dict[str, Any] = {}
    position: tuple[Annotated[float, Field(allow_inf_nan=False)], Annotated[float, Field(allow_inf_nan=False)]] = (0.0, 0.0)


class ConnectionEntry(_Strict):
    source: Address = Field(alias="from")
    target: Address = Field(alias="to")


class LinkEntry(ConnectionEntry):
    bidirectional: bool = False


class NetworkDocument(_Strict):
    format: Literal["vgraph-network"]
    version: Literal[3]
    description: str = ""
    processors: list[ProcessorEntry] = []
    connections: list[ConnectionEntry] = []
    links: list[LinkEntry] = []
    tracks: list[TrackEntry] = []   # keyframe animation (vgraph.tracks); left out when empty


# --- migrations -----------------------------------------------------------------------------------
VERSION_0_FIELDS = {"format", "version", "description", "nodes", "edges", "links"}


def _from_version_0(document: dict) -> dict:
    """Version 0, the pre-release draft: processors keyed by id under "nodes", connections and
    links as "a.out -> b.in" strings under "edges" and "links"."""
    def arrow(text: str) -> dict:
        source, _, target = str(text).partition("->")
        return {"from": source.strip(), "to": target.strip()}

    unknown = sorted(set(document) - VERSION_0_FIELDS)
    if unknown:
        raise ValueError(f"version 0 files have no field {', '.join(map(repr, unknown))} (they have "
                         f"{', '.join(sorted(VERSION_0_FIELDS))}): is 'version' right?")
    nodes = document.get("nodes", {})
    if not isinstance(nodes, dict):
        raise ValueError("'nodes' must be an object keyed by processor id")
    return {"format": FORMAT, "version": 1, "description": document.get("description", ""),
            "processors": [{"id": key, **node} for key, node in nodes.items()],
            "connections": [arrow(e) for e in document.get("edges", [])],
            "links": [arrow(e) for e in document.get("links", [])]}


# Version 2 gave one concept one name: the iso level is `iso_level` and the way derivatives are
# computed is `derivatives` on every ray caster (version 1 had `level` and `gradient` besides).
RENAMED_IN_VERSION_2 = {("RayCaster", "gradient"): "derivatives", ("CurvatureRaycaster", "level"): "iso_level"}


class MigrationError(ValueError):
    """A document a migration cannot carry over without losing something; ``problems`` are
    (JSON path, reason) pairs as NetworkFileError lists them."""

    def __init__(self, problems: list[tuple[str, str]]):
        self.problems = problems
        super().__init__("; ".join(f"{path}: {reason}" for path, reason in problems))


def _from_version_1(document: dict) -> dict:
    """Version 1: RayCaster.gradient and CurvatureRaycaster.level under their old names, in the
    processors' properties and in links. A property given under both names is refused (keeping
    either would drop the other without a word); anything malformed is left for validation."""
    document = json.loads(json.dumps(document))  # a deep copy: the caller's document stays as it was
    types, conflicts = {}, []
    processors = document.get("processors")
    for index, entry in enumerate(processors if isinstance(processors, list) else []):
        if isinstance(entry, dict) and isinstance(entry.get("properties"), dict):
            types[entry.get("id")] = entry.get("type")
            for (type_name, old), new in RENAMED_IN_VERSION_2.items():
                properties = entry["properties"]
                if entry.get("type") != type_name or old not in properties:
                    continue
                if new in properties:
                    conflicts.append(_renamed_twice(index, type_name, old, new, properties))
                    continue
                properties[new] = properties.pop(old)
    if conflicts:
        raise MigrationError(conflicts)
    for link in document.get("links") or []:
        for end in ("from", "to") if isinstance(link, dict) else ():
            pid, _, name = str(link.get(end, "")).partition(".")
            new = RENAMED_IN_VERSION_2.get((types.get(pid), name))
            if new is not None:
                link[end] = f"{pid}.{new}"
    return {**document, "version": 2}


def _renamed_twice(index: int, type_name: str, old: str, new: str, properties: dict) -> tuple[str, str]:
    where = f"processors[{index}].properties"
    return (f"{where}.{old}",
            f"given twice: {json.dumps(properties[old])} here and {json.dumps(properties[new])} as "
            f"{where}.{new}; version 2 renamed {type_name}'s '{old}' to '{new}', so the file must "
            f"give one of them")


# Version 3 changed defaults: a RayCaster (and a BrickedRayCaster) starts with the `auto` transfer function and Blinn-Phong
# shading, a ProjectedTetrahedra with a colour map over the percentiles of its field, as `vgraph run
# FILE` renders (docs/reference/general/network-format.md, "Defaults"). A saved file holds every value, but a file
# written by hand may leave one out, which then takes the default: older files get the defaults they
# were written against, so they render as before.
_OLD_RAMP = {"space": "normalized", "points": [[0.0, 0.0, 0.0, 0.0, 0.0], [0.45, 0.85, 0.55, 0.3, 0.0],
                                               [0.55, 0.95, 0.8, 0.6, 0.4], [1.0, 1.0, 1.0, 1.0, 0.8]]}
DEFAULTS_BEFORE_VERSION_3 = {"RayCaster": {"transfer_function": _OLD_RAMP, "shading": "none"},
                             "BrickedRayCaster": {"transfer_function": _OLD_RAMP, "shading": "none"},
                             "ProjectedTetrahedra": {"transfer_function": _OLD_RAMP}}


def _from_version_2(document: dict) -> dict:
    """Version 2: the processors whose defaults version 3 changed get the old ones where they
    leave them out; anything malformed is left for validation."""
    document = json.loads(json.dumps(document))  # a deep copy: the caller's document stays as it was
    processors = document.get("processors")
    for entry in processors if isinstance(processors, list) else []:
        old = DEFAULTS_BEFORE_VERSION_3.get(entry.get("type")) if isinstance(entry, dict) else None
        if old is None:
            continue
        properties = entry.setdefault("properties", {})
        if isinstance(properties, dict):
            for name, value in old.items():
                properties.setdefault(name, json.loads(json.dumps(value)))
    return {**document, "version": 3}


MIGRATIONS: dict[int, Callable[[dict], dict]] = {0: _from_version_0, 1: _from_version_1, 2: _from_version_2}


def migrate(document: dict) -> dict:
    """Upgrade a document through every migration from its version to CURRENT_VERSION."""
    version = document.get("version")
    if not isinstance(version, int) or isinstance(version, bool):
        raise ValueError(f"'version' must be an integer, got {version!r}")
    if version > CURRENT_VERSION:
        raise ValueError(f"version {version} was written by a newer vgraph (this one reads up to "
                         f"{CURRENT_VERSION})")
    while version < CURRENT_VERSION:
        if version not in MIGRATIONS:
            raise ValueError(f"no migration from version {version}")
        document = MIGRATIONS[version](document)
        version = document["version"]
    return document


# --- loading --------------------------------------------------------------------------------------
def load_network(path: str | Path, allow_write=(), render_as: str | None = None) -> Network:
    """Read, migrate, validate and build a network file. ``allow_write``: folders (besides the
    file's own) that its writers may write into. A volume file (or DICOM folder, or picture)
    instead of a network gives the standard rendering network around it (vgraph.volume_network;
    ``render_as`` "labels" or "intensity" overrides what its values suggest)."""
    path = Path(path)
    if is_volume_path(path):
        return volume_network(path, render_as=render_as)
    if is_mesh_path(path):  # before JSON: a mesh file is not a broken network (vgraph.mesh_network)
        if render_as is not None:
            raise VGraphError(f"{path}: --{render_as} (render_as) applies to volumes; a mesh renders "
                              f"the array its MeshSource names (--set source.array=NAME)")
        return mesh_network(path)
    if render_as is not None:
        raise VGraphError(f"{path}: --{render_as} (render_as) applies to a data file, not to a "
                          f"network, whose processors say how it renders")
    document = parse_document(read_json(path), str(path))
    network = build_network(document, str(path), base_dir=path.resolve().parent)
    check_write_paths(network, str(path), allow_write)
    return network


def read_json(path: Path):
    def reject_constant(name):
        raise ValueError(f"{name} is not allowed in a network file")
    text = _read_text(path)
    try:
        data = json.loads(text, parse_constant=reject_constant)
    except json.JSONDecodeError as error:
        raise NetworkFileError(str(path), [("", f"not valid JSON: {error.msg} at line {error.lineno} "
                                                f"column {error.colno}")]) from None
    except RecursionError:  # parse_document refuses what is deep but not this deep
        raise NetworkFileError(str(path), [("", f"nested more than {MAX_NESTING} levels deep")]) from None
    except ValueError as error:
        raise NetworkFileError(str(path), [("", str(error))]) from None
    return data


def _read_text(path: Path) -> str:
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise NetworkFileError(str(path), [("", "not a regular file")])
        if info.st_size > MAX_FILE_BYTES:
            raise NetworkFileError(str(path), [("", f"{info.st_size} bytes is larger than a network "
                                                    f"file can be ({MAX_FILE_BYTES} bytes)")])
        with open(path, "rb") as file:  # the size may have grown since stat()
            # the size found, then the rest: read(MAX_FILE_BYTES + 1) would allocate that first
            data = file.read(info.st_size + 1)
            if len(data) > info.st_size:
                data += file.read(MAX_FILE_BYTES + 1 - len(data))
        if len(data) > MAX_FILE_BYTES:
            raise NetworkFileError(str(path), [("", f"larger than a network file can be "
                                                    f"({MAX_FILE_BYTES} bytes)")])
        return data.decode("utf-8")
    except FileNotFoundError:
        raise NetworkFileError(str(path), [("", "file not found")]) from None
    except (OSError, UnicodeDecodeError) as error:
        raise NetworkFileError(str(path), [("", f"cannot read the file: {error}")]) from None


def parse_document(data, file: str = "<network>") -> NetworkDocument:
    if nesting_depth(data) > MAX_NESTING:
        raise NetworkFileError(file, [("", f"nested more than {MAX_NESTING} levels deep")])
    if not isinstance(data, dict):
        raise NetworkFileError(file, [("", f"expected a JSON object, got {type(data).__name__}")])
    if data.get("format") != FORMAT:
        raise NetworkFileError(file, [("format", f"expected \"{FORMAT}\", got {data.get('format')!r}")])
    try:
        data = migrate(data)
    except MigrationError as error:
        raise NetworkFileError(file, error.problems) from None
    except Exception as error:
        raise NetworkFileError(file, [("version", str(error))]) from None
    try:
        return NetworkDocument.model_validate(data)
    except ValidationError as error:
        raise NetworkFileError(file, [(json_path(e["loc"]), e["msg"]) for e in error.errors()]) from None


def json_path(location) -> str:
    text = ""
    for part in location:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def build_network(document: NetworkDocument, file: str = "<network>", base_dir=None) -> Network:
    network = Network(base_dir)
    network.description = document.description
    problems: list[tuple[str, str]] = []
    for i, entry in enumerate(document.processors):
        where = f"processors[{i}]"
        if entry.id in network:
            problems.append((f"{where}.id", f"duplicate processor id '{entry.id}'"))
            continue
        try:
            processor = registry.get(entry.type)(id=entry.id)
        except VGraphError as error:
            problems.append((f"{where}.type", str(error)))
            continue
        for name, value in entry.properties.items():
            try:
                processor.set_property(name, value, base_dir)
            except VGraphError as error:
                problems.append((f"{where}.properties.{name}", getattr(error, "reason", str(error))))
        try:
            processor.check()
        except VGraphError as error:
            problems.append((f"{where}.properties", str(error)))
        processor.position = entry.position
        network.add(processor)
    for kind, entries, make in (("connections", document.connections, network.connect),
                                ("links", document.links, network.link)):
        for i, entry in enumerate(entries):
            extra = {"bidirectional": entry.bidirectional} if kind == "links" else {}
            try:
                make(entry.source, entry.target, **extra)
            except VGraphError as error:
                problems.append((f"{kind}[{i}]", str(error)))
    if problems:
        raise NetworkFileError(file, problems)
    network.tracks = tracks_from_json(document.tracks, network, file, base_dir)
    return network


# --- saving ---------------------------------------------------------------------------------------
def network_document(network: Network, base_dir: Path | None = None) -> dict:
    """The network as a document of the current version; relative file paths are re-expressed against
    ``base_dir`` (the folder the file is saved to) so they keep pointing at the same files."""
    def value_json(processor, name, prop):
        value = processor.property_values[name]
        if isinstance(prop, FilePathProperty) and base_dir is not None:
            value = _relocated(processor, value, base_dir)
        return prop.to_json(value)

    return {
        "format": FORMAT, "version": CURRENT_VERSION, "description": network.description,
        "processors": [{"id": p.id, "type": p.type_name,
                        "properties": {n: value_json(p, n, prop) for n, prop in p.properties.items()},
                        "position": list(p.position)} for p in network.processors.values()],
        "connections": [{"from": f"{c.source}.{c.outport}", "to": f"{c.target}.{c.inport}"}
                        for c in network.connections],
        "links": [{"from": l.source, "to": l.target, "bidirectional": l.bidirectional}
                  for l in network.links],
    } | _tracks_field(network)


def _tracks_field(network: Network) -> dict:
    """``{"tracks": [...]}``, or nothing without tracks: files without them keep their form."""
    tracks = tracks_to_json(network, network.tracks)
    return {"tracks": tracks} if tracks else {}


def _relocated(processor, value: str, base_dir: Path) -> str:
    """A relative path property value re-expressed relative to ``base_dir``."""
    if not value or expanded(value).is_absolute():
        return value
    resolved = processor.resolve_path(value).resolve()
    try:
        return os.path.relpath(resolved, base_dir)
    except ValueError:  # another drive on Windows
        return str(resolved)


def save_network(network: Network, path: str | Path) -> None:
    path = Path(path)
    base_dir = path.resolve().parent
    document = network_document(network, base_dir)
    write_text_atomic(path, json.dumps(document, indent=2) + "\n")
    if network.base_dir != base_dir:  # the network now lives where it was saved
        for processor in network.processors.values():
            for name, prop in processor.properties.items():
                if isinstance(prop, FilePathProperty):
                    processor.property_values[name] = _relocated(
                        processor, processor.property_values[name], base_dir)
        network.base_dir = base_dir
