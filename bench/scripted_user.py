"""A scripted user: the edits a person makes in the window, done with real input events.

Used by the soak benchmark (``bench/gui_soak.py``, half an hour of use) and by its bounded version
in the tests, so both exercise the same paths a user does: mouse events on the network editor's
viewport, the canvas and the transfer-function plot, values typed into the inspector's editors,
the window's Delete/Undo/Redo actions.

Conventions:
- Each action leaves the network as it found it (or one undo away from it), so the loop can run
  for hours without the network drifting: a node dragged away is dragged back next time, a
  connection deleted is restored by undo, redo, undo... and then made again with the mouse.
- The network must have the shape of ``networks/raycast_sphere.json``: a RayCaster ``rc`` (camera,
  transfer function, ``sampling_rate``) feeding a Canvas ``canvas`` through ``rc.image``.
- ``settle()`` waits (processing events) until the render process has caught up with every change.
"""

from __future__ import annotations

import itertools
import time

from PySide6.QtCore import QEvent, QPointF, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QApplication, QWidget

from vgraph.gui.items import NODE_HEIGHT, NODE_WIDTH
from vgraph.network import Connection

RAY_CASTER, CANVAS = "rc", "canvas"
IMAGE_CONNECTION = Connection(RAY_CASTER, "image", CANVAS, "image")
SAMPLING_RATES = (0.5, 1.0, 1.5, 1.0)
DRAG_STEPS = 6


def send_mouse(widget: QWidget, kind, pos: QPointF, button, buttons) -> None:
    # Explicit buttons on every event: QTest's moves do not report the held button.
    event = QMouseEvent(kind, pos, widget.mapToGlobal(pos), button, buttons, Qt.NoModifier)
    QApplication.sendEvent(widget, event)


def mouse_drag(widget: QWidget, start: QPointF, end: QPointF, button=Qt.LeftButton, steps=DRAG_STEPS) -> None:
    send_mouse(widget, QEvent.MouseButtonPress, start, button, button)
    for i in range(1, steps + 1):
        send_mouse(widget, QEvent.MouseMove, start + (end - start) * (i / steps), Qt.NoButton, button)
    send_mouse(widget, QEvent.MouseButtonRelease, end, button, Qt.NoButton)


class ScriptedUser:
    """Cycles through the actions; counts actions done and frames received."""

    def __init__(self, window):
        self.window = window
        self.actions_done = 0
        self.frames = 0
        self._round = itertools.count()
        window.evaluation.frames.connect(self._count_frame)
        self.actions = [self.edit_property, self.drag_node, self.orbit_canvas, self.drag_tf_point,
                        self.reconnect_with_undo_redo]

    def _count_frame(self, frames: dict, final: bool) -> None:
        self.frames += 1

    def do_next(self) -> str:
        """Do one action (the next in the cycle); returns its name."""
        round_ = next(self._round)
        action = self.actions[round_ % len(self.actions)]
        action(round_ // len(self.actions))
        self.actions_done += 1
        QApplication.processEvents()
        return action.__name__

    def settle(self, timeout: float = 120.0) -> bool:
        """Process events until every change is rendered (False if ``timeout`` passed first)."""
        deadline = time.monotonic() + timeout
        while not self.window.evaluation.idle():
            if time.monotonic() > deadline:
                return False
            QTest.qWait(5)
        return True

    # --- the actions ----------------------------------------------------------------------------
    def _select(self, processor_id: str) -> None:
        self.window.scene.select_processor(processor_id)

    def edit_property(self, n: int) -> None:
        """Type a value into the inspector's sampling-rate box (as Enter in a spin box does)."""
        self._select(RAY_CASTER)
        spin = self.window.inspector.editors["sampling_rate"].spin
        spin.setValue(SAMPLING_RATES[n % len(SAMPLING_RATES)])

    def drag_node(self, n: int) -> None:
        """Drag the canvas node right, and back the next time (one Move command each)."""
        view, node = self.window.view, self.window.scene.nodes[CANVAS]
        step = QPointF(60.0, 0.0) if n % 2 == 0 else QPointF(-60.0, 0.0)
        centre = node.scenePos() + QPointF(NODE_WIDTH / 2, NODE_HEIGHT / 2)
        start = QPointF(view.mapFromScene(centre))
        mouse_drag(view.viewport(), start, start + step * view.transform().m11())

    def orbit_canvas(self, n: int) -> None:
        """A trackball drag on the canvas (coarse frames while it moves, a full one after)."""
        canvas = self.window.canvases.views[CANVAS]
        centre = QPointF(canvas.width() / 2, canvas.height() / 2)
        step = QPointF(40.0, 15.0) if n % 2 == 0 else QPointF(-40.0, -15.0)
        mouse_drag(canvas, centre, centre + step)

    def drag_tf_point(self, n: int) -> None:
        """Drag a middle control point of the transfer function up, and down the next time."""
        self._select(RAY_CASTER)
        plot = self.window.inspector.editors["transfer_function"].plot
        index = len(plot.points) // 2
        position, *_, opacity = plot.points[index]
        target = min(opacity + 0.2, 1.0) if n % 2 == 0 else max(opacity - 0.2, 0.0)
        mouse_drag(plot, plot.to_pixel(position, opacity), plot.to_pixel(position, target))

    def reconnect_with_undo_redo(self, n: int) -> None:
        """Delete the image connection, undo, redo, then connect the ports again with the mouse."""
        window, scene = self.window, self.window.scene
        scene.clearSelection()
        scene.edges[IMAGE_CONNECTION].setSelected(True)
        window.delete_action.trigger()
        window.undo_action.trigger()
        window.redo_action.trigger()
        view = window.view
        source = scene.nodes[RAY_CASTER].port("out", "image").scenePos()
        target = scene.nodes[CANVAS].port("in", "image").scenePos()
        mouse_drag(view.viewport(), QPointF(view.mapFromScene(source)), QPointF(view.mapFromScene(target)))
        if IMAGE_CONNECTION not in window.workspace.network.connections:
            raise RuntimeError("dragging from rc.image to canvas.image did not connect them")
