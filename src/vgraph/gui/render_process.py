"""The render process: a child process that owns the OpenGL context and evaluates for the GUI.

Why a process: moderngl holds the GIL while it renders, so rendering in a thread of the GUI process
would freeze the window for a whole frame; and the GUI then needs no GL at all, so it runs (and is
tested) anywhere Qt runs. The GUI sends what to show, the render process sends frames back.

Protocol (pickled objects over a ``multiprocessing`` pipe, one job in flight at a time):
- GUI -> render process: a ``RenderJob``, or ``None`` to stop. A job carries either the network as
  a version-1 document (a file opened, a new network, plug-ins that changed, a resync) or the
  ``changes`` made since the previous job (``vgraph.gui.changes``: property values, processors,
  connections, links; an empty tuple re-renders), plus the modules that define its plug-in
  processor types, the resolution scale, whether writers run and whether to start from a new network.
- render process -> GUI: one ``RenderResult`` per job: what ran or failed, a ``ProcessorStatus`` per
  processor, frames for the displays, histograms and value scales for the transfer-function
  editors, the concrete cameras of the last frame (for zooming a camera that fits the data). A
  result with ``needs_document`` rendered nothing: the changes could not be applied (the process
  has no network, e.g. a new one, or a change failed) and the GUI sends the whole document next.
- Coarse first: a job's ``load_limit`` (``GUI_LOAD_LIMIT`` unless the GUI says otherwise) goes to
  every processor that loads bricks progressively (a ``load_limit`` attribute: the BrickedRayCaster),
  so a frame waits at most about that long for the disk and is drawn coarser meanwhile. A result
  is ``refining`` when such a processor drew less than it planned (``last_frame["complete"]``);
  the GUI then sends an empty-changes job for the same state, which draws those processors again
  (they are invalidated: the bricks read since make the frame finer), until a frame is complete.
  ``bricks_read`` says whether an incomplete frame made progress.
- On a cluster: a job's ``cluster`` (``vgraph.gui.cluster.ClusterSetting``, the GUI's "Render on
  Cluster" setting) makes the final frames (full scale, no writers) of the displays be drawn by
  that cluster's workers (``vgraph.distributed.render``); meanwhile the render process sends
  ``RenderProgress`` messages (tiles done / total) before the job's one ``RenderResult``. Coarse
  frames stay local. A cluster that cannot be reached falls back to local frames with a warning
  in the outcome.
- Which processor runs: while a job is evaluated the render process sends ``ProcessorProgress``
  messages (a ``vgraph.progress.Progress``: the processor that started, and how far the steps of
  its work are: reading a file, prefiltering, bricks), at most one every ``PROGRESS_INTERVAL``
  seconds for the same processor, so a fast frame costs a few small messages and a long read
  does not flood the pipe (``progress_messages``). ``RenderProcess.running`` holds the last one of the job in flight.
The render process keeps its network between jobs (``mirror`` applies a document as a diff; changes
edit it in place), so unchanged processors keep their textures and outputs.

``RenderProcess`` is the GUI's handle (no Qt): ``submit`` a job, ``poll``/``wait`` for the result.
If the process dies (a driver crash), the result says so with its exit code and the next job
starts a new one; a job that never finishes (a stopped or stuck process) can be ``cancel``led.
"""

from __future__ import annotations

import multiprocessing
import signal
import statistics
import threading
import time
import traceback
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from vgraph import progress as progress_api
from vgraph.bricks.cache import LoadLimit
from vgraph.gui.cluster import ClusterRenderer, ClusterSetting, ClusterView
from vgraph.errors import VGraphError
from vgraph.gui.evaluator import (EvaluationOutcome, ProcessorStatus, evaluate_view, histograms, processor_status,
                                  value_scales, view_cameras)
from vgraph.gui.changes import Change, apply_changes
from vgraph.gui.mirror import mirror
from vgraph.gui.progress_messages import ProcessorProgress, ProgressForwarder
from vgraph.gui.view_boxes import view_boxes
from vgraph.network import Network
from vgraph.registry import registry

BUILTIN_PACKAGE = "vgraph.processors"
RECENT_JOBS = 20   # how many recent jobs say how long a job usually takes
# Reading per frame in the GUI: a frame of a volume on disk shows within about this (plus the
# drawing) and refines in the following jobs; short enough to feel immediate, long enough that a
# frame reads a good share of what it needs (docs/bricked_raycaster.md, "In the GUI").
GUI_LOAD_LIMIT = LoadLimit(seconds=0.25)


@dataclass
class RenderJob:
    version: int
    document: dict | None      # None: apply ``changes`` to the network the process has
    base_dir: str | None = None
    plugins: tuple[str, ...] = ()
    scale: float = 1.0
    include_writers: bool = False
    fresh: bool = False        # start from a new network (another file was opened)
    changes: tuple[Change, ...] = ()
    stamp: tuple | None = None  # (sender, version): names the network state this job leaves
    since: tuple | None = None  # the stamp of the state ``changes`` edit (the sender's previous job)
    load_limit: LoadLimit | None = GUI_LOAD_LIMIT  # reading per frame of bricked processors (None: no limit)
    cluster: ClusterSetting | None = None  # draw the final frames on this cluster (None: here)
    sent: float = 0.0          # time.monotonic() when the window sent it (RenderResult.submitted)


@dataclass
class RenderProgress:
    """Sent while a job's frame is drawn on a cluster: ``done`` of ``total`` tiles are in."""
    version: int
    done: int
    total: int


@dataclass
class RenderResult:
    version: int
    scale: float = 1.0
    outcome: EvaluationOutcome = field(default_factory=EvaluationOutcome)
    statuses: dict[str, ProcessorStatus] = field(default_factory=dict)
    histograms: dict[str, np.ndarray] = field(default_factory=dict)
    value_scales: dict = field(default_factory=dict)
    view_cameras: dict = field(default_factory=dict)
    view_boxes: dict = field(default_factory=dict)  # 'id.camera' -> the box it framed (canvas overlays)
    seconds: float = 0.0
    error: str | None = None   # the job as a whole failed (its network could not be built, a crash)
    needs_document: bool = False  # the changes could not be applied: send the whole network
    refining: bool = False     # a processor drew a coarser frame than planned: render the same state again
    bricks_read: int = 0       # bricks those incomplete frames read (0: no progress, stop asking)
    skipped: bool = False      # not rendered: a newer job was already waiting (its changes are applied)
    # time.monotonic() (one clock for both processes on one machine): the job sent by the window,
    # started and finished in the render process, the result received by the window. What
    # bench/bench_interaction.py reads to split a frame's latency into rendering and transfer.
    submitted: float = 0.0
    started: float = 0.0
    finished: float = 0.0
    received: float = 0.0


def plugin_modules(network: Network) -> tuple[str, ...]:
    """The modules the render process must import to know every processor type in ``network``."""
    modules = {type(p).__module__ for p in network.processors.values()}
    return tuple(sorted(m for m in modules if m != BUILTIN_PACKAGE and not m.startswith(BUILTIN_PACKAGE + ".")))


# --- the render process's side ---------------------------------------------------------------------
class RenderServer:
    """Holds the mirrored network and turns jobs into results."""

    def __init__(self):
        self.network: Network | None = None
        self.stamp: tuple | None = None   # the stamp of the job that made ``network``
        self.imported: set[str] = set()
        self.cluster = ClusterRenderer()  # the Client, kept between jobs
        self.progress = None              # progress(RenderProgress) while a frame is drawn on a cluster
        self.running = None               # running(ProcessorProgress) while a job is evaluated

    def close(self) -> None:
        self.cluster.close()

    def handle(self, job: RenderJob) -> RenderResult:
        start = time.perf_counter()
        result = RenderResult(job.version, job.scale, started=time.monotonic())
        if not self._prepare(job, result):
            return result
        try:
            view = self._cluster_view(job)
            with progress_api.listening(ProgressForwarder(self.running or _ignore, job.version)):
                result.outcome = evaluate_view(self.network, job.scale, job.include_writers,
                                               draw=view.draw if view else None)
                with progress_api.running("", ""):  # the window's own share, no processor's
                    progress_api.report(0, 0, "histograms and statuses for the window")
                    result.statuses = {pid: processor_status(self.network, p)
                                       for pid, p in self.network.processors.items()}
                    result.histograms = histograms(self.network)
            if view is not None:
                result.outcome.warnings.extend(view.messages)
                result.statuses = view.statuses(result.statuses)
            result.value_scales = value_scales(self.network)
            result.view_cameras = view_cameras(self.network)
            result.view_boxes = view_boxes(self.network)
            incomplete = [frame for frame in self._frames(result.outcome.ran) if frame.get("complete") is False]
            result.refining = bool(incomplete)
            result.bricks_read = sum(frame.get("bricks_read", 0) for frame in incomplete)
        except Exception:  # a bug below the evaluator: report it, keep serving
            result.error = "internal error in the render process (please report it):\n" + traceback.format_exc()
        result.seconds = time.perf_counter() - start
        result.finished = time.monotonic()
        return result

    def skip(self, job: RenderJob) -> RenderResult:
        """Bring the network to ``job``'s state without rendering it: a newer job is waiting, so
        its frame would be stale before it is drawn."""
        result = RenderResult(job.version, job.scale, started=time.monotonic(), skipped=True)
        self._prepare(job, result)
        result.finished = time.monotonic()
        return result

    def _prepare(self, job: RenderJob, result: RenderResult) -> bool:
        """Apply the job's document or changes; False (with the reason in ``result``) if it cannot
        be rendered."""
        try:
            self._import_plugins(job.plugins)
            if job.document is not None:
                self.network = mirror(None if job.fresh else self.network, job.document, job.base_dir)
            elif not self._applied(job):
                result.needs_document = True
                return False
            self.stamp = job.stamp
            # Writers write what `vgraph run` writes: complete frames, however long they take.
            self._limit_loading(None if job.include_writers else job.load_limit)
        except VGraphError as error:
            self.network = None  # half-applied: rebuild from the next document
            result.error = str(error)
            return False
        return True

    def _cluster_view(self, job: RenderJob) -> ClusterView | None:
        """How this job uses the cluster: only final frames without writers go there (module
        docstring); the client stays open across the other jobs."""
        final = job.scale == 1.0 and not job.include_writers
        message = self.cluster.use(job.cluster, connect=final)
        if message is not None:
            warning = ClusterView(self.cluster, self.network)  # draws nothing: reports the fallback
            warning.messages.append(message)
            return warning
        if job.cluster is None or not final:
            return None

        def progress(done: int, total: int) -> None:
            if self.progress is not None:
                self.progress(RenderProgress(job.version, done, total))
        return ClusterView(self.cluster, self.network, progress)

    def _limit_loading(self, limit: LoadLimit | None) -> None:
        """Give the processors that load progressively the job's limit, and invalidate those whose
        last frame was incomplete: the same state drawn again is finer (module docstring)."""
        for pid, processor in self.network.processors.items():
            if hasattr(processor, "load_limit"):
                processor.load_limit = limit
                frame = getattr(processor, "last_frame", None)
                if isinstance(frame, dict) and frame.get("complete") is False:
                    self.network.invalidate_downstream(pid)

    def _frames(self, ids) -> list[dict]:
        """``last_frame`` of the progressively loading processors that ran in this job."""
        return [self.network[pid].last_frame for pid in dict.fromkeys(ids)
                if pid in self.network and isinstance(getattr(self.network[pid], "last_frame", None), dict)]

    def _applied(self, job: RenderJob) -> bool:
        """Apply the job's changes; False when they cannot be: the network is not the one they
        were made on (none yet in a new process; another window's, when windows share the
        process), or one failed, which leaves the network half-changed, so it is dropped and the
        document that follows builds it again."""
        if self.network is None or job.since != self.stamp:
            return False
        try:
            apply_changes(self.network, job.changes)
        except Exception:  # any failure means the copies differ: resync rather than fail the job
            self.network = None
            return False
        return True

    def _import_plugins(self, modules) -> None:
        for module in modules:
            if module in self.imported:
                continue
            if module in ("__main__", "__mp_main__"):
                raise VGraphError("processor types defined in a script's __main__ cannot be used by the "
                                  "render process: define them in an importable module (a plug-in)")
            registry.load_plugin(module)
            self.imported.add(module)


def _ignore(message) -> None:
    """Where progress goes when nobody asked for it (a RenderServer used without a pipe)."""


def serve(connection) -> None:
    """The render process's main loop."""
    # Progress bars here need no inter-process lock; tqdm's default one is a semaphore that Python
    # reports as leaked whenever a render process is killed.
    tqdm.set_lock(threading.RLock())
    server = RenderServer()
    server.progress = server.running = connection.send
    try:
        while True:
            try:
                job = connection.recv()
            except (EOFError, OSError):
                return
            while job is not None and not job.include_writers and connection.poll():
                newer = connection.recv()   # waited behind ``job``: render that one instead
                connection.send(server.skip(job))
                job = newer
            if job is None:
                return
            connection.send(server.handle(job))
    finally:
        server.close()  # the cluster's client (and a LocalCluster it started)


# --- the GUI's side ------------------------------------------------------------------------------
def describe_exit(code: int | None) -> str:
    """'exit code 1', or for a process killed by a signal 'exit code -9 (SIGKILL)'."""
    if code is not None and code < 0:
        try:
            return f"exit code {code} ({signal.Signals(-code).name})"
        except ValueError:
            pass
    return f"exit code {code}"


class RenderProcess:
    """Starts the render process on first use; jobs are answered one result each, in order.

    Usually one job is in flight; a job submitted while others are goes behind them (the GUI does
    so while the mouse drags). The render process renders only the newest of the jobs that
    wait when it gets to them; the older ones come back ``skipped`` (their changes applied).

    For the GUI's watchdog (``LiveEvaluation``): ``elapsed()`` is how long the job in flight has
    been running, ``typical_seconds()`` the median of the last ``RECENT_JOBS`` jobs, ``died()`` the
    exit code of a process that ended by itself, ``cancel()`` kills the process of a job that does
    not finish and ``start()`` puts a new one in its place."""

    def __init__(self):
        self._process = None
        self._connection = None
        self.jobs: deque[RenderJob] = deque()  # in flight, oldest first
        self.job_started = 0.0              # time.monotonic() when the oldest job began, as seen from here
        self.recent_seconds: deque[float] = deque(maxlen=RECENT_JOBS)
        self.starts = 0                     # processes started so far
        self.progress: RenderProgress | None = None  # the last progress of the job in flight
        self.running: progress_api.Progress | None = None  # the processor running in that job

    @property
    def job(self) -> RenderJob | None:
        """The oldest job in flight: the one the render process works on."""
        return self.jobs[0] if self.jobs else None

    @property
    def busy(self) -> bool:
        return bool(self.jobs)

    @property
    def in_flight(self) -> int:
        return len(self.jobs)

    @property
    def pid(self) -> int | None:
        """The render process's id (None before the first job and after ``stop``)."""
        return self._process.pid if self._process is not None else None

    def elapsed(self) -> float:
        return time.monotonic() - self.job_started if self.busy else 0.0

    def typical_seconds(self) -> float | None:
        return statistics.median(self.recent_seconds) if self.recent_seconds else None

    def died(self) -> int | None:
        """The exit code if the render process ended without being asked to (else None)."""
        if self._process is None or self._process.is_alive():
            return None
        return self._process.exitcode

    def submit(self, job: RenderJob) -> None:
        # With jobs in flight a dead process is poll()'s to report (for them all), not to replace.
        if not self.jobs and (self._process is None or not self._process.is_alive()):
            self.start()
        if not self.jobs:
            self.job_started = time.monotonic()
            self.progress = self.running = None
        job.sent = time.monotonic()
        self.jobs.append(job)
        try:
            self._connection.send(job)
        except (OSError, ValueError):
            pass  # the process died: poll() reports it

    def poll(self) -> RenderResult | None:
        """The result of the job in flight if it is ready."""
        if not self.busy:
            return None
        try:
            while True:  # progress messages first, then the job's one result
                if not self._connection.poll():
                    if self._process.is_alive():
                        return None
                    raise EOFError
                result = self._connection.recv()
                if isinstance(result, ProcessorProgress):
                    self.running = result.progress
                    continue
                if not isinstance(result, RenderProgress):
                    break
                self.progress = result
            now = time.monotonic()
            if not result.skipped:
                self.recent_seconds.append(now - max(self.job_started, result.started))
            result.submitted, result.received = self.job.sent, now
            self.jobs.popleft()
            self.running = None  # the next job announces its own
            self.job_started = now  # the next one (if any) runs from now
        except (EOFError, OSError):
            self._process.join(timeout=1.0)
            result = RenderResult(self.job.version, self.job.scale, error=(
                f"the render process stopped unexpectedly ({describe_exit(self._process.exitcode)})"))
            self._discard()
            self.jobs.clear()  # the jobs behind it died with it
        return result

    def wait(self, timeout: float = 120.0) -> RenderResult:
        deadline = time.monotonic() + timeout
        while self.busy:
            result = self.poll()
            if result is not None:
                return result
            if time.monotonic() > deadline:
                raise VGraphError(f"the render process gave no result within {timeout:.0f} s")
            self._connection.poll(0.05)
        raise VGraphError("no job was submitted")

    def start(self) -> None:
        """Start a new render process (ending the current one, if any)."""
        self._discard()
        context = multiprocessing.get_context("spawn")
        self._connection, child = context.Pipe()
        self._process = context.Process(target=serve, args=(child,), name="vgraph-render", daemon=True)
        self._process.start()
        child.close()
        self.starts += 1

    def cancel(self) -> None:
        """Give up the job in flight: its process is killed (``start`` or the next job makes a new one)."""
        self._discard()
        self.jobs.clear()

    def _discard(self) -> None:
        if self._connection is not None:
            self._connection.close()
        if self._process is not None:
            if self._process.is_alive():
                self._process.kill()   # SIGKILL: a stopped (SIGSTOP) process ignores SIGTERM
            self._process.join(timeout=5)  # reaped, so no zombie is left behind
        self._process = self._connection = None

    def stop(self) -> None:
        if self._process is not None and self._process.is_alive():
            try:
                self._connection.send(None)
                self._process.join(timeout=5)
            except (OSError, ValueError):
                pass
        self._discard()
        self.jobs.clear()
