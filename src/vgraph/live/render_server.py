"""The render process's side: a ``RenderServer`` turns the jobs of vgraph.live.render_messages into
results, and ``serve`` is the process's main loop.

The render process keeps its network between jobs (``mirror`` applies a document as a diff; changes
edit it in place), so unchanged processors keep their textures and outputs.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import threading
import time
import traceback
from multiprocessing.connection import wait

from tqdm import tqdm

from vgraph import progress as progress_api
from vgraph.errors import VGraphError
from vgraph.frame_context import FrameContext
from vgraph.gl_context import collect_garbage, release_context
from vgraph.live.changes import apply_changes
from vgraph.live.cluster import ClusterRenderer, ClusterView
from vgraph.live.evaluator import evaluate_view, histograms, processor_status, value_scales, view_cameras
from vgraph.live.mirror import mirror
from vgraph.live.probes import Probe, ProbeAnswer, answer as probe_answer
from vgraph.live.progress_messages import ProgressForwarder
from vgraph.live.render_messages import RenderJob, RenderProgress, RenderResult
from vgraph.live.tables import TableSender
from vgraph.live.view_boxes import view_boxes
from vgraph.network import Network
from vgraph.registry import registry

_LIBC = ctypes.CDLL(ctypes.util.find_library("c")) if ctypes.util.find_library("c") else None
if _LIBC is not None and not hasattr(_LIBC, "malloc_trim"):
    _LIBC = None   # not glibc (musl, macOS): their allocators return memory themselves, or not at all


def return_memory() -> None:
    """Free what nothing refers to any more: cycles (gc), the GL objects of dead wrappers
    (gl_context.collect_garbage) and the C heap's free pages (glibc's malloc_trim; elsewhere
    nothing)."""
    gc.collect()
    collect_garbage()
    if _LIBC is not None:
        _LIBC.malloc_trim(0)


class RenderServer:
    """Holds the mirrored network and turns jobs into results."""

    def __init__(self):
        self.network: Network | None = None
        self.stamp: tuple | None = None   # the stamp of the job that made ``network``
        self.imported: set[str] = set()
        self.cluster = ClusterRenderer()  # the Client, kept between jobs
        self.progress = None              # progress(RenderProgress) while a frame is drawn on a cluster
        self.running = None               # running(ProcessorProgress) while a job is evaluated
        self.context = None               # the FrameContext of the last frame (probes pick with it)
        self.tables = TableSender()       # the tables the window holds (sent once each)

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
                self.context = frame_context(job)
                result.outcome = evaluate_view(self.network, job.scale, job.include_writers,
                                               draw=view.draw if view else None, context=self.context,
                                               hovered=job.hovered)
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
            result.tables, result.table_addresses = self.tables.changes(self.network)  # last: nothing fails after it
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
                self.tables.forget()   # the window starts over: it gets every table again
                if job.fresh:
                    self._drop_network()
                self.network = mirror(self.network, job.document, job.base_dir)
            elif not self._applied(job):
                result.needs_document = True
                return False
            self.stamp = job.stamp
            # A file's writer paths stay where the window's network was allowed to write, checked
            # again as they write (a link made since the file was opened is not followed)
            self.network.write_confinement = job.write_confinement
            self._refine_incomplete_frames()
        except VGraphError as error:
            self.network = None  # half-applied: rebuild from the next document
            result.error = str(error)
            return False
        return True

    def _drop_network(self) -> None:
        """Give the memory of the network being replaced back (File > New or Open): its arrays
        now, not whenever the cyclic collector gets to them (a processor and its network refer to
        each other); the GL context with everything made on it (measured: after tets_bonsai,
        llvmpipe kept about 670 MiB with every GL object of the network released, until the
        context was); and the heap's freed pages. The next network's first frame compiles its
        programs again on a new context: it loads its data anyway."""
        if self.network is None:
            return
        self.network = self.stamp = None
        gc.collect()
        release_context()
        return_memory()

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

    def _refine_incomplete_frames(self) -> None:
        """Invalidate the progressively loading processors whose last frame was incomplete: the
        same state drawn again is finer (render_messages). The load limit itself reaches them
        in the frame context (``frame_context``), which re-runs them when it changes."""
        for pid, processor in self.network.processors.items():
            if "load_limit" in processor.uses_context:
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


def frame_context(job: RenderJob) -> FrameContext:
    """The frame context of ``job``'s evaluations: its load limit, none for writer runs (they
    write what `vgraph run` writes: complete frames, however long they take); and whether it is
    a drag's frame (drawn below full scale: the GUI asks for those only while the mouse moves),
    where meshes are drawn at their coarse level of detail (vgraph.mesh_lod)."""
    if job.include_writers:
        return FrameContext()
    return FrameContext(load_limit=job.load_limit, interactive=job.scale < 1.0)


def _ignore(message) -> None:
    """Where progress goes when nobody asked for it (a RenderServer used without a pipe)."""


def serve(connection, probes=None) -> None:
    """The render process's main loop. ``probes``: the pipe of the hover readout's probes
    (vgraph.live.probes), answered between jobs on that pipe."""
    # Progress bars here need no inter-process lock; tqdm's default one is a semaphore that Python
    # reports as leaked whenever a render process is killed.
    tqdm.set_lock(threading.RLock())
    server = RenderServer()
    server.progress = server.running = connection.send
    try:
        while True:
            try:
                if probes is not None:
                    _answer_probes(server, connection, probes)
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


def _answer_probes(server: RenderServer, connection, probes) -> None:
    """Answer the hover readout's probes until a job (or the end) arrives on ``connection``."""
    while True:
        ready = wait([connection, probes])
        if probes in ready:
            probe: Probe = probes.recv()
            try:
                answer = probe_answer(server.network, probe, server.context)
            except Exception:  # a bug below the pick: report it, keep serving
                answer = ProbeAnswer(probe.serial, probe.canvas, None,
                                     "internal error in the pick (please report it):\n" + traceback.format_exc())
            probes.send(answer)
        if connection in ready:
            return
