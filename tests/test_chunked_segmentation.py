"""The segmentation processors (VolumeMorphology, ConnectedComponents, GradientMagnitude, VolumeMath,
VolumeMask) and cubic resampling on a store larger than its memory budget, chunk by chunk into a
new store (vgraph.chunked_segmentation): equal to the in-memory processors (bit for bit; cubic
within 1e-6 of the largest |value|), the label flag carried by the store, refusals named.

The stores: the middle 32 x 32 voxels of the shared CT head's slices, stacked twelve times along z
(32 x 32 x 1116 int16, spacing 3.2 x 3.2 x 1.5) in 16^3 bricks, opened with a budget below its 2.2
MiB (a store must be many brick rows deep to exceed a budget that holds a row's working set), and
its masks and labels made from it chunk by chunk (VolumeThreshold); a random mask (32 x 32 x 2560,
7 % of the voxels: thousands of components, many of one voxel, so the numbering's ties are
tested). Tiles of 16 x 16 voxels (TILE patched), so halos and components cross tiles along y and
x as well as z."""

import json

import numpy as np
import pytest

from helpers.chunked_stores import chunked_cache, over_budget, whole, write_store
from helpers.headsq import read_head
from vgraph import PropertyError
from vgraph.bricks.volume import BrickedVolume
from vgraph.io.convert import convert
from vgraph.registry import registry
from vgraph.volume import Volume

BUDGET_MB = 2.1  # below the head store's 2.2 MiB, above a slab's working set
MASK_BUDGET_MB = 1.05  # below its masks' 1.09 MiB
NOISE_BUDGET_MB = 2.4  # below the random mask's 2.5 MiB


@pytest.fixture(scope="module")
def tall():
    head = read_head()
    return head.with_data(np.concatenate([head.data[:, 16:48, 16:48]] * 12))


@pytest.fixture(scope="module")
def store_path(tall, tmp_path_factory):
    return write_store(tall, tmp_path_factory.mktemp("segmentation"))


@pytest.fixture(scope="module")
def noise_path(tmp_path_factory):
    folder = tmp_path_factory.mktemp("noise")
    mask = (np.random.default_rng(7).random((2560, 32, 32)) < 0.07).astype(np.uint8)
    np.save(folder / "noise.npy", mask)
    convert(folder / "noise.npy", folder / "noise.zarr", brick=16, progress=False)
    return folder / "noise.zarr"


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    return chunked_cache(tmp_path, monkeypatch, tile=16)


def store(path, budget=BUDGET_MB):
    return over_budget(path, budget)


def run(type_name, **inputs_and_properties):
    inputs = {k: v for k, v in inputs_and_properties.items() if isinstance(v, Volume)}
    properties = {k: v for k, v in inputs_and_properties.items() if k not in inputs}
    return registry.get(type_name)("f", **properties).process(**inputs)


def assert_same(ours, reference):
    """The store holds the in-memory result's voxels, type, grid and label flag."""
    data = whole(ours)
    assert data.dtype == reference.data.dtype and np.array_equal(data, reference.data)
    assert (ours.dims, ours.spacing, ours.origin) == (reference.dims, reference.spacing, reference.origin)
    assert ours.holds_labels == reference.holds_labels


def masks(tall, store_path, **threshold):
    """A mask or labels of the head: chunk by chunk from the store, and in memory."""
    return (run("VolumeThreshold", volume=store(store_path), **threshold),
            run("VolumeThreshold", volume=tall, **threshold))


# --- VolumeMorphology ---------------------------------------------------------------------------
@pytest.mark.parametrize("operation", ["dilate", "open"])
def test_grey_morphology_of_a_store_equals_the_in_memory_one(tall, store_path, operation):
    properties = {"operation": operation, "radius": 4.8}  # 1 x 1 x 3 voxels: an ellipsoid
    assert_same(run("VolumeMorphology", volume=store(store_path), **properties),
                run("VolumeMorphology", volume=tall, **properties))


@pytest.mark.parametrize("operation", ["close", "erode"])
def test_mask_morphology_of_a_store_equals_the_in_memory_one(tall, store_path, operation):
    stored, in_memory = masks(tall, store_path, lower=0.3)
    ours = run("VolumeMorphology", volume=store(stored.source, budget=MASK_BUDGET_MB), operation=operation,
               radius=4.8)
    assert_same(ours, run("VolumeMorphology", volume=in_memory, operation=operation, radius=4.8))
    assert ours.holds_labels


@pytest.mark.parametrize("operation", ["dilate", "open"])
def test_label_morphology_of_a_store_equals_the_in_memory_one(tall, store_path, operation):
    stored, in_memory = masks(tall, store_path, output="labels", lower=0.2, upper=0.5)
    ours = run("VolumeMorphology", volume=store(stored.source, budget=MASK_BUDGET_MB), operation=operation, radius=4.8)
    assert_same(ours, run("VolumeMorphology", volume=in_memory, operation=operation, radius=4.8))


# --- ConnectedComponents ------------------------------------------------------------------------
@pytest.mark.parametrize("connectivity, min_size", [(6, 0.0), (26, 0.0), (18, 3.0)])
def test_components_of_a_store_equal_the_in_memory_ones(noise_path, connectivity, min_size):
    """Thousands of components across tiles and slabs, numbered as in memory: by size, ties by
    the first voxel in memory order (scipy's numbering)."""
    volume = store(noise_path, budget=NOISE_BUDGET_MB)
    ours = run("ConnectedComponents", volume=volume, connectivity=connectivity, min_size=min_size)
    in_memory = Volume(BrickedVolume.open(noise_path, memory_budget_mb=100).data, spacing=volume.spacing,
                       holds_labels=True)
    reference = run("ConnectedComponents", volume=in_memory, connectivity=connectivity, min_size=min_size)
    assert reference.component_count > 1000
    assert_same(ours, reference)
    assert np.array_equal(ours.voxel_counts, reference.voxel_counts)
    assert np.array_equal(ours.world_volumes, reference.world_volumes)
    assert ours.component_count == reference.component_count
    assert ours.value_range == reference.value_range


def test_components_of_a_thresholded_head_store_equal_the_in_memory_ones(tall, store_path):
    stored, in_memory = masks(tall, store_path, lower=0.3)
    ours = run("ConnectedComponents", volume=store(stored.source, budget=MASK_BUDGET_MB), connectivity=6)
    reference = run("ConnectedComponents", volume=in_memory, connectivity=6)
    assert_same(ours, reference)
    assert np.array_equal(ours.voxel_counts, reference.voxel_counts)


def test_components_of_intensities_in_a_store_are_refused_by_name(store_path, cache):
    volume = BrickedVolume.open(store_path, memory_budget_mb=100)
    floats = Volume(volume.data.astype(np.float32) + 0.5, spacing=volume.spacing)
    np.save(cache.parent / "floats.npy", floats.data)
    convert(cache.parent / "floats.npy", cache.parent / "floats.zarr", brick=16, progress=False)
    with pytest.raises(Exception, match=r"ConnectedComponents 'f': .*floats.zarr holds intensities, not labels"):
        run("ConnectedComponents", volume=store(cache.parent / "floats.zarr"))
    assert not list(cache.glob("filtered/*"))


# --- GradientMagnitude --------------------------------------------------------------------------
@pytest.mark.parametrize("properties", [{}, {"method": "gaussian", "sigma": (3.2, 6.4, 2.0)}])
def test_gradient_magnitude_of_a_store_equals_the_in_memory_one(tall, store_path, properties):
    ours = run("GradientMagnitude", volume=store(store_path), **properties)
    reference = run("GradientMagnitude", volume=tall, **properties)
    data = whole(ours)
    assert data.dtype == reference.data.dtype == np.float32
    assert np.array_equal(data, reference.data)
    assert ours.value_range == pytest.approx(reference.value_range, rel=1e-6)


# --- VolumeMath and VolumeMask ------------------------------------------------------------------
@pytest.mark.parametrize("operation", ["add", "subtract", "max", "mask"])
def test_math_of_a_store_and_a_volume_equals_the_in_memory_one(tall, store_path, operation):
    stored, in_memory = masks(tall, store_path, output="labels", lower=0.2, upper=0.5)
    ours = run("VolumeMath", first=store(store_path), second=store(stored.source, budget=MASK_BUDGET_MB), operation=operation)
    reference = run("VolumeMath", first=tall, second=in_memory, operation=operation)
    assert_same(ours, reference)
    assert ours.value_range == reference.value_range
    # one input in memory, the other a store
    assert_same(run("VolumeMath", first=tall, second=store(stored.source, budget=MASK_BUDGET_MB), operation=operation),
                reference)


def test_math_resampling_an_in_memory_second_onto_a_store_equals_the_in_memory_one(tall, store_path):
    second = run("VolumeResample", volume=tall, spacing=(6.0, 5.0, 2.5))
    ours = run("VolumeMath", first=store(store_path), second=second, grid="resample", operation="subtract")
    reference = run("VolumeMath", first=tall, second=second, grid="resample", operation="subtract")
    # each slab's sample positions are computed from its own offset: float rounding apart
    data = whole(ours)
    assert data.dtype == reference.data.dtype == np.float32
    assert np.abs(data - reference.data).max() <= 1e-6 * np.abs(reference.data).max()


def test_math_resampling_a_store_larger_than_its_budget_is_refused_by_name(tall, store_path, cache):
    with pytest.raises(PropertyError, match=r"^f\.grid: grid = resample samples the second volume whole"):
        run("VolumeMath", first=tall, second=store(store_path), grid="resample")
    assert not list(cache.glob("filtered/*"))


def test_mask_of_a_store_by_stored_labels_equals_the_in_memory_one(tall, store_path):
    stored, in_memory = masks(tall, store_path, output="labels", lower=0.2, upper=0.5)
    properties = {"keep": "2", "outside": -1000.0}
    ours = run("VolumeMask", volume=store(store_path), labels=store(stored.source, budget=MASK_BUDGET_MB), **properties)
    assert_same(ours, run("VolumeMask", volume=tall, labels=in_memory, **properties))


# --- cubic resampling ---------------------------------------------------------------------------
def test_cubic_resampling_of_a_store_is_within_1e_6_of_the_in_memory_one(tall, store_path):
    """The B-spline prefilter runs along whole axes; each slab is prefiltered with 16 slices more
    on each side, which leaves an error far below 1e-6 of the largest |value| (measured: 2.9e-8
    here, float32 rounding; 99.99 % of the voxels equal)."""
    properties = {"spacing": (2.5, 4.0, 1.1), "interpolation": "cubic"}
    ours = run("VolumeResample", volume=store(store_path), **properties)
    reference = run("VolumeResample", volume=tall, **properties)
    data = whole(ours)
    assert data.dtype == reference.data.dtype == np.float32 and data.shape == reference.data.shape
    error = np.abs(data.astype(np.float64) - reference.data).max() / np.abs(reference.data).max()
    assert error < 1e-6, error
    assert np.allclose(ours.origin, reference.origin) and ours.spacing == reference.spacing


# --- the label flag -----------------------------------------------------------------------------
def test_a_label_store_carries_the_label_flag_and_an_intensity_store_does_not(tall, store_path):
    """Threshold and components write NGFF's image-label into the store: opened again (as the
    LabelRayCaster's VolumeSource opens it) it is a label volume; a smoothed store is not."""
    stored, _ = masks(tall, store_path, lower=0.3)
    components = run("ConnectedComponents", volume=store(stored.source, budget=MASK_BUDGET_MB))
    smoothed = run("VolumeSmooth", volume=store(store_path), sigma=(3.2, 3.2, 3.0))
    for volume, labels in ((stored, True), (components, True), (smoothed, False)):
        attributes = json.loads((volume.bricks.path / "zarr.json").read_text())["attributes"]
        assert ("image-label" in attributes["ome"]) == labels
        assert BrickedVolume.open(volume.source).holds_labels == labels
    source = registry.get("VolumeSource")("s", path=components.source)
    assert source.process().holds_labels


def test_morphology_of_float_labels_in_a_store_is_refused_by_name(noise_path, cache):
    """A label store of floats (another tool's: the image-label flag on float32 voxels) is refused
    by chunked morphology, naming the property and what to do; nothing is written."""
    mask = BrickedVolume.open(noise_path, memory_budget_mb=100).data.astype(np.float32)
    np.save(cache.parent / "float_labels.npy", mask)
    path = cache.parent / "float_labels.zarr"
    convert(cache.parent / "float_labels.npy", path, brick=16, progress=False)
    metadata = json.loads((path / "zarr.json").read_text())
    metadata["attributes"]["ome"]["image-label"] = {}
    (path / "zarr.json").write_text(json.dumps(metadata))
    volume = store(path, budget=8.0)
    assert volume.holds_labels
    with pytest.raises(PropertyError, match=r"^f\.radius: .*float_labels\.zarr holds labels as floats: chunked "
                                            r"morphology takes integer labels"):
        run("VolumeMorphology", volume=volume, radius=2.0)
    assert not list(cache.glob("filtered/*"))


@pytest.mark.parametrize("rank, density", [(1, 0.3), (2, 0.15), (3, 0.08)])  # 6, 18, 26 neighbours
def test_tiles_joined_across_faces_edges_and_corners_are_scipys_components(tmp_path, rank, density):
    """The tiles' labels joined across their boundaries (tiles of uneven sizes, 3 x 3 x 4 of
    them) are the components scipy.ndimage.label finds in the whole mask: one component per
    tile label's voxels, and as many components. Densities below percolation: many components."""
    from scipy import ndimage
    from vgraph.chunked_segmentation import joined_components, labelled_tiles
    mask = np.random.default_rng(3).random((23, 29, 37)) < density
    np.save(tmp_path / "mask.npy", mask.astype(np.uint8))
    convert(tmp_path / "mask.npy", tmp_path / "mask.zarr", brick=8, progress=False)
    structure = ndimage.generate_binary_structure(3, rank)
    tiles, total = labelled_tiles(BrickedVolume.open(tmp_path / "mask.zarr"), lambda block: block != 0,
                                  structure, tmp_path / "tiles.zarr", (8, 10, 12))
    joined = joined_components(tiles, structure, total)[tiles[:]]
    reference, count = ndimage.label(mask, structure=structure)
    assert count > 100 and total > count + 50  # many components cross tiles
    pairs = np.unique(np.stack([reference.reshape(-1), joined.reshape(-1)]), axis=1)
    assert pairs.shape[1] == count + 1 and np.unique(pairs[1]).size == count + 1  # one to one
