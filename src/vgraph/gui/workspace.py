"""The workspace: the open network, its file, its undo stack and the edit operations.

Conventions:
- Every edit method builds an edit (``vgraph.edits``, read from the network before it changes)
  and runs it through ``execute`` as an ``EditCommand`` (``commands.py``): the edit is applied once
  (a refused edit raises VGraphError and changes nothing) and then pushed.
- ``network_replaced`` is emitted when New/Open put a different Network in place; views rebuild.
- "Modified" means the undo stack is not at its clean index (set when saved or opened). The
  stack keeps the last ``UNDO_LIMIT`` steps; once the saved state has dropped out of it, undo
  cannot get back to "unmodified" (the title keeps its ``*``).
- Recent files live in a QSettings (injected, so tests use their own file); most recent first.
- Auto-linked cameras: a processor added with a camera property gets it linked both ways to the
  first camera property already in the network (Voreen's default), in the same undo step.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from PySide6.QtCore import QObject, QSettings, Signal
from PySide6.QtGui import QUndoStack

from vgraph.errors import PropertyError, VGraphError
from vgraph.fileformat import load_network, save_network
from vgraph.mesh_network import is_mesh_path
from vgraph.volume_network import is_volume_path
from vgraph.edits import (AddProcessor, Connect, Disconnect, Edit, LinkProperties, MoveProcessors,
                          RemoveProcessor, SetProperty, UnlinkProperties)
from vgraph.gui.commands import EditCommand, free_id
from vgraph.gui.placement import matching_connections
from vgraph.network import Connection, Link, Network, split_address
from vgraph.processor import Processor
from vgraph.properties import CameraProperty
from vgraph.registry import registry

RECENT_FILES_KEY = "recent_files"
MAX_RECENT_FILES = 8
UNDO_LIMIT = 1000   # steps kept: the history would otherwise grow with every edit of a long session


class Workspace(QObject):
    network_replaced = Signal(object)   # the new Network
    path_changed = Signal(object)       # Path or None
    recent_files_changed = Signal(list)

    def __init__(self, settings: QSettings | None = None, parent: QObject | None = None):
        super().__init__(parent)
        self.settings = settings if settings is not None else QSettings("vgraph", "vgraph")
        self.network = Network()
        self.path: Path | None = None
        self.undo_stack = QUndoStack(self)
        self.undo_stack.setUndoLimit(UNDO_LIMIT)
        self._macro_depth = 0
        self.auto_link_cameras = True

    # --- state ----------------------------------------------------------------------------------
    def is_modified(self) -> bool:
        return not self.undo_stack.isClean()

    def display_name(self) -> str:
        return self.path.name if self.path else "untitled"

    # --- commands -------------------------------------------------------------------------------
    def execute(self, edit: Edit, merge=None) -> EditCommand:
        """Apply ``edit`` (raises VGraphError if the network refuses it), then push it as one undo
        step (merged into the last one when it continues it: ``EditCommand``)."""
        command = EditCommand(self.network, edit, merge)
        command.apply()
        command.applied_once()
        if not self._merged_into_last(command):
            self.undo_stack.push(command)
        return command

    def _merged_into_last(self, command: EditCommand) -> bool:
        """Merge a continuing edit (the next mouse move of a drag) into the last command under
        the rules of QUndoStack.push, but here: PySide6 never frees a command that push merges
        away, so every move of a drag leaked one, with its values (a transfer function, a camera)."""
        stack = self.undo_stack
        if (command.id() == -1 or self._macro_depth or stack.index() == 0
                or stack.index() != stack.count() or stack.index() == stack.cleanIndex()):
            return False   # push decides (and then never merges, except after an undo)
        last = stack.command(stack.index() - 1)
        if last is None or last.id() != command.id() or not last.mergeWith(command):
            return False
        stack.indexChanged.emit(stack.index())   # as push does after a merge: views follow it
        return True

    def macro(self, text: str):
        """A context in which several edits become one undo step named ``text`` (a view's
        compound action: the Markups dock's Profile)."""
        return self._macro(text)

    @contextmanager
    def _macro(self, text: str):
        self._macro_depth += 1
        self.undo_stack.beginMacro(text)
        try:
            yield
        finally:
            self.undo_stack.endMacro()
            self._macro_depth -= 1

    def add_processor(self, type_name: str, position=(0.0, 0.0), id: str | None = None,
                      after: str | None = None) -> Processor:
        """Add a processor; ``after``: the processor it follows (placement.py), whose outports
        it is connected to where that is unambiguous, in the same undo step."""
        cls = registry.get(type_name)
        if id is not None and id in self.network:  # refuse before an (empty) undo macro opens
            raise VGraphError(f"a processor with id '{id}' already exists")
        processor = cls(id=id or free_id(self.network, cls.type_name))
        processor.position = (float(position[0]), float(position[1]))
        leaders = self._camera_leaders(processor) if self.auto_link_cameras else []
        with self._macro(f"Add {processor.id} ({cls.type_name})"):
            self.execute(AddProcessor.of(processor))
            for leader, follower in leaders:
                self.execute(LinkProperties.of(self.network, leader, follower, bidirectional=True))
            if after is not None and after in self.network:
                for connection in matching_connections(self.network, after, processor):
                    if self.connection_refusal(connection) is None:
                        self.execute(Connect(connection))
        return self.network[processor.id]

    def _camera_leaders(self, processor: Processor) -> list[tuple[str, str]]:
        """(existing camera property, new camera property) pairs to link."""
        existing = next((f"{p.id}.{name}" for p in self.network.processors.values()
                         for name, prop in p.properties.items() if isinstance(prop, CameraProperty)),
                        None)
        if existing is None:
            return []
        return [(existing, f"{processor.id}.{name}") for name, prop in processor.properties.items()
                if isinstance(prop, CameraProperty)]

    def remove(self, processor_ids=(), connections=(), links=()) -> None:
        """Delete a selection: links and connections first, then processors (with theirs)."""
        processor_ids, connections, links = list(processor_ids), list(connections), list(links)
        count = len(processor_ids) + len(connections) + len(links)
        if not count:
            return
        with self._macro(f"Delete {count} item{'s' if count > 1 else ''}"):
            for link in links:
                if link in self.network.links:
                    self.execute(UnlinkProperties.of(self.network, link))
            for connection in connections:
                if connection in self.network.connections:
                    self.execute(Disconnect.of(self.network, connection))
            for pid in processor_ids:
                if pid in self.network:
                    self.execute(RemoveProcessor.of(self.network, pid))

    def connect(self, source: str, target: str, replacing: bool = False) -> Connection:
        """Connect; ``replacing``: a taken single inport gives up its connection for this one,
        in the same place of the connection order and in one undo step (as Voreen and Inviwo)."""
        (src, out), (dst, inp) = split_address(source), split_address(target)
        connection = Connection(src, out, dst, inp)
        replaced = self.replaced_by(connection) if replacing else None
        if replaced is None:
            self.execute(Connect(connection))
            return connection
        self.network.check_connection(connection, replacing=True)  # refuse before the macro opens
        with self._macro(f"Replace {replaced} by {connection}"):
            disconnect = Disconnect.of(self.network, replaced)
            self.execute(disconnect)
            self.execute(Connect(connection, disconnect.index))
        return connection

    def replaced_by(self, connection: Connection) -> Connection | None:
        """The connection ``connection`` would replace: the one holding its single inport."""
        inport = self.network[connection.target].inport(connection.inport)
        taken = self.network.inputs_of(connection.target, connection.inport)
        if inport is None or inport.multiple or not taken or taken[0] == connection:
            return None
        return taken[0]

    def connection_refusal(self, connection: Connection, replacing: bool = False) -> str | None:
        """Why the network would refuse ``connection`` (None: it would accept it); ``replacing``:
        a taken single inport is no reason."""
        try:
            self.network.check_connection(connection, replacing=replacing)
        except VGraphError as error:
            return str(error)
        return None

    def disconnect(self, connection: Connection) -> None:
        self.execute(Disconnect.of(self.network, connection))

    def set_property(self, address: str, value, merge=None) -> None:
        """Validate and set a property through the undo stack; an unchanged value pushes nothing."""
        processor_id, name = split_address(address, "property")
        processor = self.network[processor_id]
        if name not in processor.properties:
            raise PropertyError(address, f"{processor.type_name} has no property '{name}'")
        if processor.properties[name].validate(value, address) == processor.property_values[name]:
            return
        self.execute(SetProperty.of(self.network, address, value), merge)

    def link(self, source: str, target: str, bidirectional: bool = False) -> None:
        self.execute(LinkProperties.of(self.network, source, target, bidirectional))

    def unlink(self, link: Link) -> None:
        self.execute(UnlinkProperties.of(self.network, link))

    def move(self, positions: dict[str, tuple[float, float]]) -> None:
        changed = {pid: xy for pid, xy in positions.items()
                   if tuple(self.network[pid].position) != tuple(map(float, xy))}
        if changed:
            self.execute(MoveProcessors.of(self.network, changed))

    # --- files ----------------------------------------------------------------------------------
    def new(self) -> None:
        self._replace(Network(), None)

    def open(self, path: str | Path, allow_write=(), render_as: str | None = None) -> None:
        """Load a network (NetworkFileError on a bad file; the open network is then untouched).
        Its writers may write only inside its folder and the folders in ``allow_write``
        (WritePathError names the others). A data file opens as the network for what it holds
        (``render_as``: vgraph.file_kind)."""
        path = Path(path)
        network = load_network(path, allow_write, render_as)
        # A volume or mesh file opens as a new, untitled network around it: saving must not
        # write over it.
        self._replace(network, None if is_volume_path(path) or is_mesh_path(path) else path)
        self.add_recent_file(path)

    def restore(self, network: Network, path: Path | None) -> None:
        """Put a recovered network (an autosave) in place as unsaved changes to ``path``."""
        self._replace(network, path)
        self.undo_stack.resetClean()   # nothing to undo, yet not what the file holds

    def save(self) -> None:
        if self.path is None:
            raise ValueError("the network has no file yet; use save_as")
        self.save_as(self.path)

    def save_as(self, path: str | Path) -> None:
        """Atomic save; file paths in properties are re-expressed relative to the new folder."""
        path = Path(path)
        save_network(self.network, path)
        self.undo_stack.setClean()
        if path != self.path:
            self.path = path
            self.path_changed.emit(path)
        self.add_recent_file(path)

    def _replace(self, network: Network, path: Path | None) -> None:
        self.undo_stack.clear()
        self.network = network
        self.path = path
        self.network_replaced.emit(network)
        self.path_changed.emit(path)

    # --- recent files ---------------------------------------------------------------------------
    def recent_files(self) -> list[str]:
        value = self.settings.value(RECENT_FILES_KEY, [])
        if isinstance(value, str):  # QSettings returns a lone string for a one-item list
            value = [value]
        return [str(v) for v in value or []]

    def add_recent_file(self, path: Path) -> None:
        entry = str(Path(path).resolve())
        files = [entry] + [f for f in self.recent_files() if f != entry]
        self.settings.setValue(RECENT_FILES_KEY, files[:MAX_RECENT_FILES])
        self.recent_files_changed.emit(files[:MAX_RECENT_FILES])
