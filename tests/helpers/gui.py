"""Mouse helpers for the GUI tests (pytest-qt, QT_QPA_PLATFORM=offscreen); the ``window`` fixture
is in conftest.py."""

from PySide6.QtCore import QPointF, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import QApplication


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
