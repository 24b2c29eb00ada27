"""What each worker read and computed for one cluster frame (issue 34: "bytes read per worker for
tiles against leaves"; docs/guide/distributed.md "What each worker read").

- Worker side (``measured``): a task runs its function and reports, with the result, the worker's
  address, the seconds the function took there and what the brick caches of the worker's
  networks read from their stores while the task held the worker's GL lock (``bytes_read``,
  ``bricks_read``: the caches' own counters, vgraph.bricks.cache.BrickCache.stats;
  ``counted_reads``): its own reads only, whichever of the worker's networks it evaluated, also
  while another thread of the worker reads. Every renderer that reads a store does so
  through a BrickCache: the BrickedRayCaster's bricks (of a store, or of the pyramid it makes of
  a volume in memory), the SweepPlaneRenderer's leaves (one leaf is one brick). A renderer that
  draws a volume in memory whole (the RayCaster, a SweepPlaneRenderer on a Volume) reads through
  no cache: 0 here (its source read the file, once per worker).
- Client side (``ClusterFrame``): the picture with one ``TaskReport`` per task that finished,
  summed per worker (``workers``). A task that did not finish (its worker died) reports nothing;
  its rerun on another worker reports there.
"""

from __future__ import annotations

import contextlib
import threading
import time
from dataclasses import dataclass

import numpy as np

from vgraph.bricks.cache import BrickCache
from vgraph.memory import format_bytes

COUNTED = ("bytes_read", "bricks_read")  # the BrickCache counters a task reports


@dataclass(frozen=True)
class TaskReport:
    """One finished task: where it ran, what its worker's caches read, how long it took there."""

    task: str  # as messages name it: 'tile 2 of 4 (pixels ...)', 'run 1 of 2 (bricks 1-5 of 9)'
    worker: str  # the worker's address
    bytes_read: int
    bricks_read: int  # bricks of a BrickedRayCaster, leaves of a SweepPlaneRenderer
    seconds: float  # the task's function in the worker (building the network, reading, drawing)


@dataclass(frozen=True)
class WorkerReport:
    """A worker's tasks of one frame, summed."""

    bytes_read: int
    bricks_read: int
    seconds: float
    tasks: int


@dataclass(frozen=True)
class ClusterFrame:
    """A picture drawn on a cluster (vgraph.distributed.render_report) and what its tasks did."""

    image: np.ndarray  # float32 (H, W, 4), row 0 at the top, as render() returns it
    split: str  # "tiles" or "leaves"
    tasks: tuple[TaskReport, ...]

    @property
    def workers(self) -> dict[str, WorkerReport]:
        """Worker address -> its tasks summed, by address."""
        summed = {}
        for address in sorted({task.worker for task in self.tasks}):
            mine = [task for task in self.tasks if task.worker == address]
            summed[address] = WorkerReport(sum(t.bytes_read for t in mine), sum(t.bricks_read for t in mine),
                                           sum(t.seconds for t in mine), len(mine))
        return summed

    @property
    def bytes_read(self) -> int:
        """All workers together."""
        return sum(task.bytes_read for task in self.tasks)

    @property
    def bricks_read(self) -> int:
        return sum(task.bricks_read for task in self.tasks)

    def lines(self) -> list[str]:
        """One line per worker, as ``vgraph run --cluster`` prints them."""
        return [f"  worker {address}: read {format_bytes(w.bytes_read)} ({w.bricks_read} bricks), "
                f"computed {w.seconds:.3f} s in {w.tasks} task(s)" for address, w in self.workers.items()]


def task_report(label: str, measured_values: dict) -> TaskReport:
    """The client's record of a task from what ``measured`` returned with its result."""
    return TaskReport(label, measured_values["worker"], int(measured_values["bytes_read"]),
                      int(measured_values["bricks_read"]), float(measured_values["seconds"]))


# --- in the worker process ---------------------------------------------------------------------------
# The reads of the task each thread runs (``measured``): the caches' counters around a task's whole
# function would also count what another thread of the process read meanwhile (a worker with
# several threads, which render_report refuses as cluster.one_thread_each says, ran a composite
# beside a run). Reads are counted inside ``counted_reads`` blocks instead, which hold the
# worker's GL lock.
_TASK = threading.local()


def measured(function, *args):
    """(``function(*args)``, what it cost this worker: its address, the seconds, and what the
    brick caches of the worker's networks read in its ``counted_reads`` blocks)."""
    _TASK.read = dict.fromkeys(COUNTED, 0)
    started = time.perf_counter()
    try:
        result = function(*args)
    finally:
        read, _TASK.read = _TASK.read, None
    seconds = time.perf_counter() - started
    return result, {"worker": _address(), "seconds": seconds, **read}


@contextlib.contextmanager
def counted_reads(networks):
    """Counts for this thread's task (``measured``) what the brick caches of ``networks()`` (the
    worker's networks, asked again at the end: the block may build one) read in the block. The
    block must hold the worker's GL lock (vgraph.distributed.worker.GL_LOCK), which every task
    holds while it evaluates a network: what is read meanwhile is this task's alone."""
    before = {id(cache): (cache, _counts(cache)) for cache in _caches(networks())}
    try:
        yield
    finally:
        tally = getattr(_TASK, "read", None)
        if tally is not None:  # a task function called outside measured() counts nothing
            for cache in _caches(networks()):
                earlier = before.get(id(cache))
                start = earlier[1] if earlier is not None and earlier[0] is cache else dict.fromkeys(COUNTED, 0)
                for name in COUNTED:
                    tally[name] += cache.stats[name] - start[name]


def _caches(networks) -> list[BrickCache]:
    """The brick caches of the networks' processors (the processor's own, or its parts'), once each."""
    found = {}
    for network in networks:
        for processor in network.processors.values():
            holders = [processor, *getattr(processor, "parts", {}).values()]
            for holder in holders:
                cache = getattr(holder, "cache", None)
                if isinstance(cache, BrickCache):
                    found[id(cache)] = cache
    return list(found.values())


def _counts(cache: BrickCache) -> dict:
    return {name: cache.stats[name] for name in COUNTED}


def _address() -> str:
    """This worker's address (the scheduler's name for it); a task run outside a worker: its pid."""
    try:
        from distributed import get_worker
        return str(get_worker().address)
    except (ImportError, ValueError):
        import os
        return f"pid {os.getpid()}"
