"""Where the workers come from: ``--cluster local:N`` (a LocalCluster of N single-threaded worker
processes on this machine, started and closed around one render) or ``--cluster tcp://HOST:PORT``
(the scheduler of a running cluster; its workers must see the network's files at the same paths).
Dask distributed is the cluster (docs/distributed.md); vgraph never runs one of its own.
"""

from __future__ import annotations

import contextlib
import logging
import re
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
    from distributed import Client, LocalCluster

    if kind == "local":
        with warnings.catch_warnings():
            # Without a dashboard the scheduler still serves HTTP (health, metrics), on 8787 if free,
            # else on another port with a warning that says nothing useful to a vgraph user.
            warnings.filterwarnings("ignore", message="Port 8787 is already in use", category=UserWarning)
            # One thread per worker: a worker's tasks share its one GL context (vgraph.distributed.worker).
            # silence_logs: a task's error reaches the client, which prints it once as a local
            # run does; the workers' own log of it would repeat it with Dask's traceback.
            cluster = LocalCluster(n_workers=value, threads_per_worker=1, processes=True,
                                   host="127.0.0.1", dashboard_address=None,
                                   silence_logs=logging.CRITICAL)
        with cluster, Client(cluster) as client:
            yield client
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
