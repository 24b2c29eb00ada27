"""The main window and ``run_gui`` (``vgraph gui [NETWORK.json]``).

Layout: the network editor in the middle, the processor palette and the canvases below it on the
left, the property inspector on the right, the log at the bottom, messages (such as why a
connection is refused) in the status bar. The first-run size, the layout kept between runs, the
View menu's docks and Reset Layout are in ``layout.py``; the Help menu is ``help.py``.

Conventions:
- The window wires views to the Workspace; it holds no model state of its own.
- Errors never close the window: a bad file gets a dialog naming every problem, a processor error
  shows on its node and in the log, and anything unexpected goes to the log (``run_gui`` installs
  an exception hook for slots and event handlers).
- Dialogs go through ``ask_*``/``report_error`` so tests can answer them.
- File handling (New, Open with crash recovery and write-path consent, Save) is the
  ``FileActions`` mixin; ``Autosave`` keeps unsaved changes aside while the window is open.
- The actions and menus are the ``WindowMenus`` mixin (menus.py).
- The render process is watched (``LiveEvaluation``); what the window says about it (outcomes in
  the log, an overdue frame's "Cancel rendering" button, the cluster) is the ``RenderStatus``
  mixin (render_status.py); restarts and deaths go to the log.
- No OpenGL here: evaluation happens in the render process (``LiveEvaluation``), frames come back
  as images.
"""

from __future__ import annotations

import sys
import traceback
from contextlib import contextmanager
from pathlib import Path

from PySide6.QtCore import QSettings, Qt
from PySide6.QtGui import QCursor
from PySide6.QtWidgets import QApplication, QDockWidget, QMainWindow, QMessageBox

from vgraph.atomic import atomic_path
from vgraph.errors import VGraphError
from vgraph.gui import layout
from vgraph.gui.autosave import Autosave
from vgraph.gui.canvases import CanvasDocks
from vgraph.gui.cluster_dialog import load_setting
from vgraph.gui.file_actions import FileActions
from vgraph.gui.inspector import PropertyInspector
from vgraph.gui.links import LinkDialog
from vgraph.gui.live_evaluation import LiveEvaluation
from vgraph.gui.log import LogPanel
from vgraph.gui.markups_dock import markups_dock
from vgraph.gui.menus import WindowMenus
from vgraph.gui.palette import ProcessorPalette
from vgraph.gui.perspectives import Perspectives
from vgraph.gui.progress_view import EvaluationProgress
from vgraph.gui.render_status import RenderStatus
from vgraph.gui.scene import NetworkScene, NetworkView
from vgraph.gui.table_dock import table_dock
from vgraph.gui.timeline_dock import timeline_dock
from vgraph.gui.welcome import WelcomeSwitch
from vgraph.gui.workspace import Workspace
from vgraph.live.render_process import RenderProcess


class MainWindow(FileActions, WindowMenus, RenderStatus, QMainWindow):
    def __init__(self, settings: QSettings | None = None, renderer: RenderProcess | None = None):
        super().__init__()
        self.workspace = Workspace(settings, self)
        self.evaluation = LiveEvaluation(self.workspace, renderer, parent=self)
        self.autosave = Autosave(self.workspace, self.workspace.settings, self)
        self.scene = NetworkScene(self.workspace, self, status_of=self.evaluation.status_of)
        self.view = NetworkView(self.scene)
        self.insert_at = None   # where Find Processor's choice goes (the mouse in the editor)
        self.welcome = WelcomeSwitch(self)  # the welcome page while there is no network (welcome.py)
        self.setCentralWidget(self.welcome.stack)
        self.palette = ProcessorPalette()
        self.inspector = PropertyInspector(self.workspace, status_of=self.evaluation.status_of)
        self.log = LogPanel()
        self.palette_dock = self._dock("Processors", self.palette, Qt.LeftDockWidgetArea)
        self.properties_dock = self._dock("Properties", self.inspector, Qt.RightDockWidgetArea)
        self.log_dock = self._dock("Log", self.log, Qt.BottomDockWidgetArea)
        self.canvases = CanvasDocks(self, self.workspace, self.evaluation)
        self.markups_dock = markups_dock(self)  # every markup in a table, tabbed with the Log, hidden
        self.timeline_dock = timeline_dock(self)  # keyframes, scrub and play; tabbed with the Log, hidden
        self.table_dock = table_dock(self)  # the selected processor's whole table; tabbed with the Log, hidden
        self.running = EvaluationProgress(self)  # which processor runs, how far (progress_view.py)
        self.failures: dict[str, str] = {}
        self.remember_layout = True  # a screenshot run leaves the user's layout alone
        self.blank_warnings: dict[str, str] = {}  # display id -> the empty-image warning logged
        self.perspectives = Perspectives(self)  # editing and views layouts (perspectives.py)
        self._build_actions()
        self._add_cancel_button()
        self._build_menus()
        self._wire()
        if not layout.restore_layout(self, self.workspace.settings):
            self.arrange(*layout.first_run_size(self))
        self.perspectives.restore()
        self._update_title()
        self.set_cluster(load_setting(self.workspace.settings), save=False)

    def arrange(self, width: int, height: int) -> None:
        """Size the window; the right column (canvases, inspector) fits the widest editor."""
        layout.arrange(self, width, height)

    def home_areas(self) -> dict[QDockWidget, Qt.DockWidgetArea]:
        """The fixed docks and where the first-run layout puts them (View > Reset Layout)."""
        return {self.palette_dock: Qt.LeftDockWidgetArea, self.properties_dock: Qt.RightDockWidgetArea,
                self.log_dock: Qt.BottomDockWidgetArea}

    def log_tabs(self) -> list[QDockWidget]:
        """The docks tabbed with the Log and hidden at first (Reset Layout puts them back there)."""
        return [self.markups_dock, self.timeline_dock, self.table_dock]

    def _dock(self, title: str, widget, area) -> QDockWidget:
        dock = QDockWidget(title, self)
        dock.setObjectName(title)
        dock.setWidget(widget)
        self.addDockWidget(area, dock)
        return dock

    def _wire(self) -> None:
        workspace = self.workspace
        self.palette.processor_chosen.connect(self.add_processor)
        self.scene.status_message.connect(self.show_message)
        self.inspector.status_message.connect(self.show_message)
        self.inspector.interacting.connect(self.evaluation.interactive)
        self.scene.selectionChanged.connect(self._selection_changed)
        workspace.undo_stack.cleanChanged.connect(self._update_title)
        workspace.path_changed.connect(self._update_title)
        workspace.recent_files_changed.connect(self._fill_recent_menu)
        workspace.network_replaced.connect(self._network_replaced)
        self.evaluation.finished.connect(self.report_outcome)
        self.evaluation.histograms.connect(self.inspector.set_histograms)
        self.evaluation.value_scales.connect(self.inspector.set_value_scales)
        self.evaluation.busy_changed.connect(self._busy_changed)
        self.evaluation.crashed.connect(self.log.error)
        self.evaluation.warning.connect(self.log.warning)
        self.evaluation.info.connect(self.log.info)
        self.evaluation.stalled.connect(self._stalled)
        self.evaluation.progress.connect(self._cluster_progress)
        self.canvases.problem.connect(self.log.error)

    # --- messages and dialogs -------------------------------------------------------------------
    def show_message(self, text: str) -> None:
        self.statusBar().showMessage(text)

    def report_error(self, title: str, message: str) -> None:
        self.log.error(message)
        QMessageBox.critical(self, title, message)

    def _update_title(self, *_) -> None:
        self.setWindowTitle(f"{self.workspace.display_name()}[*] - vgraph")
        self.setWindowModified(self.workspace.is_modified())

    # --- editing -------------------------------------------------------------------------------
    def add_processor(self, type_name: str):
        """Add from the palette: at the point Find Processor was asked at, else after the anchor
        (below or beside it, connected where unambiguous: placement.py), else mid-view."""
        anchor, at, self.insert_at = self.scene.anchor(), self.insert_at, None
        try:
            if at is not None:
                position = self.scene.free_position(at)
            elif anchor is not None:
                position = self.scene.spot_after(anchor, type_name)
            else:
                position = self.scene.free_position(self.view.mapToScene(self.view.viewport().rect().center()))
            processor = self.workspace.add_processor(type_name, position, after=anchor)
        except VGraphError as error:
            self.show_message(f"Cannot add {type_name}: {error}")
            return None
        self.scene.select_processor(processor.id)
        return processor

    def find_processor(self) -> None:
        """Edit > Find Processor (Ctrl+F): the palette's search, for a processor that goes where
        the mouse is in the network editor (else where it would go from the palette)."""
        self.welcome.show_editor()   # from the welcome page: the editor, to insert into
        cursor = self.view.viewport().mapFromGlobal(QCursor.pos())
        inside = self.view.viewport().rect().contains(cursor)
        self.insert_at = self.view.mapToScene(cursor) if inside else None
        self.palette_dock.show()
        self.palette_dock.raise_()
        self.palette.search.setFocus()
        self.palette.search.selectAll()

    def edit_links(self) -> None:
        LinkDialog(self.workspace, self).exec()

    def _set_auto_link(self, on: bool) -> None:
        self.workspace.auto_link_cameras = on

    def _select_all(self) -> None:
        for node in self.scene.nodes.values():
            node.setSelected(True)

    def _selection_changed(self) -> None:
        processors, _, _ = self.scene.selection()
        self.inspector.show_processor(processors[0] if len(processors) == 1 else None)

    def _network_replaced(self, network) -> None:
        self.view.resetTransform()   # New must not keep the last network's zoom (Open then fits)
        self.view.centerOn(0.0, 0.0)
        self.insert_at = None
        self.failures.clear()
        self.inspector.show_processor(None)

    def closeEvent(self, event) -> None:
        if not self.confirm_discard():
            event.ignore()
            return
        for view in (self.scene, self.inspector, self.canvases, self.welcome, self.markups_dock.widget(),
                     self.timeline_dock.widget()):
            view.detach()
        self.autosave.stop()
        self.autosave.remove()   # a clean exit: the changes were saved or discarded on purpose
        self.evaluation.shutdown()
        if self.remember_layout:
            self.perspectives.save()
            layout.save_layout(self, self.workspace.settings)
        event.accept()


def run_gui(path: str | Path | None = None, screenshot: str | Path | None = None,
            select: str | None = None, size: tuple[int, int] | None = None,
            render_as: str | None = None) -> int:
    """Start the GUI (optionally opening a network) and return the exit code. With ``screenshot``:
    wait until the canvases have rendered, save the whole window as a PNG and exit. ``render_as``
    ("labels", "intensity") overrides how a data file's values are taken (vgraph.file_kind)."""
    app = QApplication.instance() or QApplication([sys.argv[0] if sys.argv else "vgraph"])
    app.setApplicationName("vgraph")
    window = MainWindow()
    window.remember_layout = screenshot is None
    try:
        with log_exceptions(window):
            if size is not None:
                window.arrange(*size)
            window.show()
            if path is not None and screenshot is not None:
                window.workspace.open(path, render_as=render_as)  # a bad file: an error on stderr, not a dialog
                window.view.fit_network()
            elif path is not None:
                window.open_network(path, render_as=render_as)
            else:
                window.offer_recovery(window.autosave.newest_orphan())
            if select is not None:
                window.workspace.network[select]  # names the ids if there is no such processor
                window.scene.select_processor(select)
            if screenshot is not None:
                return save_screenshot(window, screenshot)
            return app.exec()
    finally:
        if screenshot is not None and window.isVisible():  # it failed halfway: do not leave it open
            window.workspace.undo_stack.setClean()
            window.close()


@contextmanager
def log_exceptions(window: MainWindow):
    """Send exceptions that escape slots and event handlers to the window's log: Qt would only
    print them, and the user would not know that something failed."""
    previous_hook = sys.excepthook

    def log_exception(kind, value, trace):
        window.log.error("internal error (please report it):\n"
                         + "".join(traceback.format_exception(kind, value, trace)))

    sys.excepthook = log_exception
    try:
        yield
    finally:
        sys.excepthook = previous_hook


def save_screenshot(window: MainWindow, path: str | Path) -> int:
    """Evaluate, let the window lay itself out, save it (atomically) and close it."""
    window.evaluation.run(wait=True)
    for _ in range(3):
        QApplication.processEvents()
    with atomic_path(path, suffix=".png") as temporary:
        if not window.grab().save(str(temporary), "PNG"):
            raise VGraphError(f"cannot write the screenshot {path}")
    for message in window.log.messages("error"):
        print(f"vgraph gui: {message}", file=sys.stderr)
    window.workspace.undo_stack.setClean()
    window.close()
    print(f"wrote {path}", file=sys.stderr)
    return 0
