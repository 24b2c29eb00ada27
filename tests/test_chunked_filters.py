"""The volume filters on a store larger than its memory budget, chunk by chunk into a new store
(vgraph.chunked_filtering): equal to the in-memory filters everywhere (halos handled), a store the
BrickedRayCaster can draw (its pyramid), within the budget in `vgraph run`, bad input named.

The store: the shared CT head (headsq, 64 x 64 x 93 int16, spacing 3.2 x 3.2 x 1.5 mm) stacked
eight times along z (744 slices: a store much taller than a row of bricks with its halo), in 16^3
bricks (so slabs of 16 slices, and tiles of 32 x 32 voxels here: halos along every axis), opened with a
budget below its 5.8 MiB. Tolerance for mixed (float32) values: 1e-6 of the largest |value|, as
tests/test_volume_filters.py."""

import json
import tracemalloc

import numpy as np
import pytest

from helpers.chunked_stores import chunked_cache, over_budget, whole, write_store
from helpers.headsq import read_head
from vgraph.bricks.pyramid import halve
from vgraph.bricks.volume import BrickedVolume, MemoryBudgetError
from vgraph.io.convert import convert
from vgraph.registry import registry

BUDGET_MB = 4.5  # below the store's 5.8 MiB, above a slab's working set


@pytest.fixture(scope="module")
def tall():
    head = read_head()
    return head.with_data(np.concatenate([head.data] * 8))


@pytest.fixture(scope="module")
def store_path(tall, tmp_path_factory):
    return write_store(tall, tmp_path_factory.mktemp("chunked"))


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    return chunked_cache(tmp_path, monkeypatch, tile=32)  # 2 x 2 tiles in a plane of the head


def store(path, budget=BUDGET_MB):
    return over_budget(path, budget)


def run(type_name, volume, **properties):
    return registry.get(type_name)("f", **properties).process(volume=volume)


def assert_close(ours, reference):
    assert ours.shape == reference.shape and ours.dtype == reference.dtype
    tolerance = 1e-6 * max(1.0, float(np.abs(reference).max()))
    assert np.abs(ours.astype(np.float64) - reference).max() <= tolerance


def assert_drawable(volume, reference):
    """A store of the reference's grid whose level 1 is the halving of level 0 (what the
    BrickedRayCaster draws from), with the reference's value range."""
    assert (volume.dims, volume.spacing, volume.origin) == (reference.dims, reference.spacing, reference.origin)
    assert volume.value_range == reference.value_range
    assert len(volume.bricks.levels) >= 3
    level1 = volume.bricks.read(1, (0, 0, 0), volume.bricks.levels[1].shape)
    assert np.allclose(level1, halve(whole(volume)), atol=1e-6 * max(1.0, np.abs(level1).max()))


@pytest.mark.parametrize("sigma", [(3.0, 5.0, 2.0), (6.4, 1.0, 3.0)])
def test_gaussian_of_a_store_larger_than_its_budget_equals_the_in_memory_one(tall, store_path, sigma):
    ours = run("VolumeSmooth", store(store_path), sigma=sigma)
    reference = run("VolumeSmooth", tall, sigma=sigma)
    assert_close(whole(ours), reference.data)
    assert_drawable(ours, reference)


def test_median_of_a_store_larger_than_its_budget_equals_the_in_memory_one(tall, store_path):
    properties = {"filter": "median", "size": (7.0, 10.0, 4.0)}  # 3 x 3 x 3 voxels
    ours = run("VolumeSmooth", store(store_path), **properties)
    reference = run("VolumeSmooth", tall, **properties)
    assert np.array_equal(whole(ours), reference.data) and whole(ours).dtype == np.int16
    assert_drawable(ours, reference)


@pytest.mark.parametrize("properties", [
    {}, {"output": "labels", "lower": 0.2, "upper": 0.6},
    {"method": "otsu"}, {"method": "otsu", "output": "labels", "classes": 4}])
def test_threshold_of_a_store_larger_than_its_budget_equals_the_in_memory_one(tall, store_path, properties):
    ours = run("VolumeThreshold", store(store_path), **properties)
    reference = run("VolumeThreshold", tall, **properties)
    assert np.array_equal(whole(ours), reference.data)
    assert ours.holds_labels and ours.value_range == reference.value_range


def test_crop_of_a_box_larger_than_the_budget_is_a_store_of_its_voxels(tall, store_path):
    box = (3, 5, 7, 60, 50, 350)
    ours = run("VolumeCrop", store(store_path, budget=1.5), units="voxels", voxel_box=box)
    reference = run("VolumeCrop", tall, units="voxels", voxel_box=box)
    assert np.array_equal(whole(ours), reference.data)
    assert_drawable(ours, reference)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_resample_of_a_store_larger_than_its_budget_equals_the_in_memory_one(tall, store_path, interpolation):
    properties = {"spacing": (2.5, 4.0, 1.1), "interpolation": interpolation}
    ours = run("VolumeResample", store(store_path), **properties)
    reference = run("VolumeResample", tall, **properties)
    if interpolation == "linear":
        assert_close(whole(ours), reference.data)
    else:  # equal but where a sample lies halfway between two slices: rounding picks either
        step = 1.1 / 1.5
        start = ((tall.dims[2] - 1) * 1.5 - (reference.dims[2] - 1) * 1.1) / 2 / 1.5
        position = start + np.arange(reference.dims[2]) * step
        ties = np.abs(position - np.floor(position) - 0.5) < 1e-9
        differing = np.unique(np.argwhere(whole(ours) != reference.data)[:, 0])
        assert ties.sum() < 0.2 * ties.size and set(differing) <= set(np.flatnonzero(ties))
    assert (ours.dims, ours.spacing) == (reference.dims, reference.spacing)
    assert np.allclose(ours.origin, reference.origin)


def test_the_same_filter_of_the_same_store_opens_the_cached_store(store_path, cache):
    first = run("VolumeSmooth", store(store_path), sigma=(2.0, 2.0, 2.0))
    assert first.source.startswith(str(cache / "filtered"))
    stamp = (first.bricks.path / "zarr.json").stat().st_mtime_ns
    again = run("VolumeSmooth", store(store_path), sigma=(2.0, 2.0, 2.0))
    assert again.source == first.source and (again.bricks.path / "zarr.json").stat().st_mtime_ns == stamp
    other = run("VolumeSmooth", store(store_path), sigma=(3.0, 2.0, 2.0))
    assert other.source != first.source


def test_a_slab_larger_than_the_budget_is_named_and_nothing_is_written(store_path, cache):
    with pytest.raises(MemoryBudgetError, match=r"^VolumeSmooth 'f': filtering .*tall.zarr chunk by chunk "
                                                r"needs about .* more than its memory budget of 0.5 MiB"):
        run("VolumeSmooth", store(store_path, budget=0.5), sigma=(20.0, 20.0, 20.0))
    assert not list(cache.glob("filtered/*"))


def test_a_store_that_fits_its_budget_is_still_filtered_in_memory(tall, store_path):
    ours = run("VolumeSmooth", BrickedVolume.open(store_path, memory_budget_mb=100), sigma=(2.0, 2.0, 2.0))
    assert not isinstance(ours, BrickedVolume)
    assert_close(ours.data, run("VolumeSmooth", tall, sigma=(2.0, 2.0, 2.0)).data)


def test_vgraph_run_of_a_filter_network_on_a_store_larger_than_its_budget_stays_within_it(tmp_path):
    """A 96 x 96 x 512 float32 store (18 MiB) smoothed and thresholded by `vgraph run` with a 10 MiB
    budget: the peak of traced allocations (numpy's arrays, zarr's and dask's buffers) stays below
    10 MiB. A first run on a small store imports what the filters import (code, not data)."""
    from vgraph.cli import main
    z, y, x = np.mgrid[0:512, 0:96, 0:96].astype(np.float32)
    data = np.sin(x / 7.0) * np.cos(y / 11.0) + np.sin(z / 13.0)
    np.save(tmp_path / "big.npy", data)
    convert(tmp_path / "big.npy", tmp_path / "big.zarr", brick=16, progress=False)
    np.save(tmp_path / "warm.npy", data[:400, :40, :40].copy())
    convert(tmp_path / "warm.npy", tmp_path / "warm.zarr", brick=16, progress=False)
    del data, x, y, z
    network = {"format": "vgraph-network", "version": 3, "processors": [
        {"id": "source", "type": "VolumeSource", "properties": {"path": "warm.zarr", "memory_budget": 2.0}},
        {"id": "smooth", "type": "VolumeSmooth", "properties": {"sigma": [1.5, 1.5, 1.5]}},
        {"id": "threshold", "type": "VolumeThreshold", "properties": {"lower": 0.6}}],
        "connections": [{"from": "source.volume", "to": "smooth.volume"},
                        {"from": "smooth.volume", "to": "threshold.volume"}], "links": []}
    (tmp_path / "warm.json").write_text(json.dumps(network))
    network["processors"][0]["properties"] = {"path": "big.zarr", "memory_budget": 10.0}
    (tmp_path / "big.json").write_text(json.dumps(network))
    assert main(["run", str(tmp_path / "warm.json"), "--port", "threshold.volume"]) == 0
    tracemalloc.start()
    try:
        assert main(["run", str(tmp_path / "big.json"), "--port", "threshold.volume"]) == 0
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10 * 2**20, f"peak {peak / 2**20:.2f} MiB"
    smoothed, labels = sorted((tmp_path / "cache" / "filtered").glob("big.*.zarr"), key=lambda p: len(p.name))
    smoothed, labels = BrickedVolume.open(smoothed), BrickedVolume.open(labels, memory_budget_mb=100)
    assert smoothed.dims == labels.dims == (96, 96, 512) and labels.dtype == np.uint8
    level = (labels.data[::37] == 1).mean()
    assert 0.05 < level < 0.95  # both sides of the level in the store, not an empty mask


def test_a_filtered_store_goes_where_python_asks_and_a_bad_name_is_named(tall, store_path, tmp_path):
    from vgraph.chunked_filtering import filtered_store, voxel_plan
    from vgraph.errors import OutputFileError
    volume = store(store_path)
    plan = voxel_plan(volume, (0, 0, 0), (63, 63, 99), volume.dtype, lambda voxels: voxels, volume.value_range)
    out = filtered_store(volume, plan, "test", {}, output=tmp_path / "mine.zarr", progress=False)
    assert out.source == str(tmp_path / "mine.zarr") and np.array_equal(whole(out), tall.data[:100])
    with pytest.raises(OutputFileError, match=r"mine\.npy.*must end in \.zarr"):
        filtered_store(volume, plan, "test", {}, output=tmp_path / "mine.npy", progress=False)
    assert not (tmp_path / "mine.npy").exists()
