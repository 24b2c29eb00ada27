"""Two perspectives of the main window, as Voreen's development and application modes.

- ``editing``: today's layout, the network editor in the middle (layout.py).
- ``views``: the canvases take the centre of the window: the network editor, the palette and the
  log are hidden, the canvases fill the room they leave, and the properties of the selected
  processor sit in a side panel as wide as what it shows (``properties_width``), at most
  ``MAX_PROPERTIES_FRACTION`` of the window.
  The canvases: one 3D view (a canvas with a camera upstream) and two or three slice views (no
  camera: SliceViewer) as Slicer's "3D + 3 slices": the 3D view large on the left
  (``MAIN_VIEW_FRACTION`` of the canvases' width), the slices stacked beside it; otherwise one
  alone, two side by side, three or four in a 2 x 2 grid, as Slicer's "Four-Up" (canvas_grid.py).

Switching: the View menu, the Perspective toolbar, or F9 to toggle (Ctrl+1 and the like are the
canvases' view keys: canvas_toolbar.py). Each
perspective's dock and splitter state (QMainWindow.saveState) is kept in the window's QSettings
under ``perspective/<name>/state`` when it is left, and put back when it is entered again; which
one is current (``perspective/current``) comes back with a new window. A perspective never entered
gets its default arrangement; View > Reset Layout goes back to the editing perspective's first-run
layout and forgets both. While there is no network the views perspective shows the welcome page
(welcome.py) in the middle, so that an empty window always offers a start.

Canvas docks come and go with the network: whenever a canvas is added or removed while the views
perspective is current (one at a time, by an edit, undo or redo), the canvases are tiled again as
above once the event loop is back (an undo that brings back several canvases re-tiles once),
instead of the new one being tabbed behind the others.
"""

from __future__ import annotations

from PySide6.QtCore import QObject, QTimer, Qt
from PySide6.QtGui import QAction, QActionGroup, QKeySequence
from PySide6.QtWidgets import QApplication, QMainWindow, QToolBar

from vgraph.gui import canvas_grid
from vgraph.gui.canvas_mouse import camera_property_for
from vgraph.gui.layout import INSPECTOR_CHROME, STATE_VERSION, reset_layout

EDITING, VIEWS = "editing", "views"
TITLES = {EDITING: "&Edit Network", VIEWS: "&Views"}
TOGGLE_KEY = "F9"
CURRENT_KEY = "perspective/current"
MIN_PROPERTIES_WIDTH = 220
MAX_PROPERTIES_FRACTION = 0.3
MAIN_VIEW_FRACTION = 2 / 3


def state_key(name: str) -> str:
    return f"perspective/{name}/state"


def properties_width(window: QMainWindow) -> int:
    """The width the inspector's form asks for, within [MIN_PROPERTIES_WIDTH, 30 % of the window]."""
    wanted = window.inspector.form_host.sizeHint().width() + INSPECTOR_CHROME
    return max(MIN_PROPERTIES_WIDTH, min(wanted, int(window.width() * MAX_PROPERTIES_FRACTION)))


class Perspectives(QObject):
    def __init__(self, window: QMainWindow):
        super().__init__(window)
        self.window = window
        self.settings = window.workspace.settings
        self.current = EDITING
        self.central = None   # the central widget while the views perspective has taken it out
        self.actions: dict[str, QAction] = {}
        group = QActionGroup(self)
        for name in (EDITING, VIEWS):
            action = QAction(TITLES[name].replace("&", ""), window, checkable=True)
            action.setText(TITLES[name])
            action.setToolTip(f"{TITLES[name].replace('&', '')} perspective ({TOGGLE_KEY} toggles)")
            action.triggered.connect(lambda _=False, n=name: self.switch(n))
            group.addAction(action)
            self.actions[name] = action
        self.actions[EDITING].setChecked(True)
        self.toggle_action = QAction("&Toggle Perspective", window)
        self.toggle_action.setShortcut(QKeySequence(TOGGLE_KEY))
        self.toggle_action.triggered.connect(self.toggle)
        self.toolbar = QToolBar("Perspective", window)
        self.toolbar.setObjectName("Perspective")   # saveState needs it
        self.toolbar.addActions(list(self.actions.values()))
        window.addToolBar(Qt.TopToolBarArea, self.toolbar)
        window.workspace.network_replaced.connect(self._network_replaced)
        self._retile = QTimer(self, singleShot=True, interval=0)
        self._retile.timeout.connect(self._retile_canvases)
        window.canvases.docks_changed.connect(self._canvases_changed)
        window.scene.selectionChanged.connect(self._selection_changed)

    def menu_actions(self) -> list[QAction]:
        return [*self.actions.values(), self.toggle_action]

    def toggle(self) -> None:
        self.switch(VIEWS if self.current == EDITING else EDITING)

    def switch(self, name: str) -> None:
        """Keep the current perspective's state, then enter ``name``'s (remembered or default)."""
        if name == self.current:
            self.actions[name].setChecked(True)
            return
        self.settings.setValue(state_key(self.current), self.window.saveState(STATE_VERSION))
        self.enter(name)

    def enter(self, name: str) -> None:
        self.current = name
        self.settings.setValue(CURRENT_KEY, name)
        self.actions[name].setChecked(True)
        self._show_central()
        state = self.settings.value(state_key(name))
        if state is None or not self.window.restoreState(state, STATE_VERSION):
            self._default(name)
        elif name == VIEWS:
            self.tile_canvases()   # the network's canvases may not be those of the saved state
        self.settings.sync()

    def restore(self) -> None:
        """A new window: back to the perspective the last one was left in (its state is the
        window's, restored by layout.restore_layout)."""
        if self.settings.value(CURRENT_KEY) == VIEWS:
            self.current = VIEWS
            self.actions[VIEWS].setChecked(True)
            self._show_central()

    def _show_central(self) -> None:
        """The editor in the editing perspective; in the views one only the welcome page, while
        there is no network (an empty views perspective would show nothing to start from)."""
        self._show_editor(self.current == EDITING or not self.window.workspace.network.processors)

    def _show_editor(self, shown: bool) -> None:
        """Put the central widget (the network editor) in or take it out: a hidden central
        widget keeps its room, a taken one leaves it to the docks."""
        window = self.window
        if shown and window.centralWidget() is None:
            window.setCentralWidget(self.central)
            self.central.show()
        elif not shown and window.centralWidget() is not None:
            self.central = window.takeCentralWidget()
            self.central.hide()

    def _default(self, name: str) -> None:
        window = self.window
        if name == EDITING:
            reset_layout(window)
            return
        for dock in (window.palette_dock, window.log_dock):
            dock.hide()
        window.properties_dock.show()
        self.tile_canvases()

    def save(self) -> None:
        """The window closes: keep the current perspective's state too."""
        self.settings.setValue(state_key(self.current), self.window.saveState(STATE_VERSION))
        self.settings.setValue(CURRENT_KEY, self.current)

    def tile_canvases(self) -> None:
        """The canvases side by side or in a grid, the properties panel fitted to its form."""
        window = self.window
        docks = [dock for dock in window.canvases.docks.values() if not dock.isFloating()]
        for dock in docks:
            dock.show()
        main, slices = self._main_and_slices(docks)
        if main is not None:
            self._main_beside_slices(main, slices)
        else:
            canvas_grid.tile_canvases(window, docks)
        QApplication.processEvents()   # the grid's layout first, or the resizes below are lost
        self.fit_properties(main)

    def _main_and_slices(self, docks: list) -> tuple:
        """(the 3D view's dock, the slice views' docks) for "3D + slices", else (None, [])."""
        network, ids = self.window.workspace.network, {id(d): pid for pid, d in self.window.canvases.docks.items()}
        with_camera = [d for d in docks if camera_property_for(network, ids[id(d)]) is not None]
        slices = [d for d in docks if d not in with_camera]
        if len(with_camera) == 1 and 2 <= len(slices) <= 3:
            return with_camera[0], slices
        return None, []

    def _main_beside_slices(self, main, slices: list) -> None:
        window = self.window
        for dock in [main, *slices]:
            window.removeDockWidget(dock)
        QApplication.processEvents()   # lets an emptied tab bar go (as canvas_grid does)
        window.addDockWidget(Qt.LeftDockWidgetArea, main)
        window.splitDockWidget(main, slices[0], Qt.Horizontal)
        for above, below in zip(slices, slices[1:]):
            window.splitDockWidget(above, below, Qt.Vertical)
        for dock in [main, *slices]:
            dock.setFloating(False)
            dock.show()
        window.resizeDocks(slices, [window.height() // len(slices)] * len(slices), Qt.Vertical)

    def fit_properties(self, main=None) -> None:
        """The properties panel as wide as its form; the canvases' columns share the rest (the
        3D view ``main``, if any, gets MAIN_VIEW_FRACTION of it)."""
        window, dock = self.window, self.window.properties_dock
        if not dock.isVisible() or dock.isFloating():
            return
        width = properties_width(window)
        window.resizeDocks([dock], [width], Qt.Horizontal)
        columns, room = self._first_row(), window.width() - width
        if main is not None and len(columns) == 2:
            window.resizeDocks(columns, [int(room * MAIN_VIEW_FRACTION), room - int(room * MAIN_VIEW_FRACTION)],
                               Qt.Horizontal)
        elif columns:
            window.resizeDocks(columns, [room // len(columns)] * len(columns), Qt.Horizontal)

    def _first_row(self) -> list:
        """The visible canvas docks at the top of the grid, left to right."""
        docks = [d for d in self.window.canvases.docks.values() if d.isVisible() and not d.isFloating()]
        top = min((d.y() for d in docks), default=0)
        return sorted((d for d in docks if d.y() == top), key=lambda d: d.x())

    def _network_replaced(self, _network) -> None:
        if self.current == VIEWS:
            self._show_central()
            self.tile_canvases()

    def _canvases_changed(self) -> None:
        if self.current == VIEWS:
            self._retile.start()

    def _retile_canvases(self) -> None:
        if self.current == VIEWS:
            self._show_central()   # the first canvas of an empty network takes the welcome's place
            self.tile_canvases()

    def reset(self) -> None:
        """View > Reset Layout: the editing perspective's first-run layout; both perspectives'
        stored states are forgotten."""
        self.current = EDITING
        self.actions[EDITING].setChecked(True)
        self._show_central()
        for name in (EDITING, VIEWS):
            self.settings.remove(state_key(name))
        self.settings.setValue(CURRENT_KEY, EDITING)
        reset_layout(self.window)

    def _selection_changed(self) -> None:
        if self.current == VIEWS:
            QTimer.singleShot(0, self.fit_properties)   # after the inspector has shown the new form
