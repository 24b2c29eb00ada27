"""Watching the tasks of one frame until they are done: a task that runs too long has its worker
restarted, so that Dask runs it again on another worker (docs/guide/distributed.md, "A worker that
stops or dies").

Dask reruns the tasks of a worker that is lost (killed, out of memory, restarted), but it has no
time limit for a task: a worker that stops (SIGSTOP, a hung driver, a network file system that
never answers) keeps its tasks for good. So the client waits on the frame's futures in short steps
and asks the scheduler where each task is (``Client.processing``):

- A task's time counts from when the scheduler gives it to a worker (it may first wait there
  behind another task). It may take ``TaskTimeout.allowance``: while no task of the frame has
  finished, ``first`` seconds (a worker's first task builds the network, reads the volume and
  makes its GL context); afterwards ``multiple`` times the slowest finished task of the frame,
  at least ``floor`` seconds.
- A worker holding a task past its allowance is restarted (``Scheduler.restart_workers``: its
  nanny kills the process and starts a new one; a worker without a nanny is removed), with a
  ``ClusterWarning`` naming the task, the worker and the seconds. The scheduler then gives the
  task to another worker, with a new allowance there. When tasks are late and some workers have
  stopped sending heartbeats (``SILENT_SECONDS``), those are restarted instead: a late task on a
  worker that still answers may just be waiting for its inputs from a stopped one, and gets a
  new allowance.
- A task that outlived its allowance on ``attempts`` workers, or that Dask gave up on because the
  workers running it died (``KilledWorker``: ``distributed.scheduler.allowed-failures``), or a
  cluster left without workers for an allowance, ends the frame with ``ClusterTaskError``: exit
  2, naming the cluster, the task and the seconds waited. The workers still running the frame's
  tasks are then restarted (once the tasks are cancelled), free for the next frame.
- A task the scheduler cancelled (the client did not) is a ``TaskCancelledError``: render()
  draws the frame again, once.
- However ``watch`` ends (done, an error, Ctrl-C), the frame's unfinished futures are cancelled.

The numbers are Dask configuration (``vgraph.task-timeout.first`` and so on, or the environment
variables ``DASK_VGRAPH__TASK_TIMEOUT__FLOOR`` and the like), read when a frame starts.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

from vgraph.errors import VGraphError, VGraphWarning

POLL_SECONDS = 0.5  # how often the scheduler is asked where the frame's tasks are
SILENT_SECONDS = 5.0  # a worker unheard of this long has stopped (heartbeats: every 0.5 s, <= 10 workers)
RESTART_SECONDS = 30.0  # for a nanny to stop its worker; one that cannot is removed from the scheduler
# A cluster whose workers were all restarted has none until they are back: a new Python process
# importing vgraph, seconds on a loaded machine. Only after this is it "left without workers".
COMEBACK_SECONDS = 30.0
DEFAULTS = {"first": 120.0, "multiple": 10.0, "floor": 30.0, "attempts": 3}


class ClusterWarning(VGraphWarning):
    """A fault of the cluster the frame goes on after: a worker restarted, a frame drawn again."""


class ClusterTaskError(VGraphError, RuntimeError):
    """A task of a frame that no worker of the cluster finished."""

    def __init__(self, task: str, reason: str, cluster: str | None = None):
        self.task, self.reason, self.cluster = task, reason, cluster
        super().__init__(str(self))

    def __str__(self) -> str:
        return f"cluster {self.cluster or '?'}: {self.task} did not finish: {self.reason}"


@dataclass(frozen=True)
class TaskTimeout:
    """How long a task may run before its worker is restarted (see the module docstring)."""

    first: float = DEFAULTS["first"]        # seconds, while no task of the frame has finished
    multiple: float = DEFAULTS["multiple"]  # times the slowest finished task of the frame ...
    floor: float = DEFAULTS["floor"]        # ... but at least this many seconds
    attempts: int = DEFAULTS["attempts"]    # workers a task may outlive its allowance on

    @classmethod
    def from_config(cls) -> "TaskTimeout":
        """The numbers of the Dask configuration's ``vgraph.task-timeout`` (DEFAULTS where unset)."""
        # Dask (0.4 s to import) loads only when a cluster is used
        import dask

        values = {name: dask.config.get(f"vgraph.task-timeout.{name}", default)
                  for name, default in DEFAULTS.items()}
        try:
            timeout = cls(first=float(values["first"]), multiple=float(values["multiple"]),
                          floor=float(values["floor"]), attempts=int(values["attempts"]))
        except (TypeError, ValueError) as error:
            raise VGraphError(f"Dask configuration vgraph.task-timeout: {error}") from None
        if min(timeout.first, timeout.multiple, timeout.floor) <= 0 or timeout.attempts < 1:
            raise VGraphError(f"Dask configuration vgraph.task-timeout: first, multiple and floor must be "
                              f"positive and attempts at least 1, got {values}")
        return timeout

    def allowance(self, slowest: float | None) -> float:
        """Seconds a task may take, given the slowest finished task of the frame (None: none yet)."""
        if slowest is None:
            return self.first
        return max(self.floor, self.multiple * slowest)

    def rule(self, slowest: float | None) -> str:
        if slowest is None:
            return f"{self.first:g} s while no task of the frame has finished"
        return f"{self.multiple:g} x the slowest finished task ({slowest:.2f} s), at least {self.floor:g} s"


@dataclass
class _Task:
    label: str
    since: float  # when it was seen given to its worker; not yet: the last look that found it waiting
    worker: str | None = None  # where the scheduler has it (None: waiting, for a worker or its inputs)
    outlived: list = field(default_factory=list)  # (worker, seconds) of the tries that ran too long


def watch(client, tasks: dict, timeout: TaskTimeout | None = None, cluster: str | None = None) -> None:
    """Wait until every future of ``tasks`` (future -> what it computes, e.g. "tile 3 of 4") is
    done, restarting the workers that hold a task past its allowance. Raises the first task's
    error (a ClusterTaskError when no worker finished it). Cancels the unfinished futures on the
    way out, whatever ends the wait (Ctrl-C included)."""
    frame = _Frame(client, tasks, timeout or TaskTimeout.from_config(), cluster or _address(client))
    try:
        frame.run()
    finally:
        unfinished = [future for future in tasks if not future.done()]
        if unfinished:
            _cancel(client, unfinished)
        if frame.abandoned:
            # Only once cancelled (else the scheduler would give the tasks to other workers): the
            # workers still running tasks given up on (which may hang as the one that ended the
            # frame did; a cancelled task runs on) are restarted, free for the frames to come.
            try:
                _restart(client, frame.abandoned)
            except Exception:  # the error that ended the frame is the one to report
                pass


class _Frame:
    """The watch over one frame's futures (see watch)."""

    def __init__(self, client, tasks: dict, timeout: TaskTimeout, cluster: str):
        self.client, self.timeout, self.cluster = client, timeout, cluster
        self.start = time.monotonic()
        self.states = {future.key: _Task(label, self.start) for future, label in tasks.items()}
        self.pending = set(tasks)
        self.slowest: float | None = None  # seconds, of the slowest finished task
        self.restarted: set[str] = set()  # workers restarted and not yet gone from the scheduler
        self.workerless_since: float | None = None
        self.restarted_at: float | None = None  # when this frame last restarted workers
        self.abandoned: set[str] = set()  # workers to restart once the frame is given up

    def run(self) -> None:
        # Dask (0.4 s to import) loads only when a cluster is used
        from distributed import wait
        from distributed.client import FuturesCancelledError

        while self.pending:
            try:
                done, self.pending = wait(self.pending, timeout=POLL_SECONDS, return_when="FIRST_COMPLETED")
            except TimeoutError:
                done = set()
            except FuturesCancelledError:  # cancelled, not by us: said by _raise_for below
                done = {future for future in self.pending if future.status == "cancelled"}
            now = time.monotonic()
            order = list(self.states)  # as given: a cause before what depends on it (leaves)
            for future in sorted(done, key=lambda f: order.index(f.key)):
                _raise_for(future, self.states[future.key], self.cluster)
                # At most this long on its worker: it was not there yet at the look before.
                self.slowest = max(self.slowest or 0.0, now - self.states[future.key].since)
            if self.pending:
                self.look(now)

    def look(self, now: float) -> None:
        """Note where each pending task is; restart the workers holding one past its allowance,
        or give up on a task that has outlived it on ``attempts`` workers."""
        processing = self.client.processing()  # every worker -> the keys it holds
        allowance = self.timeout.allowance(self.slowest)
        self.check_workers(processing, allowance, now)
        self.restarted &= set(processing)  # gone from the scheduler: an address seen again is new
        where = {key: worker for worker, keys in processing.items() for key in keys
                 if worker not in self.restarted}  # a restarted worker's tasks are on their way elsewhere
        late = []  # (task, worker, seconds there) past the allowance
        for future in self.pending:
            state, worker = self.states[future.key], where.get(future.key)
            if worker is None or worker != state.worker:  # waiting, or given to a worker: a new try
                state.worker, state.since = worker, now
            elif now - state.since > allowance:
                late.append((state, worker, now - state.since))
        if not late:
            return
        silent = _silent(self.client, set(processing) - self.restarted)
        if silent:
            # A late task on a worker that still answers may only be waiting for its inputs, held
            # by a silent (stopped) one: the silent ones are restarted, and it gets a new
            # allowance (a lost input is computed again).
            for state, worker, _ in late:
                if worker not in silent:
                    state.since = now
            late = [entry for entry in late if entry[1] in silent]
        for state, worker, seconds in late:
            state.outlived.append((worker, seconds))
            state.worker, state.since = None, now  # its next worker starts a new try
            if len(state.outlived) >= self.timeout.attempts:
                busy = {where[f.key] for f in self.pending if f.key in where}
                self.abandoned = busy | {w for _, w, _ in late}
                tries = ", ".join(f"{s:.0f} s on {address}" for address, s in state.outlived)
                raise ClusterTaskError(state.label, f"waited {now - self.start:.0f} s ({tries}; a task may "
                                       f"take {self.timeout.rule(self.slowest)}: the Dask configuration "
                                       "vgraph.task-timeout sets it)", self.cluster)
        overdue = {worker for _, worker, _ in late} | silent
        _restart(self.client, overdue)
        self.restarted |= overdue
        if overdue:
            self.restarted_at = now
        for state, worker, seconds in late:  # say so: the frame goes on, later than it would have
            warnings.warn(ClusterWarning(
                f"cluster {self.cluster}: {state.label} was {seconds:.0f} s on worker {worker} (a task "
                f"may take {self.timeout.rule(self.slowest)}): the worker was restarted and the task "
                "given to another"), stacklevel=2)
        for worker in sorted(silent - {worker for _, worker, _ in late}):
            warnings.warn(ClusterWarning(
                f"cluster {self.cluster}: worker {worker} stopped answering while tasks of the frame waited "
                "(for its data, perhaps): it was restarted"), stacklevel=2)

    def check_workers(self, processing: dict, allowance: float, now: float) -> None:
        """A cluster left without workers (all lost, none coming back) finishes nothing: after the
        allowance the frame ends, naming a task that waits; workers this frame restarted get
        COMEBACK_SECONDS more to come back."""
        if processing:
            self.workerless_since = None
            return
        coming_back = self.restarted_at is not None and now - self.restarted_at < COMEBACK_SECONDS
        if self.workerless_since is None:
            self.workerless_since = now
        elif now - self.workerless_since > allowance and not coming_back:
            label = self.states[next(iter(self.pending)).key].label
            raise ClusterTaskError(label, f"the cluster has had no worker for "
                                   f"{now - self.workerless_since:.0f} s (waited {now - self.start:.0f} s)",
                                   self.cluster)


def _silent(client, workers) -> set[str]:
    """Those of ``workers`` whose last heartbeat reached the scheduler more than SILENT_SECONDS
    (or three heartbeat intervals, on a large cluster) ago, by the scheduler's clock: stopped, or
    stuck where they cannot even answer."""
    def ages(dask_scheduler=None):
        # Dask (0.4 s to import) loads only when a cluster is used
        from distributed.scheduler import heartbeat_interval

        now = time.time()
        silent = max(SILENT_SECONDS, 3.0 * heartbeat_interval(len(dask_scheduler.workers)))
        return {address: now - worker.last_seen > silent
                for address, worker in dask_scheduler.workers.items()}

    try:
        heard = client.run_on_scheduler(ages)
    except Exception:  # no answer about heartbeats: treat the late workers alike
        return set()
    return {worker for worker in workers if heard.get(worker, False)}


def _restart(client, workers) -> None:
    """Dask's own way out of a worker that holds a task too long (Scheduler.restart_workers): its
    nanny kills the process and starts a new one; a worker without a nanny is removed from the
    scheduler (its process is left to whoever started it). Either way the scheduler gives the
    worker's tasks to the other workers. Returns once the old processes are gone, without waiting
    for the new ones (the frame goes on with the workers there are)."""
    client.run_on_scheduler(_restart_workers, sorted(workers))


async def _restart_workers(addresses, dask_scheduler=None) -> None:
    await dask_scheduler.restart_workers(addresses, timeout=RESTART_SECONDS, wait_for_workers=False,
                                         on_error="return", stimulus_id=f"vgraph-task-timeout-{time.time()}")


class TaskCancelledError(ClusterTaskError):
    """The scheduler cancelled a task of the frame that the client did not cancel (seen once in
    a few hundred fault cases, after a worker was killed: FutureCancelledError, reason unknown).
    render() draws such a frame again, once."""


def _raise_for(future, state: _Task, cluster: str) -> None:
    """The task's own error, ClusterTaskError where Dask gave up on it (its workers died), or
    TaskCancelledError where the scheduler cancelled it."""
    if future.status == "cancelled":
        raise TaskCancelledError(state.label, f"the scheduler cancelled it ({_cancelled_reason(future)})",
                                 cluster)
    if future.status != "error":
        return
    # Dask (0.4 s to import) loads only when a cluster is used
    from distributed import KilledWorker

    error = future.exception()
    if isinstance(error, KilledWorker):
        raise ClusterTaskError(state.label, f"{error.allowed_failures + 1} workers died or were "
                               f"restarted while running it (the last was {error.last_worker.address}; "
                               "distributed.scheduler.allowed-failures in the Dask configuration)",
                               cluster) from None
    future.result()  # raises the task's error as the client received it


def _cancelled_reason(future) -> str:
    try:
        future.result()  # cancelled, so done: raises at once
    except Exception as error:  # FutureCancelledError, saying why where Dask knows
        return str(error)
    return "no reason given"


def results(client, tasks: dict, cluster: str | None = None) -> list:
    """The results of ``tasks`` (future -> label, all done), in their order; a future the
    scheduler cancelled meanwhile is a TaskCancelledError."""
    # Dask (0.4 s to import) loads only when a cluster is used
    from distributed.client import FutureCancelledError

    try:
        return client.gather(list(tasks))
    except FutureCancelledError as error:
        label = next((label for future, label in tasks.items() if future.key == error.key), "a task")
        raise TaskCancelledError(label, f"the scheduler cancelled it ({error})",
                                 cluster or _address(client)) from None


def _cancel(client, futures) -> None:
    """Cancel what is left of a frame, without letting a second failure hide the first."""
    try:
        client.cancel(futures)
    except Exception:  # the client or cluster is already going away: nothing is left to run
        pass


def _address(client) -> str:
    try:
        return str(client.scheduler.address)
    except Exception:
        return "?"
