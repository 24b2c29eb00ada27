"""The window's file handling: New, Open, Save, Save As, and what they ask first.

A mixin of ``MainWindow`` (it uses the window's workspace, log, view, inspector and autosave), so
the window keeps one place per concern while tests answer its dialogs on the window itself
(``ask_*`` methods, monkeypatched).

Conventions:
- Replacing the network (New, Open) first asks about unsaved changes (``confirm_discard``).
- Opening a network that has an autosave left by a crash, newer than the file, offers to restore
  it (``offer_recovery``); see ``autosave.py``.
- A file that cannot be read opens nothing and shows every problem; a failed save keeps the file.
- A file whose writers would write outside its folder (``WritePathError``) opens only if the user
  allows it (``ask_allow_writes``, naming each processor and path); it is then loaded again with
  those paths' folders allowed. Cancel leaves the open network as it was.
- Export Image saves the current canvas's frame (``CanvasDocks.current_view``); its dialog starts
  in the network's folder with a suggested name (``image_export.suggested_image_path``).
"""

from __future__ import annotations

import time
from pathlib import Path

from PySide6.QtWidgets import QFileDialog, QMessageBox

from vgraph.errors import VGraphError, WritePathError
from vgraph.gui.autosave import FoundAutosave
from vgraph.gui.canvas_toolbar import save_complete_frame
from vgraph.io import SUPPORTED_EXTENSIONS
from vgraph.io.meshes import FILE_FILTERS as MESH_FILTERS

UNTITLED = "untitled.json"
NETWORK_FILTER = "vgraph networks (*.json);;All files (*)"
# Open also takes a volume or mesh file: it opens as a new network around it
# (vgraph.volume_network, vgraph.mesh_network).
OPEN_FILTER = ("vgraph networks, volumes or meshes (*.json " + " ".join(f"*{e}" for e in SUPPORTED_EXTENSIONS)
               + " " + " ".join(MESH_FILTERS) + ");;" + NETWORK_FILTER)


class FileActions:
    # --- dialogs (tests answer them by replacing these methods) -------------------------------
    def ask_save_changes(self) -> QMessageBox.StandardButton:
        return QMessageBox.question(
            self, "Unsaved changes", f"Save the changes to {self._file_name()}?",
            QMessageBox.Save | QMessageBox.Discard | QMessageBox.Cancel, QMessageBox.Save)

    def ask_recover(self, found: FoundAutosave) -> str:
        """'restore', 'discard' or 'later'."""
        name = found.original.name if found.original else "an untitled network"
        when = time.strftime("%Y-%m-%d %H:%M", time.localtime(found.saved))
        box = QMessageBox(QMessageBox.Question, "Recover unsaved changes",
                          f"vgraph did not close normally and kept unsaved changes to {name} "
                          f"(autosaved {when}). Restore them?", parent=self)
        buttons = {box.addButton("Restore", QMessageBox.AcceptRole): "restore",
                   box.addButton("Discard", QMessageBox.DestructiveRole): "discard",
                   box.addButton("Later", QMessageBox.RejectRole): "later"}
        box.exec()
        return buttons.get(box.clickedButton(), "later")

    def ask_allow_writes(self, path: Path, writes: list[tuple[str, Path]]) -> bool:
        """Whether the writers of ``path`` may write where the file says, outside its folder."""
        listed = "\n".join(f"  {processor_id}: {target}" for processor_id, target in writes)
        box = QMessageBox(QMessageBox.Warning, "Allow writing outside the network's folder?",
                          f"{path.name} has writers that would write outside its folder "
                          f"({path.resolve().parent}):\n\n{listed}\n\nA network from someone else "
                          f"could overwrite your files this way. Allow these writes?", parent=self)
        allow = box.addButton("Allow", QMessageBox.AcceptRole)
        box.setDefaultButton(box.addButton(QMessageBox.Cancel))
        box.exec()
        return box.clickedButton() is allow

    def ask_open_path(self) -> str:
        path, _ = QFileDialog.getOpenFileName(self, "Open network, volume or mesh", self._start_dir(), OPEN_FILTER)
        return path

    def ask_save_path(self) -> str:
        path, _ = QFileDialog.getSaveFileName(self, "Save network as", self.suggested_save_path(),
                                              NETWORK_FILTER)
        return path

    def suggested_save_path(self) -> str:
        """Where Save As starts: the network's own file (a copy is usually a small rename of it),
        or an untitled one in the current folder."""
        return str(self.workspace.path) if self.workspace.path else str(Path.cwd() / UNTITLED)

    def _start_dir(self) -> str:
        return str(self.workspace.path.parent) if self.workspace.path else ""

    def _file_name(self) -> str:
        return self.workspace.path.name if self.workspace.path else "the untitled network"

    # --- workspace actions ----------------------------------------------------------------------
    def confirm_discard(self) -> bool:
        """True when the current network may be replaced (saved, discarded, or unmodified)."""
        if not self.workspace.is_modified():
            return True
        answer = self.ask_save_changes()
        if answer == QMessageBox.Save:
            return self.save_network()
        return answer == QMessageBox.Discard

    def new_network(self) -> None:
        if self.confirm_discard():
            self.workspace.new()
            self.log.info("new network")

    def open_network(self, path: str | Path | None = None, render_as: str | None = None) -> bool:
        if not self.confirm_discard():
            return False
        path = path or self.ask_open_path()
        if not path or not self._open(Path(path), render_as):
            return False
        built = self.workspace.path is None and self.workspace.network.description  # a data file's
        self.log.info(f"opened {path}" + (f": {built}" if built else ""))
        self.view.fit_network()
        self.offer_recovery(self.autosave.find_for(Path(path)))
        return True

    def _open(self, path: Path, render_as: str | None = None) -> bool:
        """Load ``path``; a file that cannot be read is reported. False if nothing was opened."""
        try:
            return self._load_with_consent(path, render_as)
        except VGraphError as error:
            self.report_error("Cannot open network", f"Cannot open {path}:\n{error}")
            return False

    def _load_with_consent(self, path: Path, render_as: str | None = None) -> bool:
        """Writers that would write outside the file's folder need the user's consent."""
        try:
            self.workspace.open(path, render_as=render_as)
            return True
        except WritePathError as refused:
            writes = refused.paths
        if not self.ask_allow_writes(path, writes):
            self.log.info(f"did not open {path}: its writers would write outside its folder")
            return False
        self.workspace.open(path, allow_write=sorted({str(target.parent) for _, target in writes}))
        self.log.warning(f"{path}: allowed writing outside its folder to "
                         + ", ".join(str(target) for _, target in writes))
        return True

    def offer_recovery(self, found: FoundAutosave | None) -> bool:
        """Ask whether to restore an autosave left by a crash; True if it was restored."""
        if found is None:
            return False
        answer = self.ask_recover(found)
        if answer == "discard":
            found.path.unlink(missing_ok=True)
            self.log.info(f"discarded the autosave {found.path}")
            return False
        if answer != "restore":
            return False   # "later": it is offered again next time
        try:
            network = found.network()
        except VGraphError as error:
            self.report_error("Cannot restore the autosave", f"Cannot restore {found.path}:\n{error}")
            return False
        self.workspace.restore(network, found.original)
        found.path.unlink(missing_ok=True)
        self.autosave.write()   # protected again at once, under this window's name
        self.view.fit_network()
        self.log.info(f"restored unsaved changes to {self.workspace.display_name()} from {found.path}")
        return True

    def export_image(self, path: str | Path | None = None) -> Path | None:
        """File > Export Image: the current canvas's frame as a PNG (asks where, unless given)."""
        view = self.canvases.current_view()
        if view is None:
            self.show_message("Export Image: the network has no canvas")
            return None
        return save_complete_frame(view, path)

    def save_network(self) -> bool:
        if self.workspace.path is None:
            return self.save_network_as()
        return self._save(self.workspace.path)

    def save_network_as(self, path: str | Path | None = None) -> bool:
        path = path or self.ask_save_path()
        if not path:
            return False
        path = Path(path)
        return self._save(path if path.suffix else path.with_suffix(".json"))

    def _save(self, path: Path) -> bool:
        try:
            self.workspace.save_as(path)
        except (OSError, VGraphError) as error:
            self.report_error("Cannot save network", f"Cannot save {path}:\n{error}")
            return False
        self.inspector.show_processor(self.inspector.processor_id)  # paths may be re-expressed
        self.log.info(f"saved {path}")
        return True
