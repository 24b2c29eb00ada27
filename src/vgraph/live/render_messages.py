"""What the GUI and its render process (vgraph.live.render_process) send each other.

Protocol (pickled objects over a ``multiprocessing`` pipe, one job in flight at a time):
- GUI -> render process: a ``RenderJob``, or ``None`` to stop. A job carries either the network as
  a version-1 document (a file opened, a new network, plug-ins that changed, a resync) or the
  ``changes`` made since the previous job (the edits of ``vgraph.edits``, gathered by
  ``vgraph.live.changes``: property values, processors, connections, links; an empty tuple
  re-renders), plus the modules that define its plug-in processor types, the resolution scale,
  whether writers run and whether to start from a new network.
- render process -> GUI: one ``RenderResult`` per job: what ran or failed, a ``ProcessorStatus`` per
  processor, frames for the displays, histograms and value scales for the transfer-function
  editors, the concrete cameras of the last frame (for zooming a camera that fits the data). A
  result with ``needs_document`` rendered nothing: the changes could not be applied (the process
  has no network, e.g. a new one, or a change failed) and the GUI sends the whole document next.
- Coarse first: a job's ``load_limit`` (``GUI_LOAD_LIMIT`` unless the GUI says otherwise) goes, in
  the frame context (vgraph.frame_context), to every processor that loads bricks progressively
  (``uses_context`` names it: the BrickedRayCaster, the RayCaster), so a frame waits at most about that long for the disk and is drawn coarser meanwhile. A result
  is ``refining`` when such a processor drew less than it planned (``last_frame["complete"]``);
  the GUI then sends an empty-changes job for the same state, which draws those processors again
  (they are invalidated: the bricks read since make the frame finer), until a frame is complete.
  ``bricks_read`` says whether an incomplete frame made progress.
- On a cluster: a job's ``cluster`` (``vgraph.live.cluster.ClusterSetting``, the GUI's "Render on
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
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vgraph.bricks.cache import LoadLimit
from vgraph.edits import Edit
from vgraph.live.cluster import ClusterSetting
from vgraph.live.evaluator import EvaluationOutcome, ProcessorStatus
from vgraph.network import Network

BUILTIN_PACKAGE = "vgraph.processors"
# Reading per frame in the GUI: a frame of a volume on disk shows within about this (plus the
# drawing) and refines in the following jobs; short enough to feel immediate, long enough that a
# frame reads a good share of what it needs (docs/explanations/bricked-ray-casting.md, "In the GUI").
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
    changes: tuple[Edit, ...] = ()
    stamp: tuple | None = None  # (sender, version): names the network state this job leaves
    since: tuple | None = None  # the stamp of the state ``changes`` edit (the sender's previous job)
    load_limit: LoadLimit | None = GUI_LOAD_LIMIT  # reading per frame of bricked processors (None: no limit)
    cluster: ClusterSetting | None = None  # draw the final frames on this cluster (None: here)
    write_confinement: object | None = None  # the window's network's (vgraph.write_paths.Confinement)
    sent: float = 0.0          # time.monotonic() when the window sent it (RenderResult.submitted)
    history: int = 0           # which network's frame times it counts in (RenderProcess.history)
    hovered: tuple[str, ...] = ()  # canvases under the mouse: their depth is drawn with the frame (live.probes)


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
    tables: dict = field(default_factory=dict)  # 'id.port' -> Table, new since the last result (live.tables)
    table_addresses: tuple[str, ...] = ()       # every table's address now
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
