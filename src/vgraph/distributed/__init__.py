"""Rendering on a Dask cluster (issue #15; docs/guide/distributed.md).

One concept per module: ``tiles`` (cutting a picture, the tile cameras, assembling),
``worker`` (what runs in a worker process: the shipped network, its one GL context),
``leaves`` (the sort-last split: runs of a BrickedRayCaster's bricks, composited on the workers),
``render`` (the client side: ``render(network_or_path, client, split="tiles"|"leaves", ...)``;
``render_report`` the same with what each worker read, ``report``),
``watch`` (waiting on a frame's tasks: a worker holding one past its allowance is restarted, a
task no worker finishes is a ClusterTaskError), ``cluster`` (``local:N`` or ``tcp://HOST:PORT``
-> a Client) and ``faults`` (killed, stopped and slowed workers for the fault tests and
bench/cluster_faults.py). Dask itself is imported only when a cluster is used.
"""

from vgraph.distributed.cluster import ClusterError, connect, parse_cluster
from vgraph.distributed.render import SPLITS, render, render_report
from vgraph.distributed.report import ClusterFrame, TaskReport, WorkerReport
from vgraph.distributed.tiles import Tile, TileError, cut, parse_grid
from vgraph.distributed.watch import ClusterTaskError, TaskTimeout

__all__ = ["ClusterError", "ClusterFrame", "ClusterTaskError", "SPLITS", "TaskReport", "TaskTimeout", "Tile",
           "TileError", "WorkerReport", "connect", "cut", "parse_cluster", "parse_grid", "render", "render_report"]
