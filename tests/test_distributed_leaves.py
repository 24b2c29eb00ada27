"""The leaves split (sort-last, issue #15; docs/guide/distributed.md "Leaves"): runs of a BrickedRayCaster
frame's bricks drawn on two worker processes and composited in visibility order equal the
single-process picture; and a worker killed during a render is replaced while the frame still
completes with the right picture (tiles and leaves)."""

import os
import re
import signal
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from vgraph.distributed import TileError, render, render_report
from vgraph.distributed.leaves import composite, split_runs
from vgraph.distributed.render import prepare

from distributed_cases import bricked_network_of as bricked_network
from helpers.paths import REPO

SPHERE = REPO / "networks" / "raycast_sphere.json"
PSNR_FLOOR = 50.0  # dB against the single-process picture (the bar)
# dvr regroups the "under" sums of the bricks' colours: measured up to 1.2e-7 (tests/
# test_distributed_stiff.py and `bench/distributed_tolerances.py`); mip and iso are identical.
DVR_TOLERANCE = 1e-6
# A local cluster without a dashboard still serves HTTP, on another port if 8787 is taken.
pytestmark = pytest.mark.filterwarnings("ignore:Port 8787 is already in use")


def psnr(image, reference) -> float:
    mse = float(np.mean((image.astype(np.float64) - reference.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def volume_file(folder, shape=(37, 29, 41)):
    """A ball with ripples, saved where the workers read it (the volume never travels)."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in shape], indexing="ij")
    data = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.15 * np.sin(9 * x)
    path = folder / "ball.npy"
    np.save(path, np.clip(data, 0, 1).astype(np.float32))
    return path


# --- without a cluster ------------------------------------------------------------------------------
def test_runs_are_contiguous_balanced_and_cover_every_brick():
    assert split_runs([], 3) == []
    assert split_runs([5, 5], 4) == [(0, 1), (1, 2)]  # never an empty run
    runs = split_runs([1, 1, 1, 1, 8, 1, 1, 1, 1], 2)
    assert runs == [(0, 5), (5, 9)] or runs == [(0, 4), (4, 9)]
    runs = split_runs(np.ones(10), 3)
    assert runs[0][0] == 0 and runs[-1][1] == 10 and all(a[1] == b[0] for a, b in zip(runs, runs[1:]))
    assert max(b - a for a, b in runs) - min(b - a for a, b in runs) <= 1


def test_composite_is_the_passes_blending():
    rng = np.random.default_rng(3)
    alpha = rng.random((4, 5, 1)).astype(np.float32)
    front = (np.concatenate([rng.random((4, 5, 3)) * alpha, alpha], -1).astype(np.float32),
             np.zeros((4, 5, 4), np.float32))
    back = (np.full((4, 5, 4), 0.5, np.float32), np.tile(np.float32([7, 0, 0, 1]), (4, 5, 1)))
    total, first = composite(front, back, "dvr")
    assert np.allclose(total, front[0] + (1 - alpha) * back[0])
    assert np.array_equal(first, back[1])  # the front run had no sample there
    mip_front = (np.tile(np.float32([0.5, 3, 0, 1]), (1, 3, 1)), np.zeros((1, 3, 4), np.float32))
    mip_back = (np.float32([[[0.7, 9, 0, 1], [0.5, 9, 0, 1], [0, 0, 0, 0]]]), np.zeros((1, 3, 4), np.float32))
    total, _ = composite(mip_front, mip_back, "mip")
    assert total[0, :, 1].tolist() == [9, 3, 3]  # a larger maximum wins; a tie keeps the front


def test_leaves_need_one_bricked_raycaster_without_early_termination(tmp_path):
    with pytest.raises(TileError, match="one BrickedRayCaster.*needs none"):
        prepare(SPHERE, split="leaves")
    network = bricked_network(volume_file(tmp_path), early_termination=0.99)
    with pytest.raises(TileError, match="rc.early_termination: 0.99"):
        prepare(network, split="leaves")
    network.set("rc.compositing", "mip")  # early termination is dvr's only
    assert prepare(network, split="leaves").tiles == []


# --- on two worker processes ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        yield client


@pytest.mark.parametrize("mode, properties", [
    ("dvr", {"shading": "blinn_phong"}),
    ("mip", {}),
    ("iso", {"iso_level": 0.45, "shading": "blinn_phong"}),
])
def test_leaves_equal_the_single_process_picture(client, tmp_path, mode, properties):
    network = bricked_network(volume_file(tmp_path), compositing=mode, **properties)
    reference = network.evaluate(size=(64, 48))
    bricks = network["rc"].last_frame["bricks"]
    assert bricks >= 8 and np.ptp(reference[..., :3]) > 0.1
    for runs in (None, 3):  # one run per worker; three runs: a tree of two composites
        image = render(network, client, split="leaves", size=(64, 48), runs=runs)
        assert image.shape == reference.shape and image.dtype == np.float32
        if mode == "dvr":
            assert np.abs(image - reference).max() <= DVR_TOLERANCE, (runs, np.abs(image - reference).max())
        else:
            assert np.array_equal(image, reference), (mode, runs)
    # The depth output (the first depth sample, or mip's maximum's) is resolved from the composite
    # too, identical (the composite blends with IEEE arithmetic as the GL does).
    depth = render(network, client, split="leaves", target="rc.depth", size=(64, 48), runs=3)
    assert np.array_equal(depth, network.evaluate("rc.depth", size=(64, 48)), equal_nan=True)


def test_leaves_of_an_ome_zarr_store_read_by_the_workers(client, tmp_path):
    from vgraph.io.convert import convert
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, 96)] * 3, indexing="ij")
    ball = np.clip(255 * (1.0 - np.sqrt(x * x + 1.3 * y * y + z * z)), 0, 255).astype(np.uint8)
    np.save(tmp_path / "ball.npy", ball)
    convert(tmp_path / "ball.npy", tmp_path / "ball.zarr", brick=32, progress=False)
    network = bricked_network(tmp_path / "ball.zarr", compositing="mip")
    reference = network.evaluate(size=(48, 40))
    single = dict(network["rc"].cache.stats)  # one process, a fresh cache: the frame's bricks
    frame = render_report(network, client, split="leaves", size=(48, 40))
    assert psnr(frame.image, reference) >= PSNR_FLOOR
    # What each worker's brick cache read (vgraph.distributed.report): each planned brick once in all.
    assert frame.bytes_read == single["bytes_read"] > 0 and frame.bricks_read == single["bricks_read"]
    assert sum(w.bytes_read for w in frame.workers.values()) == frame.bytes_read
    tiles = render_report(network, client, split="tiles", tiles=(2, 1), size=(48, 40))
    assert np.array_equal(tiles.image, reference)  # a worker that ran a run has its bricks already:
    assert all(w.bytes_read <= single["bytes_read"] for w in tiles.workers.values())  # at most the rest


def test_a_new_view_reuses_the_workers_networks_and_their_bricks(client, tmp_path):
    """Frames from two views of one network: the workers keep the network built for the first (its
    cameras aside), so the second frame reads (almost) no brick again, and is still exact."""
    from vgraph.distributed.worker import worker_info

    def bricks_read():
        from vgraph.distributed import worker
        return sum(network[0]["rc"].cache.stats["bricks_read"] for network in worker._NETWORKS.values())

    network = bricked_network(volume_file(tmp_path), compositing="mip")
    render(network, client, split="leaves", size=(48, 40))
    first = sum(client.run(bricks_read).values())
    network.set("eep.camera", network.get("eep.camera").rotate(0.05, 0.0))
    image = render(network, client, split="leaves", size=(48, 40))
    again = sum(client.run(bricks_read).values()) - first
    assert first > 0 and again <= first // 4
    assert all(info["networks"] <= 2 for info in client.run(worker_info).values())
    assert psnr(image, network.evaluate(size=(48, 40))) >= PSNR_FLOOR


def test_cli_split_leaves_writes_the_local_image(tmp_path, capsys):
    import PIL.Image

    from vgraph.cli import main
    bricked_network(volume_file(tmp_path), compositing="dvr").save(tmp_path / "net.json")
    leaves, local = tmp_path / "leaves.png", tmp_path / "local.png"
    assert main(["run", str(tmp_path / "net.json"), "-o", str(leaves), "--size", "64x48",
                 "--cluster", "local:2", "--split", "leaves"]) == 0
    err = capsys.readouterr().err
    assert "as runs of bricks (leaves) on 2 worker(s) of local:2" in err
    # then a line per worker: what its brick cache read and the seconds its tasks computed
    read = re.findall(r"^  worker tcp://[\d.:]+: read [\d.]+ \w+ \((\d+) bricks\), computed [\d.]+ s in "
                      r"\d+ task\(s\)$", err, re.MULTILINE)
    assert len(read) == 2 and sum(int(n) for n in read) > 0, err
    assert main(["run", str(tmp_path / "net.json"), "-o", str(local), "--size", "64x48"]) == 0
    a, b = (np.asarray(PIL.Image.open(p), dtype=int) for p in (leaves, local))
    assert np.abs(a - b).max() <= 1  # 8-bit: a float32 rounding can cross a level at most
    assert main(["run", str(tmp_path / "net.json"), "-o", str(leaves), "--cluster", "local:2",
                 "--split", "leaves", "--tiles", "2x2"]) == 2
    assert "--split leaves divides the bricks" in capsys.readouterr().err


# --- a worker killed during a render ----------------------------------------------------------------
def render_killing_a_worker(client, submit, drawing):
    """Start ``submit()`` (a render) in a thread, SIGKILL the worker process running one of its
    tasks for which ``drawing(key)`` holds, and return the render's result."""
    pids = client.run(os.getpid)
    with ThreadPoolExecutor(1) as pool:
        result = pool.submit(submit)
        deadline = time.monotonic() + 60
        victim = None
        while victim is None and time.monotonic() < deadline and not result.done():
            for address, keys in client.processing().items():
                if address in pids and any(drawing(str(key)) for key in keys):
                    victim = address
                    break
            else:
                time.sleep(0.01)
        assert victim is not None and not result.done(), "the render finished before a worker was killed"
        os.kill(pids[victim], signal.SIGKILL)
        image = result.result(timeout=180)
    client.wait_for_workers(2, timeout=60)  # the nanny started a new worker in its place
    assert pids[victim] not in client.run(os.getpid).values()
    return image


@pytest.mark.parametrize("split", ["tiles", "leaves"])
def test_a_worker_killed_during_a_render_is_replaced_and_the_frame_completes(tmp_path, split):
    from distributed import Client, LocalCluster
    network = bricked_network(volume_file(tmp_path, (64, 56, 72)), brick_size=8, shading="blinn_phong")
    size = (160, 120)
    reference = network.evaluate(size=size)
    # Killed while it draws a tile, or a run of bricks (not the leaves' plan: a run is rescheduled).
    drawing = (lambda key: key.startswith("vgraph-tile-")) if split == "tiles" else \
        (lambda key: key.startswith("vgraph-leaves-") and "-run" in key)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        options = {"tiles": (6, 6)} if split == "tiles" else {"runs": 6}
        image = render_killing_a_worker(
            client, lambda: render(network, client, split=split, size=size, **options), drawing)
    floor = PSNR_FLOOR if split == "leaves" else 90.0  # tiles differ by float rounding only
    assert psnr(image, reference) >= floor
