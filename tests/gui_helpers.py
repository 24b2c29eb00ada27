"""Fixtures and helpers shared by the GUI tests (pytest-qt, QT_QPA_PLATFORM=offscreen)."""

import pytest
from PySide6.QtCore import QPointF, QSettings, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import QApplication

import toy_processors
import vgraph

for cls in toy_processors.ALL:
    vgraph.register(cls)


@pytest.fixture
def window(qtbot, tmp_path, renderer):
    """A shown main window with its own settings file (recent files do not touch the user's)."""
    from vgraph.gui.app import MainWindow
    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)
    main = MainWindow(settings, renderer)
    main.show()
    qtbot.waitExposed(main)
    yield main
    main.workspace.undo_stack.setClean()  # no unsaved-changes prompt on closing
    main.close()                           # closeEvent detaches the views from the network
    main.deleteLater()


def view_point(window, scene_pos: QPointF):
    return window.view.mapFromScene(scene_pos)


def drag(qtbot, window, start: QPointF, end: QPointF, steps: int = 4, release: bool = True):
    """Press at ``start``, move to ``end`` in steps, release (all in scene coordinates)."""
    viewport = window.view.viewport()
    qtbot.mousePress(viewport, Qt.LeftButton, pos=view_point(window, start))
    for i in range(1, steps + 1):
        qtbot.mouseMove(viewport, view_point(window, start + (end - start) * (i / steps)))
    if release:
        qtbot.mouseRelease(viewport, Qt.LeftButton, pos=view_point(window, end))


def port_position(window, processor_id: str, direction: str, name: str) -> QPointF:
    return window.scene.nodes[processor_id].port(direction, name).scenePos()


def send_mouse(view, kind, pos, button, buttons, modifiers=Qt.NoModifier):
    # Explicit buttons: QTest.mouseMove does not reliably report held buttons.
    point = QPointF(*pos)
    event = QMouseEvent(kind, point, view.mapToGlobal(point), button, buttons, modifiers)
    QApplication.sendEvent(view, event)
