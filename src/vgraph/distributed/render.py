"""``vgraph.distributed.render``: one picture of a network rendered by the workers of a Dask cluster.

    image = render("networks/raycast_sphere.json", client, split="tiles", tiles=(2, 2))

The client checks the network (its target is an image, nothing in it needs the whole image), cuts
the picture into tiles (vgraph.distributed.tiles), submits one task per tile (the network's JSON
document and its folder, never its volumes) and assembles the rectangles the workers return. The
result is the picture ``vgraph run`` / ``Network.evaluate`` gives in one process, to the tolerance
docs/guide/distributed.md states.
"""

from __future__ import annotations

import uuid
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import vgraph
from vgraph.distributed.cluster import one_thread_each
from vgraph.distributed.leaves import bricked_caster, render_leaves
from vgraph.distributed.report import ClusterFrame, measured, task_report
from vgraph.distributed.tiles import Tile, TileError, assemble, check_grid, cut, untileable
from vgraph.distributed.watch import ClusterWarning, TaskCancelledError, TaskTimeout, results, watch
from vgraph.distributed.worker import render_tile, shipped
from vgraph.image import Image
from vgraph.network import Network
from vgraph.scheduler import default_size, default_target, target_type

SPLITS = ("tiles", "leaves")


@dataclass(frozen=True)
class Plan:
    """What a render will do, checked before any cluster is asked: the network, its target, the
    image size and the tiles."""

    network: object
    target: str
    size: tuple[int, int]
    tiles: list[Tile]


def render(network_or_path, client, split: str = "tiles", tiles=(2, 2), size=None,
           target: str | None = None, plugins=(), runs: int | None = None,
           timeout: TaskTimeout | None = None, cluster: str | None = None) -> np.ndarray:
    """The picture of render_report (the same arguments), without the report."""
    return render_report(network_or_path, client, split, tiles, size, target, plugins, runs, timeout,
                         cluster).image


def render_report(network_or_path, client, split: str = "tiles", tiles=(2, 2), size=None,
                  target: str | None = None, plugins=(), runs: int | None = None,
                  timeout: TaskTimeout | None = None, cluster: str | None = None) -> ClusterFrame:
    """A ClusterFrame (vgraph.distributed.report): ``image``, the image at ``target`` (default:
    the network's Canvas, as ``vgraph run`` picks it) at ``size`` (width, height; default: the
    Canvas's size), float32 (H, W, 4), row 0 at the top, as Network.evaluate returns it. ``network_or_path``: a Network, or a .json network or volume file
    (as ``vgraph.load`` reads it). ``client``: a dask.distributed Client. ``tiles``: (columns,
    rows) of the tiles split. ``plugins``: plug-in modules the workers import before building the
    network (as ``--plugin``; each worker must be able to import them). ``runs``: how many runs
    of bricks the leaves split draws in parallel (default: one per worker; vgraph.distributed.leaves).
    ``timeout``: how long a task may run before its worker is restarted (default: the Dask
    configuration's vgraph.task-timeout; vgraph.distributed.watch). ``cluster``: the cluster's name
    in messages (default: the scheduler's address). A frame one of whose tasks the scheduler
    cancelled (the client did not) is drawn again with new tasks, once, with a ClusterWarning. A
    cluster with a worker of several threads is refused (ClusterError: its GL context serves one).
    Its ``tasks`` and ``workers`` say what each task and each worker read through its brick
    caches (bytes, bricks or leaves) and the seconds it computed."""
    plan = prepare(network_or_path, split, tiles, size, target)
    one_thread_each(client, cluster)
    for attempt in (1, 2):
        try:
            if split == "leaves":
                return render_leaves(plan, client, runs, plugins, timeout, cluster)
            return render_tiles(plan, client, plugins, timeout, cluster)
        except TaskCancelledError as error:  # the scheduler dropped a task: new tasks, once
            if attempt == 2:
                raise
            warnings.warn(ClusterWarning(f"{error}; the frame is drawn again"), stacklevel=2)


def render_tiles(plan: Plan, client, plugins=(), timeout: TaskTimeout | None = None,
                 cluster: str | None = None) -> ClusterFrame:
    """The picture of ``plan`` drawn by the tiles split (one task per tile), with its report."""
    document, base_dir = shipped(plan.network)
    # Unique keys: the same tile of another call (a changed file with the same name) is new work.
    token = uuid.uuid4().hex[:12]
    futures = {client.submit(measured, render_tile, document, base_dir, plan.target, plan.size, tile,
                             tuple(plugins), pure=False, key=f"vgraph-tile-{token}-{i}"):
               tile_label(i, plan.tiles) for i, tile in enumerate(plan.tiles)}
    watch(client, futures, timeout, cluster)
    done = results(client, futures, cluster)
    reports = tuple(task_report(label, costs) for label, (_, costs) in zip(futures.values(), done))
    return ClusterFrame(assemble(plan.size, plan.tiles, [pixels for pixels, _ in done]), "tiles", reports)


def tile_label(index: int, tiles: list[Tile]) -> str:
    """How messages name a tile: 'tile 3 of 4 (pixels 32-63 x 0-23)'."""
    tile = tiles[index]
    return (f"tile {index + 1} of {len(tiles)} (pixels {tile.x}-{tile.x + tile.width - 1} x "
            f"{tile.y}-{tile.y + tile.height - 1})")


def prepare(network_or_path, split: str = "tiles", tiles=(2, 2), size=None,
            target: str | None = None) -> Plan:
    """Check everything render() can refuse without a cluster (``vgraph run --cluster`` asks
    before starting one): the split, the grid, the target (an image) and the network (nothing in
    it needs the whole image)."""
    if split not in SPLITS:
        raise TileError(f"unknown split '{split}'; choose one of {', '.join(SPLITS)}")
    grid = check_grid(tiles)
    network = _network(network_or_path)
    target = target or default_target(network)
    data_type = target_type(network, target)
    if data_type is not None and not issubclass(data_type, Image):
        raise TileError(f"{target} carries {data_type.__name__}, not an image: only images can be "
                        "rendered as tiles")
    size = tuple(int(v) for v in size) if size is not None else \
        tuple(default_size(network, [target.partition(".")[0]]))
    if split == "leaves":  # every worker renders the whole picture: nothing needs to be tileable
        bricked_caster(network, target)
        return Plan(network, target, size, [])
    reasons = untileable(network, target)
    if reasons:
        raise TileError("this network cannot be rendered as tiles: " + "; ".join(reasons))
    return Plan(network, target, size, cut(size, grid))


def _network(network_or_path):
    if isinstance(network_or_path, Network):
        return network_or_path
    if isinstance(network_or_path, (str, Path)):
        return vgraph.load(network_or_path)
    raise TypeError(f"render() takes a Network or the path of a network or volume file, got "
                    f"{type(network_or_path).__name__}")
