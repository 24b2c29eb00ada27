"""Autosave and crash recovery: unsaved changes survive a crash, a killed window or a power cut.

While the network has unsaved changes, ``Autosave`` writes it every ``interval_seconds()``
(QSettings key ``autosave/interval_seconds``, default 60; 0 turns autosave off) to a file of its
own; the network's file, path and clean state are left alone. Saving, and every way of leaving
the network on purpose (a clean exit, New, Open: each asks about unsaved changes first), removes
the autosave. What is left behind was left by a crash; the window offers it back (``find_for``
when a network is opened, ``newest_orphan`` at start-up without one).

Where: one folder per user, ``autosave_folder(settings)``: the QSettings key ``autosave/folder``
if set; else beside the settings file when the settings are an INI file (tests and portable
set-ups: their autosaves stay with their settings); else the per-user data folder
(``QStandardPaths.GenericDataLocation``) ``/vgraph/autosave``: on Linux
``~/.local/share/vgraph/autosave``. Not beside the network: its folder may be read-only or under
version control, and an untitled network has none.

An autosave file is JSON: ``{"format": "vgraph-autosave", "version": 1, "original": path or
null, "base_dir": folder that relative file paths in the network are relative to, "pid": the
writing process, "network": the network document}``. It is named after the network's file
(``<stem>-<hash of its absolute path>.json``) or, for an untitled network, after the process
(``untitled-<pid>.json``). An autosave whose writer is still running (another window on the same
file) is never offered. Atomic writes: a crash while autosaving leaves the previous autosave.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import QObject, QSettings, QStandardPaths, QTimer

from vgraph.atomic import write_text_atomic
from vgraph.fileformat import build_network, network_document, parse_document
from vgraph.network import Network

AUTOSAVE_FORMAT = "vgraph-autosave"
INTERVAL_KEY = "autosave/interval_seconds"
FOLDER_KEY = "autosave/folder"
DEFAULT_INTERVAL_SECONDS = 60


def autosave_folder(settings: QSettings) -> Path:
    chosen = settings.value(FOLDER_KEY)
    if chosen:
        return Path(str(chosen))
    if settings.format() == QSettings.IniFormat:
        return Path(settings.fileName()).parent / "autosave"
    # The generic location plus our name, not AppDataLocation: that one follows the running
    # program's name, and a script that opens the window would look elsewhere than `vgraph gui`.
    return Path(QStandardPaths.writableLocation(QStandardPaths.GenericDataLocation)) / "vgraph" / "autosave"


def autosave_name(original: Path | None, pid: int) -> str:
    if original is None:
        return f"untitled-{pid}.json"
    digest = hashlib.sha1(str(Path(original).resolve()).encode()).hexdigest()[:12]
    return f"{Path(original).stem}-{digest}.json"


def process_running(pid: int) -> bool:
    if pid == os.getpid():
        return True
    if os.name == "nt":   # os.kill(pid, 0) would send CTRL_C_EVENT there; assume it is gone
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:   # someone else's process: not one of our windows
        return False
    return True


@dataclass
class FoundAutosave:
    """An autosave file on disk, as read back."""
    path: Path
    original: Path | None
    base_dir: Path | None
    pid: int
    saved: float          # modification time (seconds since the epoch)
    document: dict

    def network(self) -> Network:
        """The autosaved network (NetworkFileError if it no longer loads, e.g. a missing plug-in)."""
        document = parse_document(self.document, str(self.path))
        return build_network(document, str(self.path), base_dir=self.base_dir)

    def orphaned(self) -> bool:
        """Left behind: the window that wrote it is gone."""
        return not process_running(self.pid)


def read_autosave(path: Path) -> FoundAutosave | None:
    """The autosave in ``path``, or None if it is not one (or cannot be read)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("format") != AUTOSAVE_FORMAT:
            return None
        optional = lambda key: Path(data[key]) if data.get(key) else None
        return FoundAutosave(path, optional("original"), optional("base_dir"), int(data["pid"]),
                             path.stat().st_mtime, data["network"])
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


class Autosave(QObject):
    def __init__(self, workspace, settings: QSettings, parent: QObject | None = None):
        super().__init__(parent)
        self.workspace = workspace
        self.settings = settings
        self.folder = autosave_folder(settings)
        self.current: Path | None = None   # the autosave this window wrote last
        self._dirty = False                # changed since it was written
        self.timer = QTimer(self)
        self.timer.timeout.connect(self.write_if_needed)
        if self.interval_seconds() > 0:
            self.timer.start(self.interval_seconds() * 1000)
        stack = workspace.undo_stack
        stack.indexChanged.connect(self._changed)
        stack.cleanChanged.connect(self._clean_changed)
        workspace.network_replaced.connect(lambda *_: self.remove())

    def interval_seconds(self) -> int:
        try:
            return int(self.settings.value(INTERVAL_KEY, DEFAULT_INTERVAL_SECONDS))
        except (TypeError, ValueError):
            return DEFAULT_INTERVAL_SECONDS

    # --- writing --------------------------------------------------------------------------------
    def _changed(self, *_) -> None:
        self._dirty = True

    def _clean_changed(self, clean: bool) -> None:
        if clean:
            self.remove()     # saved (or undone back to the saved state): nothing to protect
        else:
            self._dirty = True

    def write_if_needed(self) -> Path | None:
        """The timer's work: write if there are unsaved changes not autosaved yet."""
        if self.workspace.is_modified() and self._dirty:
            return self.write()
        return None

    def write(self) -> Path:
        network = self.workspace.network
        path = self.folder / autosave_name(self.workspace.path, os.getpid())
        data = {"format": AUTOSAVE_FORMAT, "version": 1,
                "original": str(self.workspace.path.resolve()) if self.workspace.path else None,
                "base_dir": str(network.base_dir) if network.base_dir else None,
                "pid": os.getpid(), "network": network_document(network)}
        self.folder.mkdir(parents=True, exist_ok=True)
        write_text_atomic(path, json.dumps(data, indent=1) + "\n")
        if self.current is not None and self.current != path:   # the network was saved elsewhere
            self.current.unlink(missing_ok=True)
        self.current, self._dirty = path, False
        return path

    def remove(self) -> None:
        if self.current is not None:
            self.current.unlink(missing_ok=True)
        self.current, self._dirty = None, False

    def stop(self) -> None:
        self.timer.stop()

    # --- recovery -------------------------------------------------------------------------------
    def find_for(self, path: Path) -> FoundAutosave | None:
        """An autosave of the file ``path`` left by a crash and newer than the file. One older
        than the file is stale (the file was saved after it) and is deleted."""
        found = read_autosave(self.folder / autosave_name(Path(path), 0))
        if found is None or not found.orphaned():
            return None
        try:
            newer = found.saved > Path(path).stat().st_mtime
        except OSError:
            newer = True
        if not newer:
            found.path.unlink(missing_ok=True)
            return None
        return found

    def orphans(self) -> list[FoundAutosave]:
        """Every autosave left by a crash, newest first."""
        if not self.folder.is_dir():
            return []
        found = [read_autosave(path) for path in self.folder.glob("*.json")]
        return sorted((f for f in found if f is not None and f.orphaned()), key=lambda f: -f.saved)

    def newest_orphan(self) -> FoundAutosave | None:
        orphans = self.orphans()
        return orphans[0] if orphans else None
