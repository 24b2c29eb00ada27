"""SweepPlaneRenderer on a Dask cluster (issue 34 item 3; docs/guide/distributed.md): the tiles split
(each tile sweeps the leaves it sees) and the leaves split (each leaf once on one worker, partials
composited in visibility order) equal the single-process picture."""

import numpy as np
import pytest

from vgraph.distributed import TileError, render
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


def network(path, **values) -> Network:
    net = Network(base_dir=path.parent)
    net.add("VolumeSource", id="src", path=str(path))
    net.add("SweepPlaneRenderer", id="sweep", transfer_function=TF, **values)
    net.connect("src.volume", "sweep.volume")
    return net


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        yield client


def test_the_leaves_split_needs_a_store_and_no_early_termination(store):
    with pytest.raises(TileError, match="sweep.early_termination: 0.99"):
        prepare(network(store / "ball.zarr"), split="leaves", target="sweep.image", size=SIZE)
    assert prepare(network(store / "ball.zarr", early_termination=1.0), split="leaves",
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
