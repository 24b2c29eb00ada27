"""A canvas view alone (tests/test_gui_canvas.py, test_gui_clip_drag.py): shown at SIZE, and a
mouse drag in it (pytest-qt, QT_QPA_PLATFORM=offscreen)."""

from PySide6.QtCore import QEvent, Qt

from vgraph.gui.canvas_view import CanvasView

from helpers.gui import send_mouse

SIZE = (200, 160)  # widget width, height


def make_view(qtbot, ws, canvas_id="canvas"):
    view = CanvasView(ws, canvas_id)
    qtbot.addWidget(view)
    view.resize(*SIZE)
    view.show()
    qtbot.waitExposed(view)
    return view


def drag(view, start, end, button=Qt.LeftButton, modifiers=Qt.NoModifier, steps=5):
    send_mouse(view, QEvent.MouseButtonPress, start, button, button, modifiers)
    for i in range(1, steps + 1):
        t = i / steps
        pos = (start[0] + (end[0] - start[0]) * t, start[1] + (end[1] - start[1]) * t)
        send_mouse(view, QEvent.MouseMove, pos, Qt.NoButton, button, modifiers)
    send_mouse(view, QEvent.MouseButtonRelease, end, button, Qt.NoButton, modifiers)
