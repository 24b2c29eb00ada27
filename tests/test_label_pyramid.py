"""The coarser levels of a label volume's pyramid (pyramid.halve_labels): the most frequent label
of each 2 x 2 x 2 group, ties to the smallest, never a mean that is no label; written so by
vgraph convert (a label volume read whole or streamed), by the chunked label filters, and by
ArrayPyramid; an intensity store's levels are still means, bit for bit."""

import json

import nibabel as nib
import numpy as np
import pytest

from vgraph.bricks.pyramid import ArrayPyramid, halve, halve_labels
from vgraph.bricks.store import BrickStore
from vgraph.bricks.volume import BrickedVolume
from vgraph.io.convert import convert
from vgraph.registry import registry
from vgraph.volume import Volume

# labels far apart: a mean of two of them (20 of 10 and 30) is no label of the volume
LABELS = np.array([0, 10, 30, 70], dtype=np.uint16)


def mode_reference(data: np.ndarray) -> np.ndarray:
    """The mode rule voxel by voxel (np.unique: ascending labels, so argmax takes the smallest of
    the most frequent), an odd axis's last group holding the voxels it has."""
    out = np.empty(tuple((n + 1) // 2 for n in data.shape), dtype=data.dtype)
    for k, j, i in np.ndindex(*out.shape):
        values, counts = np.unique(data[2 * k:2 * k + 2, 2 * j:2 * j + 2, 2 * i:2 * i + 2], return_counts=True)
        out[k, j, i] = values[np.argmax(counts)]
    return out


def random_labels(shape, seed=3) -> np.ndarray:
    return LABELS[np.random.default_rng(seed).integers(0, len(LABELS), shape)]


def levels_of(path):
    store = BrickStore(path)
    return [store.read(k, (0, 0, 0), level.shape) for k, level in enumerate(store.levels)]


def multiscale_type(path) -> str:
    return json.loads((path / "zarr.json").read_text())["attributes"]["ome"]["multiscales"][0]["type"]


def test_halve_labels_takes_each_groups_most_frequent_label_ties_to_the_smallest():
    """A hand-made 4^3 volume: each of its eight 2^3 groups and the label it halves to."""
    data = np.zeros((4, 4, 4), np.uint16)
    groups = {  # (z, y, x) group -> its 8 voxels (the expected label first in each comment)
        (0, 0, 0): [5] * 8,                      # 5: all alike
        (0, 0, 1): [1, 1, 1, 3, 3, 3, 3, 3],     # 3: five of eight
        (0, 1, 0): [9, 9, 2, 2, 7, 7, 7, 0],     # 7: three against two, two, one
        (0, 1, 1): [4, 4, 4, 4, 8, 8, 8, 8],     # 4: a tie of four, the smaller wins
        (1, 0, 0): [6, 6, 1, 1, 2, 2, 3, 3],     # 1: a four-way tie
        (1, 0, 1): [0, 0, 0, 1, 2, 3, 4, 5],     # 0: background is a label too
        (1, 1, 0): [1, 2, 3, 4, 5, 6, 7, 8],     # 1: all different
        (1, 1, 1): [10, 30, 30, 10, 30, 10, 70, 70],  # 10: a tie of three; the mean, 32.5, is no label
    }
    for (k, j, i), voxels in groups.items():
        data[2 * k:2 * k + 2, 2 * j:2 * j + 2, 2 * i:2 * i + 2] = np.reshape(voxels, (2, 2, 2))
    expected = np.array([[[5, 3], [7, 4]], [[1, 0], [1, 10]]], np.uint16)
    result = halve_labels(data)
    assert result.dtype == data.dtype
    np.testing.assert_array_equal(result, expected)
    np.testing.assert_array_equal(mode_reference(data), expected)
    assert not np.array_equal(halve(data), expected)  # the mean differs: the rule matters here


@pytest.mark.parametrize("shape", [(5, 7, 9), (1, 2, 3), (6, 6, 6)])
@pytest.mark.parametrize("dtype", [np.uint8, np.int32, np.float32])
def test_halve_labels_equals_the_mode_rule_voxel_by_voxel(shape, dtype):
    """Odd axes included: the last group's mode is that of the voxels it has."""
    data = random_labels(shape).astype(dtype)
    result = halve_labels(data)
    assert result.dtype == data.dtype
    np.testing.assert_array_equal(result, mode_reference(data))


def test_an_array_pyramid_of_labels_holds_only_its_labels_at_every_level():
    data = random_labels((24, 20, 18))
    pyramid = ArrayPyramid(data, brick=(4, 4, 4), holds_labels=True)
    assert len(pyramid.levels) > 3
    for k in range(1, len(pyramid.levels)):
        coarse = pyramid.read(k, (0, 0, 0), pyramid.levels[k].shape)
        assert set(np.unique(coarse)) <= set(LABELS)
        np.testing.assert_array_equal(coarse, halve_labels(pyramid.read(k - 1, (0, 0, 0), pyramid.levels[k - 1].shape)))
    volume = Volume(data=data, holds_labels=True)
    assert ArrayPyramid.from_volume(volume, brick=(4, 4, 4)).read(1, (0, 0, 0), (12, 10, 9)).tolist() == \
        halve_labels(data).tolist()


def label_nifti(path, data, gzipped):
    image = nib.Nifti1Image(np.ascontiguousarray(data.T), np.eye(4))
    image.header.set_intent("label")
    name = path / ("labels.nii.gz" if gzipped else "labels.nii")
    nib.save(image, name)
    return name


@pytest.mark.parametrize("gzipped", [True, False], ids=["read-whole", "streamed"])
def test_a_converted_label_volume_halves_by_the_mode(tmp_path, gzipped):
    """vgraph convert of a NIfTI label map (intent "label"), read whole (.nii.gz) or slab by slab
    (.nii): every coarser level is halve_labels of the one before, holds only level 0's labels,
    and the store says so (image-label, multiscales type "mode")."""
    data = random_labels((21, 18, 14))
    source = label_nifti(tmp_path, data, gzipped)
    report = convert(source, tmp_path / "labels.zarr", brick=4, progress=False)
    assert report.how.startswith("read whole" if gzipped else "streamed")
    levels = levels_of(tmp_path / "labels.zarr")
    assert len(levels) == 4
    np.testing.assert_array_equal(levels[0], data)
    for finer, coarser in zip(levels, levels[1:]):
        np.testing.assert_array_equal(coarser, halve_labels(finer))
        assert set(np.unique(coarser)) <= set(np.unique(data))
    assert not set(np.unique(halve(data))) <= set(np.unique(data))  # what the mean would have written
    assert multiscale_type(tmp_path / "labels.zarr") == "mode"
    assert BrickedVolume.open(tmp_path / "labels.zarr").holds_labels


def test_an_intensity_store_keeps_its_mean_pyramid_bit_for_bit(tmp_path):
    """The same voxels as intensities (no label intent): every level the mean, as before."""
    data = random_labels((21, 18, 14)).astype(np.float32) * np.float32(1.37)
    np.save(tmp_path / "values.npy", data)
    convert(tmp_path / "values.npy", tmp_path / "values.zarr", brick=4, progress=False)
    expected = data
    for level in levels_of(tmp_path / "values.zarr"):
        assert level.dtype == expected.dtype and level.tobytes() == expected.tobytes()
        expected = halve(expected)
    assert multiscale_type(tmp_path / "values.zarr") == "mean"


def test_a_chunked_label_filter_writes_a_mode_pyramid(tmp_path, monkeypatch):
    """VolumeThreshold's labels (0 below, 1 inside, 2 above a narrow band) of a noise store, chunk
    by chunk: groups mix 0 and 2, whose mean, 1, they need not hold; each level is the mode."""
    monkeypatch.setenv("VGRAPH_CACHE", str(tmp_path / "cache"))
    noise = np.random.default_rng(5).random((64, 32, 32)).astype(np.float32)
    np.save(tmp_path / "noise.npy", noise)
    convert(tmp_path / "noise.npy", tmp_path / "noise.zarr", brick=4, progress=False)
    store = BrickedVolume.open(tmp_path / "noise.zarr", memory_budget_mb=0.2)
    assert not store.fits_budget
    labels = registry.get("VolumeThreshold")("t", output="labels", lower=0.45, upper=0.55).process(volume=store)
    assert isinstance(labels, BrickedVolume) and labels.holds_labels
    levels = levels_of(labels.bricks.path)
    for finer, coarser in zip(levels, levels[1:]):
        np.testing.assert_array_equal(coarser, halve_labels(finer))
        assert set(np.unique(coarser)) <= set(np.unique(levels[0]))
    assert not np.array_equal(halve(levels[0]), levels[1])  # the mean would have differed
    assert multiscale_type(labels.bricks.path) == "mode"
