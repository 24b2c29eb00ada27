"""The scripted user's input for bench/bench_gui_session.py: real X input from ``xdotool`` (under
Xvfb), or Qt events sent to the same widgets (the offscreen platform, the tests).

Each action is a generator: it yields what the session waits for before its next step (the
xdotool process it started, or seconds), so Qt goes on processing events meanwhile (the session's
Stepper). Points are in the widget's own coordinates; a mouse button is 1 (left), 2 (middle) or 3
(right), as X numbers them. A wheel notch forward (away from the user) is X's button 4 and
Qt's angleDelta +120.
"""

from __future__ import annotations

import shutil
import subprocess

MOVE_S = 0.016          # one mouse move per 60 Hz frame
CLICK_GAP_MS = 60       # between the clicks of a double-click and between wheel notches


class XdotoolInput:
    """Real X input. Each action yields the xdotool process it started."""

    def __init__(self):
        if shutil.which("xdotool") is None:
            raise SystemExit("--xvfb needs xdotool (apt install xdotool)")

    @staticmethod
    def _at(widget, point) -> list[str]:
        from PySide6.QtCore import QPoint
        spot = widget.mapToGlobal(QPoint(round(point.x()), round(point.y())))
        return [str(spot.x()), str(spot.y())]

    def _run(self, *args: str):
        yield subprocess.Popen(["xdotool", *args])

    def click(self, widget, point):
        yield from self._run("mousemove", "--sync", *self._at(widget, point), "click", "1")

    def double_click(self, widget, point):
        yield from self._run("mousemove", "--sync", *self._at(widget, point),
                             "click", "--repeat", "2", "--delay", str(CLICK_GAP_MS), "1")

    def press_and_move(self, widget, start, end, seconds: float, button: int = 1):
        """Press at ``start`` and move to ``end`` in ``seconds`` (the button stays down)."""
        steps = max(1, round(seconds / MOVE_S))
        moves = []
        for i in range(1, steps + 1):
            moves += ["mousemove", *self._at(widget, start + (end - start) * (i / steps)), "sleep", str(MOVE_S)]
        yield from self._run("mousemove", "--sync", *self._at(widget, start), "mousedown", str(button), *moves)

    def release(self, widget, point, button: int = 1):
        yield from self._run("mouseup", str(button))

    def wheel(self, widget, point, notches: int):
        """``notches`` wheel notches over ``point``: forward (positive) or back (negative)."""
        button = "4" if notches > 0 else "5"
        yield from self._run("mousemove", "--sync", *self._at(widget, point),
                             "click", "--repeat", str(abs(notches)), "--delay", str(CLICK_GAP_MS), button)

    def keys(self, widget, combo: str):
        """``combo`` in xdotool's spelling (ctrl+s, Return); goes to the focused window."""
        yield from self._run("key", "--clearmodifiers", combo)

    def type(self, widget, text: str):
        yield from self._run("type", "--delay", "15", text)


class QtInput:
    """Qt events sent to the widgets (no X server): the paths a test or the offscreen platform has.
    Keys go through a zero timer, since a shortcut may open a modal dialog (a nested event loop)."""

    KEYS = {"Return": "Key_Return", "ctrl+a": ("Key_A", "ControlModifier"), "ctrl+s": ("Key_S", "ControlModifier"),
            "ctrl+shift+s": ("Key_S", "ControlModifier|ShiftModifier"), "ctrl+o": ("Key_O", "ControlModifier"),
            "ctrl+n": ("Key_N", "ControlModifier"), "F9": "Key_F9"}

    @staticmethod
    def _button(button: int):
        from PySide6.QtCore import Qt
        return {1: Qt.LeftButton, 2: Qt.MiddleButton, 3: Qt.RightButton}[button]

    def click(self, widget, point):
        from PySide6.QtCore import Qt
        from PySide6.QtTest import QTest
        QTest.mouseClick(widget, Qt.LeftButton, Qt.NoModifier, point.toPoint())
        yield 0.0

    def double_click(self, widget, point):
        """A click, then the second press as a double-click (what the window system sends; a
        double-click event alone does not activate an item view's item)."""
        from PySide6.QtCore import Qt
        from PySide6.QtTest import QTest
        QTest.mouseClick(widget, Qt.LeftButton, Qt.NoModifier, point.toPoint())
        QTest.mouseDClick(widget, Qt.LeftButton, Qt.NoModifier, point.toPoint())
        yield 0.0

    def press_and_move(self, widget, start, end, seconds: float, button: int = 1):
        from PySide6.QtCore import QEvent, Qt
        from scripted_user import send_mouse
        held = self._button(button)
        send_mouse(widget, QEvent.MouseButtonPress, start, held, held)
        steps = max(1, round(seconds / MOVE_S))
        for i in range(1, steps + 1):
            yield MOVE_S
            send_mouse(widget, QEvent.MouseMove, start + (end - start) * (i / steps), Qt.NoButton, held)

    def release(self, widget, point, button: int = 1):
        from PySide6.QtCore import QEvent, Qt
        from scripted_user import send_mouse
        send_mouse(widget, QEvent.MouseButtonRelease, point, self._button(button), Qt.NoButton)
        yield 0.0

    def wheel(self, widget, point, notches: int):
        from PySide6.QtCore import QPoint, QPointF, Qt
        from PySide6.QtGui import QWheelEvent
        from PySide6.QtWidgets import QApplication
        for _ in range(abs(notches)):
            delta = QPoint(0, 120 if notches > 0 else -120)
            event = QWheelEvent(QPointF(point), QPointF(widget.mapToGlobal(point.toPoint())), QPoint(), delta,
                                Qt.NoButton, Qt.NoModifier, Qt.NoScrollPhase, False)
            QApplication.sendEvent(widget, event)
            yield CLICK_GAP_MS / 1000

    def keys(self, widget, combo: str):
        from PySide6.QtCore import Qt, QTimer
        from PySide6.QtTest import QTest
        from PySide6.QtWidgets import QApplication
        key, modifiers = self.KEYS[combo] if isinstance(self.KEYS[combo], tuple) else (self.KEYS[combo], "NoModifier")
        flags = Qt.KeyboardModifier(0)
        for name in modifiers.split("|"):
            flags |= getattr(Qt, name)
        target = QApplication.focusWidget() or widget
        QTimer.singleShot(0, lambda: QTest.keyClick(target, getattr(Qt, key), flags))
        yield 0.01

    def type(self, widget, text: str):
        from PySide6.QtTest import QTest
        from PySide6.QtWidgets import QApplication
        QTest.keyClicks(QApplication.focusWidget() or widget, text)
        yield 0.0
