"""When and how the GUI evaluates: shortly after every change, in the render process.

Changes arriving together (a macro such as a delete) are gathered by a short single-shot timer,
started by the first of them (a stream of changes does not postpone it). Then they go to the
render process (``render_process``) as the edits made since the last job (``changes``: a
property's new value, a processor, connection or link added or removed), not as the whole network;
while it works, further changes wait and go together with the next job (while dragging they are
queued instead, and the render process skips the stale ones: see below). Results come back
through ``finished`` (the outcome) and ``frames``.

The whole network goes as a document instead when the render process's copy cannot be trusted or
reached by changes: a network opened or new (``network_replaced``), a new render process (after a
crash or a cancel), a job that failed, the network's folder changed (Save As: relative file paths
mean other things), other plug-in modules, an event that could not be described as a change, and
when the render process asks for it (``RenderResult.needs_document``).

Conventions:
- ``interactive(True)`` (the mouse drags on a canvas, a slider or a TF point) renders the displays
  at ``INTERACTIVE_SCALE`` of their size at once, without the gathering delay; ``interactive(False)``
  asks for the full-size frame again at once ("refine on release").
- While interactive, each change goes out at once as a job queued behind those in flight (at most
  ``MAX_IN_FLIGHT``), so the render process never waits for a round trip through the window; it
  renders the newest job waiting and answers the older ones ``skipped`` (changes applied, nothing
  drawn). Results that arrive together are shown newest only (``frames_dropped`` counts the
  others): every poll that brings frames shows one.
- A result is *final* when it is at full scale and no change has happened since its job was sent.
- Coarse first: a final result that is ``refining`` (a bricked ray caster drew coarser than planned
  because its bricks were still being read, render_messages.GUI_LOAD_LIMIT) is shown as not final
  ("refining...") and the same state is rendered again (an empty-changes job), by itself, until a
  frame is complete; any change takes over as usual. A refining result that read no bricks made
  no progress: refining stops there, with a warning, rather than spin.
- ``set_cluster(setting)`` (a ``vgraph.live.cluster.ClusterSetting``, or None) makes the render
  process draw the final frames on that cluster (coarse ones stay local) and renders again;
  ``progress(done, total)`` reports its tiles while such a frame is drawn.
- ``running(progress)`` says which processor the render process runs now and how far its steps
  are (a ``vgraph.progress.Progress``), each new report once; ``running(None)`` when the job it
  belonged to is answered (``gui.progress_view`` shows it after a short delay).
- ``status_of(processor_id)`` is what the render process last reported for that processor (the
  GUI's own copy of the network is never evaluated).
- Nothing that goes wrong escapes: processor failures are in the outcome; a job that fails as a
  whole (an unknown plug-in, a crashed render process) is reported through ``crashed``.
- ``run(wait=True)`` blocks until the current state is evaluated (scripts, ``--screenshot``, tests).
- The watchdog (render_watchdog.py, ``RenderWatchdog`` mixed in here) reports an overdue job and
  replaces a render process that died; ``cancel()`` gives up the frame in flight.
"""

from __future__ import annotations

import traceback
import uuid

import numpy as np

from PySide6.QtCore import QObject, QTimer, Signal

from vgraph.edits import Edit
from vgraph.errors import VGraphError
from vgraph.fileformat import network_document
from vgraph.live.changes import append_change, change_of
from vgraph.live.evaluator import EvaluationOutcome, ProcessorStatus, processor_status
from vgraph.live.render_messages import GUI_LOAD_LIMIT, RenderJob, RenderResult, plugin_modules
from vgraph.live.render_process import RenderProcess
from vgraph.live.tables import merged_tables
from vgraph.gui.render_watchdog import (STALL_FACTOR, STALL_FIRST_SECONDS, STALL_MIN_SECONDS, WATCHDOG_MS,
                                       RenderWatchdog)
from vgraph.gui.workspace import Workspace
from vgraph.network import Network

TRIGGER_EVENTS = {"processor_added", "processor_removed", "connected", "disconnected",
                  "linked", "unlinked", "property_changed"}
DELAY_MS = 30
POLL_MS = 10
INTERACTIVE_SCALE = 0.25
MAX_IN_FLIGHT = 4           # jobs queued while dragging: a few small pickles, never a full pipe


class LiveEvaluation(RenderWatchdog, QObject):
    finished = Signal(object)   # an EvaluationOutcome
    frames = Signal(dict, bool)  # display id -> uint8 RGBA frame, final
    histograms = Signal(dict)   # processor id -> histogram counts of its volume
    value_scales = Signal(dict)  # processor id -> ValueScale of its volume
    tables_changed = Signal()   # ``tables`` changed (a measuring processor ran again, or went)
    crashed = Signal(str)       # a job failed as a whole, with the reason
    busy_changed = Signal(bool)
    warning = Signal(str)       # a job takes far too long; a job was cancelled
    info = Signal(str)          # a new render process took over
    stalled = Signal(float)     # seconds the overdue job has been running (each watchdog tick)
    progress = Signal(int, int)  # tiles done, total of a frame drawn on a cluster
    running = Signal(object)    # vgraph.progress.Progress of the job in flight, None when it is answered
    received = Signal(object)   # every RenderResult as it arrives, before it is shown (timing)

    def __init__(self, workspace: Workspace, renderer: RenderProcess | None = None, parent=None,
                 stall_min_seconds: float = STALL_MIN_SECONDS, stall_factor: float = STALL_FACTOR,
                 stall_first_seconds: float = STALL_FIRST_SECONDS):
        super().__init__(parent)
        self.stall_min_seconds, self.stall_factor = stall_min_seconds, stall_factor
        self.stall_first_seconds = stall_first_seconds
        self._stall_reported = False
        self.workspace = workspace
        self.renderer = renderer or RenderProcess()
        self._owns_renderer = renderer is None
        self.network: Network | None = None
        self.last_outcome: EvaluationOutcome | None = None
        self.last_result: RenderResult | None = None
        self.statuses: dict[str, ProcessorStatus] = {}
        self.view_cameras: dict = {}  # 'id.camera' -> the concrete camera of the last frame
        self.tables: dict = {}      # 'id.port' -> the Table it output (vgraph.live.tables)
        self.version = 0            # counts changes; a result is current when it carries the latest
        self.scale = 1.0
        self.load_limit = GUI_LOAD_LIMIT  # reading per frame in the render process (None: complete frames)
        self.cluster = None         # ClusterSetting: final frames drawn on a cluster (None: here)
        self.hovered: tuple[str, ...] = ()  # the canvas under the mouse: its depth is drawn with its frames (hover.py)
        self._progress = None       # the last RenderProgress reported
        self._running = None        # the last Progress reported through ``running``
        self._include_writers = False
        self._fresh = True          # the next job starts the render process's copy afresh
        self._resync = False        # the next job sends the whole document
        self._changes: list[Edit] = []    # edits since the last job
        self._sent_context = None   # (base_dir, plug-in modules) of the last job
        self._last_job: RenderJob | None = None
        self._sender = uuid.uuid4().hex   # tells the render process whose changes a job carries
        self._wanted = False        # a change waits for the render process to be free
        self.frames_dropped = 0     # results not shown: a newer one arrived with them
        self._shown_extras = None   # (histograms, value scales) last emitted
        self.timer = self._timer(DELAY_MS, self._send)
        self.poller = self._timer(POLL_MS, self._poll)
        self.watchdog = self._timer(WATCHDOG_MS, self.check_renderer)
        self.watchdog.setSingleShot(False)
        self.watchdog.start()
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
        self._shown_extras = None
        self._fresh = True
        self._changes.clear()
        network.subscribe(self._on_event)
        self.schedule()

    def detach(self) -> None:
        if self.network is not None:
            self.network.unsubscribe(self._on_event)
        self.timer.stop()

    def shutdown(self) -> None:
        """Stop evaluating; stop the render process if it is ours (a shared one is left idle)."""
        self.detach()
        self.poller.stop()
        self.watchdog.stop()
        if self._owns_renderer:
            self.renderer.stop()
        else:
            try:  # every job: a shared process must not answer the next window with ours
                while self.renderer.busy:
                    self.renderer.wait(timeout=self.stall_limit())
            except VGraphError:
                self.renderer.cancel()  # a stuck job must not keep the window from closing

    def idle(self) -> bool:
        """Nothing waits to be sent and no job is in flight: the views show the current state."""
        return not self._wanted and not self.timer.isActive() and not self.renderer.busy

    def status_of(self, processor_id: str) -> ProcessorStatus:
        status = self.statuses.get(processor_id)
        return status if status is not None else processor_status(self.network, self.network[processor_id])

    # --- when ----------------------------------------------------------------------------------
    def _on_event(self, event: str, **details) -> None:
        if event in TRIGGER_EVENTS:
            self._record(event, details)
            self.version += 1
            self.schedule()
            if self.scale < 1.0:  # the mouse is moving: no gathering delay
                self._send()

    def _record(self, event: str, details: dict) -> None:
        try:
            append_change(self._changes, change_of(self.network, event, details))
        except Exception:  # a listener must not break the edit: the document says it instead
            self._resync = True

    def schedule(self) -> None:
        self._wanted = True
        if not self.timer.isActive():  # restarting it on every change would wait out a whole drag
            self.timer.start()

    def set_cluster(self, setting) -> None:
        """Draw the final frames on ``setting``'s cluster (None: in the render process) from now on."""
        if setting != self.cluster:
            self.cluster = setting
            self.schedule()  # the next job carries it: connects (or closes) and draws again

    def interactive(self, on: bool) -> None:
        self.scale = INTERACTIVE_SCALE if on else 1.0
        coarse_last = self._last_job is not None and self._last_job.scale < 1.0
        if not on and (self._wanted or coarse_last):  # a press and release that changed nothing: nothing
            self._wanted = True
            self._send()  # queued behind the coarse jobs, which it makes stale: they are skipped

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
        busy = self.renderer.busy
        if not self._wanted or (busy and not self._may_queue()):
            return
        if not busy:
            self._replace_if_dead("")
        try:
            job = self._job()
        except Exception:
            self.crashed.emit(traceback.format_exc())
            return
        self._wanted = self._include_writers = self._fresh = self._resync = False
        self._changes.clear()
        self._sent_context = (job.base_dir, job.plugins)
        self._stall_reported = False
        self._last_job = job
        self.renderer.submit(job)
        if not busy:
            self.busy_changed.emit(True)
        self.poller.start()

    def _may_queue(self) -> bool:
        """Whether the next job may go behind those in flight: changes only (no document, no
        writers), a few at most, and never a full-size job behind another (edits made while a full
        frame renders are gathered into the next job, as they always were)."""
        if self.renderer.in_flight >= MAX_IN_FLIGHT or self._include_writers or self._whole()[0]:
            return False
        return self.scale < 1.0 or all(job.scale < 1.0 for job in self.renderer.jobs)

    def _whole(self) -> tuple[bool, str | None, tuple[str, ...]]:
        """(whether the next job must carry the whole document, its base_dir, its plug-ins)."""
        base_dir = str(self.network.base_dir) if self.network.base_dir else None
        plugins = plugin_modules(self.network)
        return self._fresh or self._resync or (base_dir, plugins) != self._sent_context, base_dir, plugins

    def _job(self) -> RenderJob:
        """The changes since the last job, or the whole document when changes cannot do."""
        whole, base_dir, plugins = self._whole()
        return RenderJob(self.version, network_document(self.network) if whole else None, base_dir,
                         plugins, self.scale, self._include_writers, self._fresh,
                         changes=() if whole else tuple(self._changes), stamp=(self._sender, self.version),
                         since=self._last_job.stamp if self._last_job else None, load_limit=self.load_limit,
                         cluster=self.cluster, write_confinement=self.network.write_confinement,
                         hovered=self.hovered)

    def _poll(self) -> None:
        results = []
        while self.renderer.busy:
            result = self.renderer.poll()
            if result is None:
                break
            results.append(result)
        self._report_progress()
        # Frames that arrive together: the newest is shown, the older ones were stale on arrival.
        newest = max((i for i, result in enumerate(results) if result.outcome.frames), default=-1)
        for i, result in enumerate(results):
            self._receive(result, show=i == newest)
        if self.renderer.busy:
            self.poller.start()

    def _report_progress(self) -> None:
        """Tiles done / total of a frame drawn on a cluster, and the processor running, each new
        report once."""
        progress = getattr(self.renderer, "progress", None)
        if progress is not None and progress is not self._progress:
            self._progress = progress
            self.progress.emit(progress.done, progress.total)
        running = getattr(self.renderer, "running", None)
        if running is not self._running:
            self._running = running
            self.running.emit(running)

    def _receive(self, result: RenderResult, show: bool = True) -> None:
        self._report_progress()  # run(wait=True) receives without polling
        self.last_result = result
        self.received.emit(result)
        if result.needs_document:   # nothing rendered: send the whole network at once
            self._resync = self._wanted = True
            self._include_writers |= self._last_job.include_writers
        elif result.error:
            self._fresh = True  # the render process starts over with the next job
            self.crashed.emit(result.error)
            if self.renderer.pid is None:   # it died with the job: a new one, ready for the next
                self._replace()
        elif not result.skipped:
            self.statuses = dict(result.statuses)
            self.last_outcome = result.outcome
            final = result.scale == 1.0 and result.version == self.version
            if show or final or not result.outcome.frames:
                self.frames.emit(result.outcome.frames, final and not result.refining)
            else:
                self.frames_dropped += 1
            if final and result.refining:
                self._refine(result)
            self.view_cameras = dict(result.view_cameras)
            self._emit_extras(result)
            self._take_tables(result)
            self.finished.emit(result.outcome)
        coarse_last = self._last_job is not None and self._last_job.scale < 1.0
        if self._wanted or (coarse_last and self.scale == 1.0):  # a drag ended: the full frame
            self._wanted = True
            self._send()
        if not self.renderer.busy:
            self.busy_changed.emit(False)

    def _emit_extras(self, result: RenderResult) -> None:
        """Histograms and value scales when they differ from the last ones: each repaints the
        TF editor, which a drag should not pay for every frame."""
        extras = (result.histograms, result.value_scales)
        if self._shown_extras is not None and _same_extras(self._shown_extras, extras):
            return
        self._shown_extras = extras
        self.histograms.emit(result.histograms)
        self.value_scales.emit(result.value_scales)

    def _take_tables(self, result: RenderResult) -> None:
        tables = merged_tables(self.tables, result.tables, result.table_addresses)
        if result.tables or tables.keys() != self.tables.keys():
            self.tables = tables
            self.tables_changed.emit()

    def _refine(self, result: RenderResult) -> None:
        """Render the same state again: the bricks read meanwhile make the frame finer."""
        if result.bricks_read > 0:
            self._wanted = True
        else:
            self.warning.emit("stopped refining: a frame drawn coarser than planned read no bricks "
                              "(the frame stays coarse; any change renders again)")

def _same_extras(old: tuple, new: tuple) -> bool:
    (old_histograms, old_scales), (new_histograms, new_scales) = old, new
    return (old_scales == new_scales and old_histograms.keys() == new_histograms.keys()
            and all(np.array_equal(old_histograms[key], new_histograms[key]) for key in new_histograms))
