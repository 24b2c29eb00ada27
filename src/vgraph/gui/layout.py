"""The main window's layout: its first-run size, the dock layout remembered between runs, the
View menu's list of docks and View > Reset Layout.

Conventions:
- The first run fits the screen it opens on (``FIRST_RUN_FRACTION`` of the available geometry), not
  a fixed size that a laptop screen cuts off; on a screen too small for that fraction to hold the
  inspector (under ``SMALL_SCREEN``: a 1280 x 800 laptop), all of the available area.
- Columns: the palette with the canvases below it on the left, the network editor in the middle,
  the property inspector on the right, the log under the left and middle columns. The inspector
  is as wide as the widest property editor (no horizontal scroll bar) and runs the window's full
  height (a RayCaster's form down to its transfer-function editor is ~700 px: it did not fit
  under a canvas at 1280 x 800). The canvas column takes ``CANVAS_FRACTION`` of the width, less
  if the network editor would get under ``MIN_NETWORK_WIDTH``; the canvases get
  ``CANVAS_SHARE`` of its height, the palette the rest.
- Geometry and dock state go into the window's QSettings when it closes and come back when a
  window starts with the same settings; a stored state that Qt refuses falls back to the first-run
  layout. Canvas docks come and go with the network, so a restored state places only the fixed docks.
- The View menu's dock list is rebuilt each time the menu opens: canvas docks appear later.
"""

from __future__ import annotations

from PySide6.QtCore import QPoint, QRect, QSettings, Qt
from PySide6.QtGui import QGuiApplication
from PySide6.QtWidgets import QDockWidget, QFormLayout, QLabel, QMainWindow, QMenu, QScrollArea, QWidget

from vgraph.gui.editors import editor_for
from vgraph.registry import registry

FIRST_RUN_FRACTION = 0.85
SMALL_SCREEN = (1280, 800)   # the first run takes at least this much of the screen (all, if smaller)
GEOMETRY_KEY = "window/geometry"
STATE_KEY = "window/state"
STATE_VERSION = 2          # raise when the fixed docks change, so an old state is not applied
FALLBACK_SIZE = (1280, 800)  # no screen (should not happen, even offscreen)
# The inspector's margins, the scroll area's frame and its vertical scroll bar around the form.
INSPECTOR_CHROME = 48
CANVAS_FRACTION = 0.3      # of the window's width, for the canvas column ...
MIN_NETWORK_WIDTH = 300    # ... as long as the network editor keeps this much
CANVAS_SHARE = 2 / 3       # of the left column's height, for the canvases (the palette above)


def first_run_size(window: QMainWindow) -> tuple[int, int]:
    screen = window.screen() or QGuiApplication.primaryScreen()
    if screen is None:
        return FALLBACK_SIZE
    available = screen.availableGeometry()
    return (max(int(available.width() * FIRST_RUN_FRACTION), min(available.width(), SMALL_SCREEN[0])),
            max(int(available.height() * FIRST_RUN_FRACTION), min(available.height(), SMALL_SCREEN[1])))


def widest_editor_width() -> int:
    """The width of an inspector form holding every built-in processor's editors (labels
    included): the width at which no processor needs a horizontal scroll bar."""
    host = QWidget()
    form = QFormLayout(host)
    for cls in registry.all():
        try:
            processor = cls(id="measure")
        except Exception:  # noqa: BLE001 - a plug-in that cannot be made bare is not measured
            continue
        for prop in processor.properties.values():
            form.addRow(QLabel(prop.label), editor_for(prop, processor))
    width = host.sizeHint().width()
    host.deleteLater()
    return width + INSPECTOR_CHROME


def inspector_width(width: int) -> int:
    """The widest editor's width, at least 9/25 of the window and at most half of it."""
    return max(width * 9 // 25, min(widest_editor_width(), width // 2))


def canvas_column_width(window) -> int:
    width = window.width()
    room = width - inspector_width(width) - MIN_NETWORK_WIDTH
    return max(window.palette_dock.minimumSizeHint().width(), min(int(width * CANVAS_FRACTION), room))


def arrange(window, width: int, height: int) -> None:
    """Size the window and its columns (see the module docstring)."""
    window.resize(width, height)
    window.setCorner(Qt.BottomRightCorner, Qt.RightDockWidgetArea)  # the inspector runs to the bottom
    window.resizeDocks([window.properties_dock], [inspector_width(width)], Qt.Horizontal)
    window.resizeDocks([window.log_dock], [max(100, height // 8)], Qt.Vertical)
    canvases = [dock for dock in window.canvases.docks.values() if not dock.isFloating()]
    if canvases:
        _size_canvas_column(window, canvases[0])


def place_canvas(window, dock: QDockWidget, siblings: list[QDockWidget]) -> None:
    """Put a new canvas dock where the layout wants it: the first below the palette (widening the
    left column), the others tabbed with the first."""
    if siblings:
        window.addDockWidget(Qt.LeftDockWidgetArea, dock)
        window.tabifyDockWidget(siblings[0], dock)
        return
    palette = window.palette_dock
    window.addDockWidget(Qt.LeftDockWidgetArea, dock)
    if window.dockWidgetArea(palette) == Qt.LeftDockWidgetArea and not palette.isFloating():
        window.splitDockWidget(palette, dock, Qt.Vertical)
    _size_canvas_column(window, dock)


def _size_canvas_column(window, dock: QDockWidget) -> None:
    window.resizeDocks([dock], [canvas_column_width(window)], Qt.Horizontal)
    palette = window.palette_dock
    if window.dockWidgetArea(palette) == window.dockWidgetArea(dock) and palette.isVisible():
        column = palette.height() + dock.height() or window.height()
        share = int(column * CANVAS_SHARE)
        window.resizeDocks([palette, dock], [column - share, share], Qt.Vertical)


def restore_layout(window, settings: QSettings) -> bool:
    """Put back the geometry and dock layout of the last run; False (and nothing changed) if
    there is none or Qt refuses it."""
    window.setCorner(Qt.BottomRightCorner, Qt.RightDockWidgetArea)
    geometry, state = settings.value(GEOMETRY_KEY), settings.value(STATE_KEY)
    if geometry is None or state is None:
        return False
    return bool(window.restoreGeometry(geometry) and window.restoreState(state, STATE_VERSION))


def save_layout(window, settings: QSettings) -> None:
    settings.setValue(GEOMETRY_KEY, window.saveGeometry())
    settings.setValue(STATE_KEY, window.saveState(STATE_VERSION))
    settings.sync()


def reset_layout(window) -> None:
    """The first-run layout: every fixed dock shown in its own area, the canvases below the
    palette, the window fitted to the screen again."""
    if window.isMaximized() or window.isFullScreen():
        window.showNormal()
    for dock, area in window.home_areas().items():
        dock.setFloating(False)
        window.addDockWidget(area, dock)
        dock.show()
    for dock in window.log_tabs():
        _tab_with_log(window, dock)
    canvases = list(window.canvases.docks.values())
    for index, dock in enumerate(canvases):
        dock.setFloating(False)
        place_canvas(window, dock, canvases[:index])
        dock.show()
    arrange(window, *first_run_size(window))
    settings = window.workspace.settings
    settings.remove(GEOMETRY_KEY), settings.remove(STATE_KEY)


def log_tab(window, title: str, panel) -> QDockWidget:
    """A dock tabbed with the Log and hidden until View shows it (Markups, Tables, Timeline); the
    panel's ``status_message`` goes to the status bar."""
    dock = QDockWidget(title, window)
    dock.setObjectName(title)
    dock.setWidget(panel)
    _tab_with_log(window, dock)
    panel.status_message.connect(window.statusBar().showMessage)
    return dock


def _tab_with_log(window, dock: QDockWidget) -> None:
    dock.setFloating(False)
    window.addDockWidget(Qt.BottomDockWidgetArea, dock)
    window.tabifyDockWidget(window.log_dock, dock)
    dock.hide()


def shown_whole(widget: QWidget) -> bool:
    """Whether all of ``widget`` is on screen: visible, and inside the viewport of the scroll area
    holding it, if any (the check behind docs/guide/gui.md's screenshots: nothing cut off)."""
    if widget is None or not widget.isVisible():
        return False
    area = widget.parent()
    while area is not None and not isinstance(area, QScrollArea):
        area = area.parent()
    if area is None:
        return True
    viewport = area.viewport()
    corner = widget.mapTo(viewport, QPoint(0, 0))
    return viewport.rect().contains(QRect(corner, widget.size()))


def fill_dock_menu(menu: QMenu, window: QMainWindow, before) -> None:
    """Keep one show/hide action per dock (fixed ones first, then canvases) in ``menu`` above
    ``before``; called when the menu is about to show."""
    for action in getattr(menu, "_dock_actions", []):
        menu.removeAction(action)
    docks = sorted(window.findChildren(QDockWidget), key=lambda d: (d.objectName().startswith("canvas:"),
                                                                    d.windowTitle()))
    menu._dock_actions = [dock.toggleViewAction() for dock in docks]
    menu.insertActions(before, menu._dock_actions)
