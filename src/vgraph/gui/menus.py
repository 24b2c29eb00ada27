"""The main window's actions and menus: File (with Open Recent), Edit, View (the docks, Tile
Canvases, Reset Layout, the perspectives), Network and Help (help.py). ``WindowMenus`` is mixed
into ``MainWindow`` (app.py); the slots are the window's (and its FileActions' and
RenderStatus's).

Conventions:
- Each action is an attribute of the window (``new_action``, ``undo_action``, ...), so tests and
  other views trigger the same action a user does.
- The View menu's docks sit between two separators and are filled each time the menu opens
  (``refresh_dock_menu``, layout.fill_dock_menu): canvas docks come and go with the network.
"""

from __future__ import annotations

from PySide6.QtGui import QAction, QKeySequence

from vgraph.gui import canvas_grid
from vgraph.gui import layout
from vgraph.gui.help import build_help_menu, redo_keys


class WindowMenus:
    """The actions and menus of a MainWindow (a mix-in before QMainWindow)."""

    def refresh_dock_menu(self) -> None:
        layout.fill_dock_menu(self.view_menu, self, before=self.reset_layout_action)

    def _action(self, text: str, slot, shortcut=None, checkable=False, checked=False) -> QAction:
        action = QAction(text, self)
        if shortcut is not None:
            action.setShortcut(QKeySequence(shortcut))
        action.setCheckable(checkable)
        if checkable:
            action.setChecked(checked)
            action.toggled.connect(slot)
        else:
            action.triggered.connect(lambda *_: slot())
        return action

    def _build_actions(self) -> None:
        stack = self.workspace.undo_stack
        self.new_action = self._action("&New", self.new_network, QKeySequence.New)
        self.open_action = self._action("&Open...", self.open_network, QKeySequence.Open)
        self.save_action = self._action("&Save", self.save_network, QKeySequence.Save)
        self.save_as_action = self._action("Save &As...", self.save_network_as, QKeySequence.SaveAs)
        self.export_image_action = self._action("&Export Image...", self.export_image, "Ctrl+E")
        self.quit_action = self._action("&Quit", self.close, QKeySequence.Quit)
        self.undo_action = stack.createUndoAction(self, "&Undo")
        self.undo_action.setShortcut(QKeySequence.Undo)
        self.redo_action = stack.createRedoAction(self, "&Redo")
        self.redo_action.setShortcuts(redo_keys(QKeySequence.keyBindings(QKeySequence.Redo)))
        self.delete_action = self._action("&Delete", self.scene.delete_selected, QKeySequence.Delete)
        self.select_all_action = self._action("Select &All", self._select_all, QKeySequence.SelectAll)
        self.links_action = self._action("Property &Links...", self.edit_links, "Ctrl+L")
        self.find_action = self._action("&Find Processor...", self.find_processor, QKeySequence.Find)
        self.auto_link_action = self._action("Auto-link &Cameras", self._set_auto_link, checkable=True,
                                             checked=self.workspace.auto_link_cameras)
        self.zoom_in_action = self._action("Zoom &In", lambda: self.view.zoom(1.25), QKeySequence.ZoomIn)
        self.zoom_out_action = self._action("Zoom &Out", lambda: self.view.zoom(0.8), QKeySequence.ZoomOut)
        self.fit_action = self._action("&Fit Network", self.view.fit_network, "Ctrl+0")
        self.show_links_action = self._action("Show Property Links", self.scene.set_links_visible,
                                              checkable=True, checked=True)
        self.evaluate_action = self._action("&Evaluate Now", self.evaluation.run, "F5")
        self.writers_action = self._action("Run &Writers", lambda: self.evaluation.run(include_writers=True),
                                           "Ctrl+R")
        self.cancel_action = self._action("&Cancel Rendering", self.cancel_rendering)
        self.reset_layout_action = self._action("&Reset Layout", lambda: self.perspectives.reset())
        self.tile_canvases_action = self._action(  # side by side, e.g. a multi-planar layout
            "&Tile Canvases", lambda: canvas_grid.tile_canvases(self, list(self.canvases.docks.values())))
        self.cancel_action.setEnabled(False)
        self.cluster_action = self._action("Render on C&luster...", self.edit_cluster)

    def _build_menus(self) -> None:
        bar = self.menuBar()
        file_menu = bar.addMenu("&File")
        file_menu.addActions([self.new_action, self.open_action])
        self.recent_menu = file_menu.addMenu("Open &Recent")
        file_menu.addActions([self.save_action, self.save_as_action, self.export_image_action])
        file_menu.addSeparator()
        file_menu.addAction(self.quit_action)
        edit_menu = bar.addMenu("&Edit")
        edit_menu.addActions([self.undo_action, self.redo_action])
        edit_menu.addSeparator()
        edit_menu.addActions([self.delete_action, self.select_all_action, self.find_action])
        edit_menu.addSeparator()
        edit_menu.addActions([self.links_action, self.auto_link_action])
        self.view_menu = view_menu = bar.addMenu("&View")
        view_menu.addActions([self.zoom_in_action, self.zoom_out_action, self.fit_action,
                              self.show_links_action])
        view_menu.addSeparator()
        view_menu.addSeparator()  # the docks go between the separators: canvas docks come and go
        view_menu.addActions([self.tile_canvases_action, self.canvases.hover.corner_action,
                              self.reset_layout_action])
        view_menu.addSeparator()
        view_menu.addActions(self.perspectives.menu_actions())
        view_menu.aboutToShow.connect(self.refresh_dock_menu)
        self.refresh_dock_menu()
        network_menu = bar.addMenu("&Network")
        network_menu.addActions([self.evaluate_action, self.writers_action, self.cancel_action,
                                 self.cluster_action])
        build_help_menu(self)
        self._fill_recent_menu(self.workspace.recent_files())

    def _fill_recent_menu(self, files: list[str]) -> None:
        self.recent_menu.clear()
        for path in files:
            self.recent_menu.addAction(path).triggered.connect(lambda *_, p=path: self.open_network(p))
        self.recent_menu.setEnabled(bool(files))
