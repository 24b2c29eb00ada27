"""SweepPlaneRenderer out of core (issue 34 item 2): a store larger than its memory budget swept leaf
by leaf through the brick cache, front to back, equal to the in-memory sweep of the same volume;
leaves the threshold empties are never read (docs/explanations/sweep-plane.md, "Out of core")."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from vgraph import VGraphError
from vgraph.bricks.cache import HALO, MB, brick_extent
from vgraph.camera import Camera
from vgraph.io import read_volume
from vgraph.network import Network
from vgraph.sweep.grid import classified_cells
from vgraph.sweep.leaves import leaves
from vgraph.testing import GivenVolume
from vgraph.transfer_function import TransferFunction

pytest.importorskip("zarr")

SIZE = (48, 40)
BRICK = 8
BUDGET_MB = 0.02  # 20 KiB: four 12^3 uint16 bricks with their halo; the volume is 53 KiB
TOLERANCE = 1e-5  # float32 images; the leaves composite the same segments in the same order
TF = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.0), (0.3, 0.2, 0.6, 0.9, 0.05),
                              (0.7, 0.9, 0.7, 0.2, 0.3), (1.0, 1.0, 0.3, 0.1, 0.6)])


@pytest.fixture(scope="module")
def volumes(tmp_path_factory):
    """The same volume as a store over its budget and in memory."""
    from vgraph.bricks.volume import BrickedVolume
    from vgraph.io.convert import convert
    folder = tmp_path_factory.mktemp("sweep_store")
    z, y, x = np.meshgrid(*[np.linspace(-1.0, 1.0, n) for n in (30, 27, 33)], indexing="ij")
    blob = np.exp(-3.0 * ((x - 0.2) ** 2 + y * y + 1.3 * z * z)) + 0.1 * np.sin(4 * x) * y
    data = (np.clip(blob, 0.0, None) / blob.max() * 60000).astype(np.uint16)
    np.save(folder / "v.npy", data)
    convert(folder / "v.npy", folder / "v.zarr", brick=BRICK, progress=False)
    return BrickedVolume.open(folder / "v.zarr", memory_budget_mb=BUDGET_MB), read_volume(folder / "v.npy")


def camera(projection: str, direction=(-0.45, -0.35, -1.0)) -> Camera:
    return Camera.looking_at_box((0, 0, 0), (32, 26, 29), direction=direction, projection=projection)


def sweep(volume, projection="perspective", direction=(-0.45, -0.35, -1.0), **values):
    net = Network()
    net.add(GivenVolume(id="src", volume=volume))
    net.add("SweepPlaneRenderer", id="sweep", camera=camera(projection, direction), transfer_function=TF,
            background=[0, 0, 0, 0], **values)  # transparent: the alpha is the sweep's coverage
    net.connect("src.volume", "sweep.volume")
    image = net.evaluate("sweep.image", size=SIZE)
    depth = net.evaluate("sweep.depth", size=SIZE)
    return image, depth, net.processors["sweep"].last_sweep


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("threshold", [None, [0.4, 1.0]])
def test_a_store_over_its_budget_is_swept_leaf_by_leaf_as_the_whole_volume(volumes, projection, threshold):
    store, memory = volumes
    assert not store.fits_budget
    got, got_depth, counts = sweep(store, projection, threshold=threshold)
    want, want_depth, whole = sweep(memory, projection, threshold=threshold)
    assert want[..., 3].max() > 0.3  # the blob shows
    assert np.abs(got - want).max() <= TOLERANCE
    assert np.abs(got_depth - want_depth).max() <= TOLERANCE
    assert counts["faces_projected"] >= whole["faces_projected"]  # seam faces twice, no cell lost
    assert 0 < counts["peak_cache_bytes"] <= BUDGET_MB * MB


@pytest.mark.parametrize("direction", [(0.6, 0.3, 0.9), (-0.2, 1.0, 0.3)])
def test_the_leaves_are_composited_front_to_back_from_any_side(volumes, direction):
    """Early termination (0.99, the default) stops a pixel where the leaves in front left it: a
    leaf swept out of visibility order would change the picture."""
    store, memory = volumes
    got, _, _ = sweep(store, direction=direction, early_termination=0.9)
    want, _, _ = sweep(memory, direction=direction, early_termination=0.9)
    assert (want[..., 3] >= 0.9).any()  # early termination stops pixels
    assert np.abs(got - want).max() <= TOLERANCE


def test_leaves_the_threshold_empties_are_never_read(volumes):
    store, memory = volumes
    threshold = (0.75, 1.0)
    _, _, counts = sweep(store, threshold=list(threshold))
    source = store.bricks
    all_leaves = leaves(source, 0)
    values = memory.normalized(memory.data)
    kept = classified_cells(values, threshold)
    holding = [leaf for leaf in all_leaves
               if kept[tuple(slice(a, b - 1) for a, b in zip(leaf.start, leaf.stop))].any()]
    assert 0 < len(holding) <= counts["leaves_swept"] < len(all_leaves)
    # The store's per-brick min/max say a leaf is empty when its brick and the next along each axis
    # (its overlap voxel's) hold no value in the threshold: exactly those leaves are never read.
    lo, hi = memory.value_range
    raw = (np.asarray(threshold) * (hi - lo) + lo)

    def may_hold(leaf):
        region = memory.data[tuple(slice(a, a + 2 * BRICK) for a in leaf.start)]
        return region.max() >= raw[0] and region.min() <= raw[1]

    def bytes_with_halo(leaf):  # uint16 voxels of the brick and its halo
        start, stop = brick_extent(source, leaf.key)
        return int(np.prod(stop - start + 2 * HALO)) * 2

    read = [leaf for leaf in all_leaves if may_hold(leaf)]
    assert counts["leaves_swept"] == len(read)
    assert counts["bytes_read"] == sum(bytes_with_halo(leaf) for leaf in read)
    assert counts["bytes_read"] < 0.6 * sum(bytes_with_halo(leaf) for leaf in all_leaves)


def test_peak_memory_of_the_out_of_core_sweep_stays_below_the_whole_volumes(volumes):
    store, memory = volumes
    peaks = []
    for volume in (store, memory):
        sweep(volume)  # compiled and warm
        tracemalloc.start()
        sweep(volume)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[0] < peaks[1]


def test_a_coarser_leaf_level_sweeps_the_coarser_grid(volumes):
    store, _ = volumes
    fine, _, fine_counts = sweep(store)
    coarse, _, coarse_counts = sweep(store, leaf_level=1)
    assert coarse_counts["vertices_swept"] < fine_counts["vertices_swept"] / 4
    assert np.abs(coarse - fine).mean() < 0.05


def test_a_leaf_over_the_budget_and_a_missing_level_are_refused_by_name(volumes, tmp_path):
    from vgraph.bricks.volume import BrickedVolume
    store, _ = volumes
    tiny = BrickedVolume(store.bricks, memory_budget_mb=0.001, source="tiny.zarr")
    with pytest.raises(VGraphError, match="sweep'.*leaf of the store tiny.zarr needs .* over the volume's "
                                          "memory budget"):
        sweep(tiny)
    with pytest.raises(VGraphError, match="sweep'.leaf_level: 9 is not a level of the store"):
        sweep(store, leaf_level=9)
