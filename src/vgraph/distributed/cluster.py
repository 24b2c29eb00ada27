"""Where the workers come from: ``--cluster local:N`` (a LocalCluster of N single-threaded worker
processes on this machine, started and closed around one render) or ``--cluster tcp://HOST:PORT``
(the scheduler of a running cluster; its workers must see the network's files at the same paths).
Dask distributed is the cluster (docs/guide/distributed.md); vgraph never runs one of its own.
"""

from __future__ import annotations

import contextlib
import logging
import re
import signal
import threading
import warnings

from vgraph.errors import VGraphError

CONNECT_TIMEOUT = 3.0  # seconds to reach a scheduler before saying it cannot be reached


class ClusterError(VGraphError, ValueError):
    """A cluster address that is malformed or cannot be reached."""


def parse_cluster(spec: str) -> tuple[str, int | str]:
    """('local', N) or ('address', 'tcp://HOST:PORT') from a --cluster value."""
    spec = str(spec).strip()
    local = re.fullmatch(r"local:(\d+)", spec)
    if local:
        workers = int(local.group(1))
        if workers < 1:
            raise ClusterError(f"--cluster {spec}: a local cluster needs at least one worker")
        return "local", workers
    if re.fullmatch(r"(tcp|tls)://[^\s:/]+:\d+", spec):
        return "address", spec
    raise ClusterError(f"--cluster {spec}: expected local:N (N worker processes here) or "
                       "tcp://HOST:PORT (a running Dask scheduler)")


@contextlib.contextmanager
def connect(spec: str, timeout: float = CONNECT_TIMEOUT):
    """A dask.distributed Client for a --cluster value, closed (with the LocalCluster it started)
    on leaving the block."""
    kind, value = parse_cluster(spec)
    # Dask (0.4 s to import) loads only when a cluster is used
    from distributed import Client

    if kind == "local":
        # A LocalCluster cut short by Ctrl-C while it starts or closes leaves worker processes
        # and a cluster half up (Dask's exit hook then fails on it): there Ctrl-C is noted and
        # raised once the cluster is up, or closed; while the client is used it acts at once.
        with _CtrlC() as ctrl_c:
            with local_cluster(value) as cluster, Client(cluster) as client:
                ctrl_c.acts()
                try:
                    yield client
                finally:
                    ctrl_c.noted()
        return
    try:
        client = Client(value, timeout=timeout)
    except (OSError, TimeoutError) as error:
        raise ClusterError(f"--cluster {spec}: cannot reach a Dask scheduler there within "
                           f"{timeout:g} s ({type(error).__name__}: {error})") from None
    try:
        yield client
    finally:
        client.close()


def one_thread_each(client, cluster: str | None = None) -> None:
    """Refuses (ClusterError) a cluster with a worker of several threads: a worker's tasks draw in
    its process's one GL context, which is current only in the thread that made it; a task on
    another thread fails ('cannot create texture', seen with 2 threads a worker)."""
    workers = client.scheduler_info().get("workers", {})
    crowded = sorted(f"{address} ({info['nthreads']} threads)" for address, info in workers.items()
                     if info.get("nthreads", 1) > 1)
    if crowded:
        raise ClusterError(f"cluster {cluster or client.scheduler.address}: worker {', '.join(crowded)}: "
                           "vgraph's tasks need one thread per worker (a worker's GL context serves one "
                           "thread); start the workers with `dask worker SCHEDULER --nthreads 1`")


@contextlib.contextmanager
def local_cluster(workers: int):
    """A LocalCluster of ``workers`` single-threaded worker processes on 127.0.0.1, closed on
    leaving the block."""
    # Dask (0.4 s to import) loads only when a cluster is used
    import dask
    from distributed import LocalCluster

    # A worker restarted by its nanny (vgraph.distributed.watch: a stalled task) is removed and
    # registers again under its name; the LocalCluster closes the nanny of a name that is missing
    # lost-worker-timeout (15 s) after a removal, so a second restart of that worker about 15 s
    # after the first lost it for good (seen here; dask/distributed#7312 is a relative). The
    # nannies bring their workers back themselves: nothing is left for that check to close.
    with dask.config.set({"distributed.deploy.lost-worker-timeout": "100 days"}):
        with warnings.catch_warnings():
            # Without a dashboard the scheduler still serves HTTP (health, metrics), on 8787 if
            # free, else on another port with a warning that says nothing useful to a vgraph user.
            warnings.filterwarnings("ignore", message="Port 8787 is already in use", category=UserWarning)
            # One thread per worker: a worker's tasks share its one GL context (vgraph.distributed.worker).
            # silence_logs: a task's error reaches the client, which prints it once as a local
            # run does; the workers' own log of it would repeat it with Dask's traceback.
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   host="127.0.0.1", dashboard_address=None, silence_logs=logging.CRITICAL)
        with cluster:
            yield cluster


class _CtrlC:
    """Where Ctrl-C (SIGINT) acts: ``noted()`` from here on it is only noted, ``acts()`` it
    raises KeyboardInterrupt (at once if one was noted). Noted from entering the block, and on
    leaving it a noted Ctrl-C is raised (unless an exception is already on its way) and the
    previous handler restored. Only in the main thread, which alone receives signals (the GUI's
    render process connects from another thread): elsewhere it does nothing."""

    def __init__(self):
        self.pressed = False
        self.active = threading.current_thread() is threading.main_thread()
        self.previous = None

    def __enter__(self):
        if self.active:
            self.previous = signal.getsignal(signal.SIGINT)
            self.noted()
        return self

    def __exit__(self, kind, error, traceback):
        if self.active:
            signal.signal(signal.SIGINT, self.previous)
            if self.pressed and kind is None:
                raise KeyboardInterrupt

    def noted(self) -> None:
        if self.active:
            signal.signal(signal.SIGINT, self._note)

    def acts(self) -> None:
        if not self.active:
            return
        if self.pressed:  # pressed while the cluster started: stop now (closing it, still noted)
            self.pressed = False
            raise KeyboardInterrupt
        signal.signal(signal.SIGINT, self.previous)

    def _note(self, signum, frame) -> None:
        self.pressed = True
