"""SweepPlaneRenderer on a Dask cluster (issue 34 item 3; docs/guide/distributed.md): the tiles split
(each tile sweeps the leaves it sees) and the leaves split (each leaf once on one worker, partials
composited in visibility order) equal the single-process picture; render_report says what each
worker read (tiles: every leaf its tiles see; leaves: each leaf once); with early termination the
leaves split is within 1 - early_termination of the single process."""

import re

import numpy as np
import pytest

from vgraph.distributed import render, render_report
from vgraph.distributed.render import prepare
from vgraph.network import Network
from vgraph.transfer_function import TransferFunction

pytest.importorskip("zarr")
pytestmark = pytest.mark.filterwarnings("ignore:Port 8787 is already in use")

SIZE = (48, 40)
# The same cell segments composited in another grouping (tiles: the same; leaves: runs of leaves
# composited pairwise in float64): measured below 1e-7 on float32 images.
TOLERANCE = 1e-6
TF = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.0), (0.3, 0.2, 0.6, 0.9, 0.05),
                              (0.7, 0.9, 0.7, 0.2, 0.3), (1.0, 1.0, 0.3, 0.1, 0.6)])


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """A rippled ball as an OME-Zarr store of 8^3 bricks (the workers read it themselves)."""
    from vgraph.io.convert import convert
    folder = tmp_path_factory.mktemp("sweep_cluster")
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (26, 22, 29)], indexing="ij")
    ball = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.1 * np.sin(7 * x)
    np.save(folder / "ball.npy", (np.clip(ball, 0, 1) * 65535).astype(np.uint16))
    convert(folder / "ball.npy", folder / "ball.zarr", brick=8, progress=False)
    return folder


def network(path, renderer="sweep", **values) -> Network:
    """``renderer``: the renderer's id; another id is another network on the workers (their
    networks, and so their caches, are kept by document)."""
    net = Network(base_dir=path.parent)
    net.add("VolumeSource", id="src", path=str(path))
    net.add("SweepPlaneRenderer", id=renderer, transfer_function=TF, **values)
    net.connect("src.volume", f"{renderer}.volume")
    return net


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        yield client


def test_the_leaves_split_takes_a_store_with_or_without_early_termination(store):
    for stop_at in (0.99, 1.0):
        assert prepare(network(store / "ball.zarr", early_termination=stop_at), split="leaves",
                       target="sweep.image", size=SIZE).tiles == []


@pytest.mark.parametrize("name, threshold", [("ball.zarr", None), ("ball.zarr", [0.3, 1.0]), ("ball.npy", None)])
def test_tiles_on_two_workers_equal_the_single_process_picture(client, store, name, threshold):
    net = network(store / name, threshold=threshold)
    reference = net.evaluate("sweep.image", size=SIZE)
    assert np.ptp(reference[..., :3]) > 0.1
    image = render(net, client, split="tiles", tiles=(2, 2), size=SIZE, target="sweep.image")
    assert image.shape == reference.shape and image.dtype == np.float32
    assert np.abs(image - reference).max() <= TOLERANCE


@pytest.mark.parametrize("threshold", [None, [0.3, 1.0]])
def test_leaves_on_two_workers_equal_the_single_process_picture(client, store, threshold):
    net = network(store / "ball.zarr", threshold=threshold, early_termination=1.0)
    reference = net.evaluate("sweep.image", size=SIZE)
    leaves = net["sweep"].last_sweep["leaves_swept"]
    assert leaves >= 8 and np.ptp(reference[..., :3]) > 0.1
    for runs in (None, 3):  # one run per worker; three runs: a tree of two composites
        image = render(net, client, split="leaves", size=SIZE, runs=runs, target="sweep.image")
        assert image.shape == reference.shape and image.dtype == np.float32
        assert np.abs(image - reference).max() <= TOLERANCE, (runs, np.abs(image - reference).max())
    depth = render(net, client, split="leaves", size=SIZE, runs=3, target="sweep.depth")
    assert np.abs(depth - net.evaluate("sweep.depth", size=SIZE)).max() <= TOLERANCE


# --- what each worker read (render_report) ------------------------------------------------------------
def cache_reads(client, renderer) -> dict:
    """Worker address -> bytes read by the brick cache of ``renderer`` in the networks the
    worker holds (the cache's own counter; other networks may come and go meanwhile)."""
    def counted():
        from vgraph.distributed.worker import kept_networks
        return sum(net[renderer].cache.stats["bytes_read"] for net in kept_networks() if renderer in net.processors)
    return client.run(counted)


def leaves_seen(net, renderer, tile) -> set:
    """The leaves (cache keys) one process reads for ``tile`` of the SIZE picture."""
    from vgraph.distributed.tiles import cameras, set_tile_cameras
    from vgraph.distributed.worker import build, shipped
    copy = build(*shipped(net))
    set_tile_cameras(copy, cameras(copy), tile, SIZE)
    copy.evaluate(f"{renderer}.image", size=tile.rendered[2:])
    assert copy[renderer].last_sweep["leaves_swept"] == len(copy[renderer].cache.ram)  # none evicted
    return set(copy[renderer].cache.ram)


def test_tiles_read_every_leaf_their_tiles_see_on_each_worker(client, store):
    from vgraph.bricks.cache import read_with_halo
    from vgraph.distributed import cut
    net = network(store / "ball.zarr", renderer="tiles_bytes")
    reference = net.evaluate("tiles_bytes.image", size=SIZE)
    single = net["tiles_bytes"].last_sweep["bytes_read"]
    source = net.output("src.volume").bricks
    size_of = {}

    def read(keys):
        return sum(size_of.setdefault(k, read_with_halo(source, k).nbytes) for k in keys)

    tiles = cut(SIZE, (2, 1))
    seen = [leaves_seen(net, "tiles_bytes", tile) for tile in tiles]
    assert seen[0] & seen[1] and read(seen[0] | seen[1]) == single  # leaves on the seam: seen by both
    before = cache_reads(client, "tiles_bytes")
    frame = render_report(net, client, split="tiles", tiles=(2, 1), size=SIZE, target="tiles_bytes.image")
    assert np.abs(frame.image - reference).max() <= TOLERANCE and frame.split == "tiles"
    after = cache_reads(client, "tiles_bytes")
    on = {}  # worker -> the leaves its tiles see
    for tile_seen, task in zip(seen, frame.tasks):
        on.setdefault(task.worker, set()).update(tile_seen)
    assert set(frame.workers) == set(on)
    for address, worker in frame.workers.items():
        assert worker.bytes_read == read(on[address]) == after[address] - before[address]
        assert worker.bricks_read == len(on[address]) and worker.seconds > 0
    # Each worker reads what its tiles see: on two workers the seam's leaves twice in all.
    assert frame.bytes_read == sum(read(keys) for keys in on.values()) >= single
    if len(on) == 2:
        assert frame.bytes_read == read(seen[0]) + read(seen[1]) > single


def test_leaves_read_each_leaf_once_in_all_and_report_it_per_worker(client, store):
    net = network(store / "ball.zarr", renderer="leaves_bytes", early_termination=1.0)
    reference = net.evaluate("leaves_bytes.image", size=SIZE)
    single = net["leaves_bytes"].last_sweep
    before = cache_reads(client, "leaves_bytes")
    frame = render_report(net, client, split="leaves", size=SIZE, runs=3, target="leaves_bytes.image")
    after = cache_reads(client, "leaves_bytes")
    assert np.abs(frame.image - reference).max() <= TOLERANCE and frame.split == "leaves"
    assert frame.bytes_read == single["bytes_read"] and frame.bricks_read == single["leaves_swept"]
    for address, worker in frame.workers.items():
        assert worker.bytes_read == after[address] - before[address]
    runs = [task for task in frame.tasks if task.task.startswith("run ")]
    assert len(runs) == 3
    for task in runs:  # each run read its own leaves: 'run 2 of 3 (bricks 17-32 of 48)'
        first, last = (int(v) for v in re.search(r"bricks (\d+)-(\d+) of", task.task).groups())
        assert task.bricks_read == last - first + 1 and task.seconds > 0
    assert sum(task.bytes_read for task in frame.tasks if not task.task.startswith("run ")) == 0
    again = render_report(net, client, split="leaves", size=SIZE, runs=3, target="leaves_bytes.image")
    assert np.array_equal(again.image, frame.image)
    # A run on the worker that drew it last frame reads nothing (that worker's caches keep its
    # leaves); Dask's work stealing may hand a run waiting behind another to an idle worker, which
    # then reads its leaves once (docs/guide/distributed.md, "Where runs go").
    before = {task.task: task for task in runs}
    for task in again.tasks:
        if task.task.startswith("run "):
            moved = task.worker != before[task.task].worker
            assert task.bytes_read == (before[task.task].bytes_read if moved else 0), task
        else:
            assert task.bytes_read == 0, task


def test_one_run_per_worker_is_read_once_and_kept_by_its_worker_frame_after_frame(client, store):
    net = network(store / "ball.zarr", renderer="leaves_kept", early_termination=1.0)
    net.evaluate("leaves_kept.image", size=SIZE)
    single = net["leaves_kept"].last_sweep
    frames = [render_report(net, client, split="leaves", size=SIZE, target="leaves_kept.image")
              for _ in range(3)]
    assert frames[0].bytes_read == single["bytes_read"]
    assert [frame.bytes_read for frame in frames[1:]] == [0, 0]  # each worker busy with its own run: none moves
    assert all(np.array_equal(frame.image, frames[0].image) for frame in frames[1:])


# --- the leaves split with early termination -------------------------------------------------------------
@pytest.mark.parametrize("stop_at", [0.5, 0.9, 0.99])
def test_leaves_with_early_termination_are_within_one_minus_it_of_the_single_process(client, store, stop_at):
    """Each run stops its rays at its own opacity, never before one sweep would; the composite
    keeps the front alone where it is opaque: the extra segments lie behind the point one sweep
    stops at, so the picture differs by at most 1 - early_termination (sweep-plane.md)."""
    net = network(store / "ball.zarr", early_termination=stop_at)
    reference = net.evaluate("sweep.image", size=SIZE)
    depth = net.evaluate("sweep.depth", size=SIZE)
    net.set("sweep.early_termination", 1.0)
    assert np.abs(net.evaluate("sweep.image", size=SIZE) - reference).max() > 0.5 * (1 - stop_at)  # it stops rays
    net.set("sweep.early_termination", stop_at)
    for runs in (None, 3):
        image = render(net, client, split="leaves", size=SIZE, runs=runs, target="sweep.image")
        assert np.abs(image - reference).max() <= (1 - stop_at) + TOLERANCE, (runs, np.abs(image - reference).max())
    split_depth = render(net, client, split="leaves", size=SIZE, runs=3, target="sweep.depth")
    # The first segment with opacity lies before any stop: the depth is one sweep's; the runs
    # composite at least the segments one sweep does.
    assert np.abs(split_depth[..., [0, 1, 3]] - depth[..., [0, 1, 3]]).max() <= TOLERANCE
    assert (split_depth[..., 2] >= depth[..., 2]).all()
