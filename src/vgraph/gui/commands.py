"""Undo: every edit the GUI makes to a Network is an edit record (``vgraph.edits``) in an
``EditCommand``; redo applies the edit, undo applies its inverse.

Conventions:
- Edits act on the Network model only (its public methods); the scene and the inspector follow
  through the network's events, never through the commands.
- ``Workspace.execute`` applies a command once itself (``apply()``, which raises VGraphError and
  changes nothing when the network refuses the edit) and only then pushes it; QUndoStack's first
  ``redo()`` after that push is therefore skipped. So a refused edit never reaches the stack.
- Undo restores what the edit disturbed exactly, including the orders the file format keeps (the
  processors', the connections' and with them each inport's, the links'): the edits are built
  with ``of(network, ...)`` before they are applied, which reads where everything was.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

from PySide6.QtGui import QUndoCommand

from vgraph.edits import Edit, SetProperty
from vgraph.network import Network

MERGE_PROPERTY_EDITS = 1001  # QUndoCommand.id() of property edits that merge (slider drags)


def free_id(network: Network, type_name: str) -> str:
    """'rayCaster', 'rayCaster1', ... : the first id not taken."""
    stem = type_name[0].lower() + type_name[1:]
    return next(f"{stem}{i or ''}" for i in itertools.count() if f"{stem}{i or ''}" not in network)


class EditCommand(QUndoCommand):
    """One undo step: ``edit`` on ``network``. Consecutive property edits of one property with the
    same ``merge`` key (one slider drag) become one step; ``merge=None`` never merges."""

    def __init__(self, network: Network, edit: Edit, merge=None, parent: QUndoCommand | None = None):
        super().__init__(edit.describe(), parent)
        self.network = network
        self.edit = edit
        self.merge = merge if isinstance(edit, SetProperty) else None
        self._skip_redo = False

    def apply(self) -> None:
        self.edit.apply(self.network)

    def applied_once(self) -> None:
        """Mark the command as already applied (by Workspace.execute) before it is pushed."""
        self._skip_redo = True

    def redo(self) -> None:
        if self._skip_redo:
            self._skip_redo = False
            return
        self.apply()

    def undo(self) -> None:
        self.edit.inverse().apply(self.network)

    def id(self) -> int:
        return MERGE_PROPERTY_EDITS if self.merge is not None else -1

    def mergeWith(self, other: QUndoCommand) -> bool:
        if not isinstance(other, EditCommand) or other.merge is None or other.merge != self.merge \
                or other.edit.address != self.edit.address:
            return False
        self.edit = replace(self.edit, value=other.edit.value)  # the drag's last value, the first's old one
        return True
