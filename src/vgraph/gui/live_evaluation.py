"""When and how the GUI evaluates: shortly after every change, in the render process.

Changes arriving together (a slider drag, a macro such as a delete) are gathered by a short
single-shot timer. Then the network goes to the render process as a document (``render_process``);
while it works, further changes wait, and only the newest state is sent next, so the GUI never
queues up stale frames. Results come back through ``finished`` (the outcome) and ``frames``.

Conventions:
- ``interactive(True)`` (the mouse is dragging on a canvas) renders the displays at
  ``INTERACTIVE_SCALE`` of their size at once, without the gathering delay; ``interactive(False)``
  asks for the full-size frame again ("refine on stop").
- A result is *final* when it is at full scale and no change has happened since its job was sent.
- ``status_of(processor_id)`` is what the render process last reported for that processor (the
  GUI's own copy of the network is never evaluated).
- Nothing that goes wrong escapes: processor failures are in the outcome; a job that fails as a
  whole (an unknown plug-in, a crashed render process) is reported through ``crashed``.
- ``run(wait=True)`` blocks until the current state is evaluated (scripts, ``--screenshot``, tests).
"""

from __future__ import annotations

import traceback

from PySide6.QtCore import QObject, QTimer, Signal

from vgraph.fileformat import network_document
from vgraph.gui.evaluator import EvaluationOutcome, ProcessorStatus, processor_status
from vgraph.gui.render_process import RenderJob, RenderProcess, RenderResult, plugin_modules
from vgraph.gui.workspace import Workspace
from vgraph.network import Network

TRIGGER_EVENTS = {"processor_added", "processor_removed", "connected", "disconnected",
                  "linked", "unlinked", "property_changed"}
DELAY_MS = 30
POLL_MS = 10
INTERACTIVE_SCALE = 0.25


class LiveEvaluation(QObject):
    finished = Signal(object)   # an EvaluationOutcome
    frames = Signal(dict, bool)  # display id -> uint8 RGBA frame, final
    histograms = Signal(dict)   # processor id -> histogram counts of its volume
    crashed = Signal(str)       # a job failed as a whole, with the reason
    busy_changed = Signal(bool)

    def __init__(self, workspace: Workspace, renderer: RenderProcess | None = None, parent=None):
        super().__init__(parent)
        self.workspace = workspace
        self.renderer = renderer or RenderProcess()
        self._owns_renderer = renderer is None
        self.network: Network | None = None
        self.last_outcome: EvaluationOutcome | None = None
        self.last_result: RenderResult | None = None
        self.statuses: dict[str, ProcessorStatus] = {}
        self.version = 0            # counts changes; a result is current when it carries the latest
        self.scale = 1.0
        self._include_writers = False
        self._fresh = True
        self._wanted = False        # a change waits for the render process to be free
        self.timer = self._timer(DELAY_MS, self._send)
        self.poller = self._timer(POLL_MS, self._poll)
        workspace.network_replaced.connect(self._follow)
        self._follow(workspace.network)

    def _timer(self, interval: int, slot) -> QTimer:
        timer = QTimer(self)
        timer.setSingleShot(True)
        timer.setInterval(interval)
        timer.timeout.connect(slot)
        return timer

    def _follow(self, network: Network) -> None:
        self.detach()
        self.network = network
        self.statuses.clear()
        self._fresh = True
        network.subscribe(self._on_event)
        self.schedule()

    def detach(self) -> None:
        if self.network is not None and self._on_event in self.network.listeners:
            self.network.listeners.remove(self._on_event)
        self.timer.stop()

    def shutdown(self) -> None:
        """Stop evaluating; stop the render process if it is ours (a shared one is left idle)."""
        self.detach()
        self.poller.stop()
        if self._owns_renderer:
            self.renderer.stop()
        elif self.renderer.busy:
            self.renderer.wait()

    def idle(self) -> bool:
        """Nothing waits to be sent and no job is in flight: the views show the current state."""
        return not self._wanted and not self.timer.isActive() and not self.renderer.busy

    def status_of(self, processor_id: str) -> ProcessorStatus:
        status = self.statuses.get(processor_id)
        return status if status is not None else processor_status(self.network, self.network[processor_id])

    # --- when ----------------------------------------------------------------------------------
    def _on_event(self, event: str, **details) -> None:
        if event in TRIGGER_EVENTS:
            self.version += 1
            self.schedule()
            if self.scale < 1.0:  # the mouse is moving: no gathering delay
                self._send()

    def schedule(self) -> None:
        self._wanted = True
        self.timer.start()

    def interactive(self, on: bool) -> None:
        self.scale = INTERACTIVE_SCALE if on else 1.0
        if not on:
            self.schedule()

    # --- sending and receiving -----------------------------------------------------------------
    def run(self, include_writers: bool = False, wait: bool = False) -> EvaluationOutcome | None:
        """Evaluate now (with ``wait``: block until the current state's result is in)."""
        self._include_writers |= include_writers
        self._wanted = True
        self._send()
        while wait and self.renderer.busy:
            self._receive(self.renderer.wait())  # which sends what changed meanwhile
        return self.last_outcome if wait else None

    def _send(self) -> None:
        self.timer.stop()
        if not self._wanted or self.renderer.busy:
            return
        try:
            job = RenderJob(self.version, network_document(self.network),
                            str(self.network.base_dir) if self.network.base_dir else None,
                            plugin_modules(self.network), self.scale, self._include_writers, self._fresh)
        except Exception:
            self.crashed.emit(traceback.format_exc())
            return
        self._wanted = self._include_writers = self._fresh = False
        self.renderer.submit(job)
        self.busy_changed.emit(True)
        self.poller.start()

    def _poll(self) -> None:
        if not self.renderer.busy:
            return
        result = self.renderer.poll()
        if result is None:
            self.poller.start()
        else:
            self._receive(result)

    def _receive(self, result: RenderResult) -> None:
        self.last_result = result
        if result.error:
            self._fresh = True  # the render process starts over with the next job
            self.crashed.emit(result.error)
        else:
            self.statuses = dict(result.statuses)
            self.last_outcome = result.outcome
            final = result.scale == 1.0 and result.version == self.version
            self.frames.emit(result.outcome.frames, final)
            self.histograms.emit(result.histograms)
            self.finished.emit(result.outcome)
        if self._wanted or (result.scale < 1.0 and self.scale == 1.0):
            self._wanted = True
            self._send()
        if not self.renderer.busy:
            self.busy_changed.emit(False)
