"""The hover readout: what lies under the mouse in a canvas, in the status bar and (View > Corner
Annotation) in the top-right corner of the canvas's frame, as 3D Slicer's data probe (issue 36).

The mouse moving over a canvas's frame (no button pressed) becomes a ``Probe`` (vgraph.live.probes)
to the render process, which picks the pixel in the frame it drew (``Network.pick``: world
point, voxel, the value of each volume upstream, the label's name, the iso-surface point with its
curvatures). One probe is in flight at a time; moves meanwhile keep only the latest position, sent
when the answer arrives, so a slow answer never queues stale probes. The canvas under the mouse
is ``LiveEvaluation.hovered``: its renderer draws its depth with each frame (in the same pass), so
probes read the frame already drawn and never draw one (bench/bench_hover.py measures the rate).

The same channel answers requested picks (``request``: the mouse placing and dragging markups,
markup_placing.py): they go before the hover's position, in order, and their answers go to their
callback instead of the status bar; a request with a ``key`` replaces the one of that key still
waiting (a drag sends only its latest position).
"""

from __future__ import annotations

import time

from PySide6.QtCore import QObject, QTimer
from PySide6.QtGui import QAction

from vgraph.live.probes import Probe, ProbeAnswer, corner_lines, status_text

POLL_MS = 5            # how often an answer is looked for while a probe is in flight
GIVE_UP_SECONDS = 30.0  # a probe unanswered this long (a render process restarted) is forgotten
SETTING = "view/corner_annotation"


class HoverReadout(QObject):
    """Sends the hovered pixel of any watched CanvasView to the render process and shows the answer."""

    def __init__(self, window, evaluation):
        super().__init__(window)
        self.window, self.evaluation = window, evaluation
        self.pending: Probe | None = None     # the latest position not sent yet
        self.sent_at: float | None = None     # time.monotonic() of the probe in flight
        self.view = None                      # the CanvasView under the mouse
        self.last: ProbeAnswer | None = None  # the last answer shown
        self.answers = 0                      # answers shown (the tests and the bench count them)
        self._serial = 0
        self.requests: list[tuple[Probe, object, object]] = []  # (probe, callback, key) not sent yet
        self._callbacks: dict[int, object] = {}  # serial -> the callback of a requested probe
        self.timer = QTimer(self)
        self.timer.setInterval(POLL_MS)
        self.timer.timeout.connect(self._poll)
        settings = getattr(getattr(window, "workspace", None), "settings", None)
        self.corner_action = QAction("Corner &Annotation", self, checkable=True)
        self.corner_action.setToolTip("show the world position, voxel and values under the mouse "
                                      "in the canvas's corner")
        self.corner_action.setChecked(bool(settings is not None and settings.value(SETTING, False, type=bool)))
        self.corner_action.toggled.connect(self._corner_toggled)
        self._settings = settings

    def watch(self, view) -> None:
        view.hovered.connect(lambda position, view=view: self.moved(view, position))
        view.hover_left.connect(lambda view=view: self.left(view))

    # --- the mouse ------------------------------------------------------------------------------
    def moved(self, view, position) -> None:
        """The mouse at widget ``position`` (no button pressed) over ``view``."""
        pixel = frame_pixel(view, position)
        self._enter(view)
        if pixel is None:
            self.pending = None
            view.set_annotation(())
            return
        self._serial += 1
        height, width = view.frame().shape[:2]
        self.pending = Probe(view.canvas_id, pixel[0], pixel[1], (width, height), self._serial)
        self._send_pending()

    def left(self, view) -> None:
        if self.view is view:
            self.view, self.pending = None, None
            self.evaluation.hovered = ()
        view.set_annotation(())

    def _enter(self, view) -> None:
        if self.view is not view:
            if self.view is not None:
                self.view.set_annotation(())
            self.view = view
            # Frames of this canvas draw its depth from now on; the frame shown has none, so the
            # first probe draws it (once).
            self.evaluation.hovered = (view.canvas_id,)

    def request(self, view, position, callback, key=None) -> bool:
        """Pick widget ``position`` of ``view`` for ``callback(answer)``; False (nothing sent)
        outside its frame. ``key``: replaces the request of that key still waiting."""
        pixel = frame_pixel(view, position)
        if pixel is None:
            return False
        self._enter(view)
        if key is not None:
            self.requests = [r for r in self.requests if r[2] != key]
        self._serial += 1
        height, width = view.frame().shape[:2]
        probe = Probe(view.canvas_id, pixel[0], pixel[1], (width, height), self._serial)
        self.requests.append((probe, callback, key))
        self._send_pending()
        return True

    # --- probes ---------------------------------------------------------------------------------
    def _send_pending(self) -> None:
        renderer = self.evaluation.renderer
        if self.sent_at is not None:
            if renderer.probes_out and time.monotonic() - self.sent_at < GIVE_UP_SECONDS:
                return  # one in flight: this position goes when it is answered
            self.sent_at = None
        if self.requests:
            probe, callback, _ = self.requests[0]
            if renderer.send_probe(probe):
                self.requests.pop(0)
                self._callbacks[probe.serial] = callback
                self.sent_at = time.monotonic()
                self.timer.start()
            return
        if self.pending is None:
            return
        if renderer.send_probe(self.pending):
            self.sent_at, self.pending = time.monotonic(), None
            self.timer.start()

    def _poll(self) -> None:
        answer = self.evaluation.renderer.probe_answer()
        if answer is None:
            if not self.evaluation.renderer.probes_out:  # the process went: nothing will come
                self.sent_at = None
                self.timer.stop()
            return
        self.sent_at = None
        callback = self._callbacks.pop(answer.serial, None)
        if callback is not None:
            callback(answer)
        else:
            self._show(answer)
        if self.pending is not None or self.requests:
            self._send_pending()
        else:
            self.timer.stop()

    def _show(self, answer: ProbeAnswer) -> None:
        self.last, self.answers = answer, self.answers + 1
        self.window.statusBar().showMessage(status_text(answer))
        view = self.view
        if view is not None and view.canvas_id == answer.canvas:
            view.set_annotation(corner_lines(answer) if self.corner_action.isChecked() else ())

    def _corner_toggled(self, on: bool) -> None:
        if self._settings is not None:
            self._settings.setValue(SETTING, bool(on))
        if self.view is not None:
            self.view.set_annotation(corner_lines(self.last) if on and self.last is not None else ())


def frame_pixel(view, position) -> tuple[float, float] | None:
    """The frame's pixel (column, row; row 0 at the top, an integer at a pixel's centre) under a
    widget position, or None outside the frame or while none is shown."""
    frame = view.frame()
    if frame is None:
        return None
    rect = view.image_rect()
    height, width = frame.shape[:2]
    x = (position.x() - rect.left()) / rect.width() * width - 0.5
    y = (position.y() - rect.top()) / rect.height() * height - 0.5
    if not (-0.5 <= x < width - 0.5 and -0.5 <= y < height - 0.5):
        return None
    return x, y
