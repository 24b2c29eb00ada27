"""The main window's layout: its first-run size, the dock layout remembered between runs, the
View menu's list of docks and View > Reset Layout.

Conventions:
- The first run fits the screen it opens on (``FIRST_RUN_FRACTION`` of the available geometry), not
  a fixed size that a laptop screen cuts off; the right column (canvases, inspector) is as wide as
  the widest property editor, so the inspector needs no horizontal scroll bar.
- Geometry and dock state go into the window's QSettings when it closes and come back when a
  window starts with the same settings; a stored state that Qt refuses falls back to the first-run
  layout. Canvas docks come and go with the network, so a restored state places only the fixed docks.
- The View menu's dock list is rebuilt each time the menu opens: canvas docks appear later.
"""

from __future__ import annotations

from PySide6.QtCore import QSettings, Qt
from PySide6.QtGui import QGuiApplication
from PySide6.QtWidgets import QDockWidget, QFormLayout, QLabel, QMainWindow, QMenu, QWidget

FIRST_RUN_FRACTION = 0.85
GEOMETRY_KEY = "window/geometry"
STATE_KEY = "window/state"
STATE_VERSION = 1          # raise when the fixed docks change, so an old state is not applied
FALLBACK_SIZE = (1280, 800)  # no screen (should not happen, even offscreen)
# The inspector's margins, the scroll area's frame and its vertical scroll bar around the form.
INSPECTOR_CHROME = 48


def first_run_size(window: QMainWindow) -> tuple[int, int]:
    screen = window.screen() or QGuiApplication.primaryScreen()
    if screen is None:
        return FALLBACK_SIZE
    available = screen.availableGeometry()
    return int(available.width() * FIRST_RUN_FRACTION), int(available.height() * FIRST_RUN_FRACTION)


def widest_editor_width() -> int:
    """The width of an inspector form holding every built-in processor's editors (labels
    included): the width at which no processor needs a horizontal scroll bar."""
    from vgraph.gui.editors import editor_for
    from vgraph.registry import registry

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


def arrange(window, width: int, height: int) -> None:
    """Size the window; the right column gets the widest editor's width, at least a third of the
    window and at most half of it (the network editor stays usable)."""
    window.resize(width, height)
    column = max(width * 9 // 25, min(widest_editor_width(), width // 2))
    window.resizeDocks([window.properties_dock], [column], Qt.Horizontal)
    window.resizeDocks([window.log_dock], [max(100, height // 8)], Qt.Vertical)


def restore_layout(window, settings: QSettings) -> bool:
    """Put back the geometry and dock layout of the last run; False (and nothing changed) if
    there is none or Qt refuses it."""
    geometry, state = settings.value(GEOMETRY_KEY), settings.value(STATE_KEY)
    if geometry is None or state is None:
        return False
    return bool(window.restoreGeometry(geometry) and window.restoreState(state, STATE_VERSION))


def save_layout(window, settings: QSettings) -> None:
    settings.setValue(GEOMETRY_KEY, window.saveGeometry())
    settings.setValue(STATE_KEY, window.saveState(STATE_VERSION))
    settings.sync()


def reset_layout(window) -> None:
    """The first-run layout: every fixed dock shown in its own area, the canvases above the
    inspector, the window fitted to the screen again."""
    if window.isMaximized() or window.isFullScreen():
        window.showNormal()
    for dock, area in window.home_areas().items():
        dock.setFloating(False)
        window.addDockWidget(area, dock)
        dock.show()
    canvases = list(window.canvases.docks.values())
    for index, dock in enumerate(canvases):
        dock.setFloating(False)
        window.addDockWidget(Qt.RightDockWidgetArea, dock)
        if index == 0:
            window.splitDockWidget(dock, window.properties_dock, Qt.Vertical)
        else:
            window.tabifyDockWidget(canvases[0], dock)
        dock.show()
    arrange(window, *first_run_size(window))
    settings = window.workspace.settings
    settings.remove(GEOMETRY_KEY), settings.remove(STATE_KEY)


def fill_dock_menu(menu: QMenu, window: QMainWindow, before) -> None:
    """Keep one show/hide action per dock (fixed ones first, then canvases) in ``menu`` above
    ``before``; called when the menu is about to show."""
    for action in getattr(menu, "_dock_actions", []):
        menu.removeAction(action)
    docks = sorted(window.findChildren(QDockWidget), key=lambda d: (d.objectName().startswith("canvas:"),
                                                                    d.windowTitle()))
    menu._dock_actions = [dock.toggleViewAction() for dock in docks]
    menu.insertActions(before, menu._dock_actions)
