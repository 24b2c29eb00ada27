"""Where a network's writers write (``FilePathProperty(writes=True)``: ImageWriter, VolumeWriter).

Three moments, one rule each:

- loading a network file (``check_write_paths``): a writer path that resolves outside the file's
  folder and the folders the user allowed is refused (``WritePathError``); those folders and the
  paths checked are kept on the network (``Confinement``, ``Network.write_confinement``);
- before evaluating, in ``vgraph run`` and ``vgraph validate`` alike (``check_writers``): what a
  writer could not write is refused, naming the JSON path: no path, a name its file types do not
  have, a folder (``.``), a file where a folder should be, a name the system refuses;
- writing (``writable_path`` and ``write_confinement``, used by the writers themselves): the same
  checks again, and the atomic write resolves the folder once more and must find it inside the
  network's folders (vgraph.atomic), so a symbolic link made since loading is not followed.

The confinement holds for the paths the file gave: a writer path set since (``--set``, a
script's ``network.set``, a field of the GUI) is the user's own, as ``-o`` is.
"""

from __future__ import annotations

import fnmatch
import os
from dataclasses import dataclass
from pathlib import Path

from vgraph.errors import NetworkFileError, PropertyError, WritePathError
from vgraph.file_names import expanded, file_name_problem, shown
from vgraph.network import Network
from vgraph.processor import Processor
from vgraph.properties import FilePathProperty


@dataclass(frozen=True)
class Confinement:
    """The folders a network file's writer paths may write into, and those paths as checked."""
    folders: tuple[Path, ...]
    checked: dict  # (processor id, property name) -> the value checked when the file was loaded

    def folders_for(self, processor: Processor, name: str) -> tuple[Path, ...] | None:
        """``folders`` while the property still holds the value from the file, else None."""
        from_file = self.checked.get((processor.id, name))
        return self.folders if from_file is not None and from_file == processor.property_values[name] else None


def writer_properties(network: Network):
    """(index in the file, processor, property name) of every property a writer writes to."""
    for index, processor in enumerate(network.processors.values()):
        for name, prop in processor.properties.items():
            if isinstance(prop, FilePathProperty) and prop.writes:
                yield index, processor, name


def check_write_paths(network: Network, file: str, allow_write=()) -> None:
    """Refuse writer paths that resolve outside the network's folder and the allowed folders;
    keep those folders and the paths checked on the network for the writes themselves."""
    allowed = [expanded(folder).resolve() for folder in allow_write]
    if network.base_dir is not None:
        allowed.append(network.base_dir.resolve())
    problems, paths, checked = [], [], {}
    for index, processor, name in writer_properties(network):
        value = processor.property_values[name]
        checked[processor.id, name] = value
        if not value:
            continue  # check_writers names it
        target = processor.resolve_path(value).resolve()
        if not _inside(target, allowed):
            paths.append((processor.id, target))
            problems.append((f"processors[{index}].properties.{name}",
                             f"{processor.id} ({processor.type_name}) would write {target}, outside "
                             f"the network's folder; allow it with --allow-write {target.parent}"))
    if problems:
        raise WritePathError(file, problems, paths)
    network.write_confinement = Confinement(tuple(allowed), checked)


def _inside(target: Path, folders) -> bool:
    return any(target.is_relative_to(folder) for folder in folders)


def check_writers(network: Network, file: str) -> None:
    """Refuse, before anything is evaluated, what a writer could not write (``writable_path``),
    every problem at once with its JSON path."""
    problems = []
    for index, processor, name in writer_properties(network):
        try:
            writable_path(processor, name)
        except PropertyError as error:
            problems.append((f"processors[{index}].properties.{name}",
                             f"{processor.id} ({processor.type_name}) {error.reason}"))
    if problems:
        raise NetworkFileError(file, problems)


def writable_path(processor: Processor, name: str) -> Path:
    """The resolved path the writer ``processor`` writes its property ``name`` to, if it could:
    PropertyError naming ``id.name`` otherwise. Checks only; creates nothing."""
    value = processor.property_values[name]
    where = f"{processor.id}.{name}"
    if not value:
        raise PropertyError(where, "no output file chosen")
    path = processor.resolve_path(value)
    problem = file_name_problem(str(path)) or _type_problem(processor.properties[name], path) \
        or _place_problem(path)
    if problem:
        raise PropertyError(where, f"cannot write {shown(value)}: {problem}")
    return path


def _type_problem(prop: FilePathProperty, path: Path) -> str | None:
    patterns = [p.lower() for p in prop.filters if p != "*"]
    if not patterns or any(fnmatch.fnmatchcase(path.name.lower(), p) for p in patterns):
        return None
    endings = " or ".join(p.lstrip("*") for p in patterns)
    return f"names a folder, not a file ending in {endings}" if _is_folder(path) or not path.name \
        else f"the name must end in {endings}"


def _place_problem(path: Path) -> str | None:
    """What stands where the file or its folders should be: a folder at the file's place, a
    file at a folder's (missing folders are fine: writers make them)."""
    if not path.name or _is_folder(path):
        return "names a folder, not a file"
    for folder in path.parents:
        if os.path.lexists(folder):
            return None if _is_folder(folder) else f"{str(folder)!r} is not a folder"
    return None


def _is_folder(path: Path) -> bool:
    return os.path.isdir(path)  # False where the system cannot tell (a loop of links): the write names it


def write_confinement(processor: Processor, name: str) -> tuple[Path, ...] | None:
    """The folders the write of ``processor``'s property ``name`` must stay in as it happens
    (None: anywhere, for a path that is not the one a file gave)."""
    confinement = processor.network.write_confinement if processor.network is not None else None
    return confinement.folders_for(processor, name) if confinement is not None else None
