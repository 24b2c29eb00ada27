"""The volume filters (VolumeCrop, VolumeResample, VolumeSmooth, VolumeThreshold) against their
reference libraries (scipy.ndimage, scikit-image) on the shared CT head (headsq: 64 x 64 x 93
int16, spacing 3.2 x 3.2 x 1.5 mm, anisotropic), with sizes in world units, world positions kept
and bad values named. Tolerance for mixed (float32) values: 1e-6 of the largest |value| (float32
keeps 6e-8; the filters compute in float64 or float32 and round once)."""

import json

import numpy as np
import pytest
from scipy import ndimage
from skimage.filters import threshold_multiotsu, threshold_otsu

from helpers.headsq import TILT, read_head
from vgraph import Network, ProcessorError, PropertyError, VGraphError, VGraphWarning
from vgraph.io import read_volume
from vgraph.registry import registry
from vgraph.volume import Volume

ORDERS = {"nearest": 0, "linear": 1, "cubic": 3}


@pytest.fixture(scope="module")
def head():
    return read_head()


def run(type_name, volume, **properties):
    return registry.get(type_name)("f", **properties).process(volume=volume)


def assert_close(ours, reference):
    assert ours.shape == reference.shape
    tolerance = 1e-6 * max(1.0, float(np.abs(reference).max()))
    assert np.abs(ours.astype(np.float64) - reference).max() <= tolerance


def voxel_centres(volume):
    """World positions (z, y, x, 3) of every voxel centre."""
    k, j, i = np.indices(volume.data.shape)
    return volume.voxel_to_world(np.stack([i, j, k], axis=-1))


def sampled_at(volume, world, order, mode):
    """scipy.ndimage.map_coordinates of ``volume`` at world points (..., 3)."""
    index = volume.world_to_voxel(world)[..., ::-1]
    data = volume.data if order == 0 else volume.data.astype(np.float64)
    return ndimage.map_coordinates(data, np.moveaxis(index, -1, 0), order=order, mode=mode)


# --- VolumeCrop ---------------------------------------------------------------------------------
@pytest.mark.parametrize("direction", [None, TILT])
def test_crop_in_world_units_keeps_the_voxels_at_their_world_positions(head, direction):
    volume = head if direction is None else head.with_overrides(direction=direction)
    low, high = volume.world_box()
    box = (*(low + (high - low) * 0.2), *(low + (high - low) * 0.7))
    cropped = run("VolumeCrop", volume, crop_box=box)
    centres = voxel_centres(cropped)
    assert np.all(centres >= np.array(box[:3]) - 1e-9) and np.all(centres <= np.array(box[3:]) + 1e-9)
    # every voxel of the input whose centre lies in the box, and it holds the same value
    inside = np.all((voxel_centres(volume) >= box[:3]) & (voxel_centres(volume) <= box[3:]), axis=-1)
    assert inside.sum() == cropped.data.size
    assert np.array_equal(np.sort(volume.data[inside]), np.sort(cropped.data.ravel()))
    assert np.array_equal(sampled_at(volume, centres, 0, "constant"), cropped.data)
    assert cropped.direction == volume.direction and cropped.spacing == volume.spacing
    assert cropped.value_range == volume.value_range and cropped.data.dtype == np.int16


def test_crop_in_voxels_is_numpy_slicing_with_the_origin_moved(head):
    cropped = run("VolumeCrop", head, units="voxels", voxel_box=(5, 10, 20, 40, 50, 200))
    assert np.array_equal(cropped.data, head.data[20:, 10:51, 5:41])  # clipped to the volume
    assert np.allclose(cropped.affine @ [0, 0, 0, 1], head.affine @ [5, 10, 20, 1])
    assert np.allclose(cropped.affine[:3, :3], head.affine[:3, :3])


def test_crop_of_a_store_reads_only_the_box_within_its_budget(head):
    from vgraph.bricks.pyramid import ArrayPyramid
    from vgraph.bricks.volume import BrickedVolume, MemoryBudgetError
    store = BrickedVolume(ArrayPyramid(head.data, spacing=head.spacing, brick=(16, 16, 16)), memory_budget_mb=0.1)
    with pytest.raises(MemoryBudgetError):  # the whole 0.73 MiB array is over the budget ...
        store.data
    cropped = run("VolumeCrop", store, units="voxels", voxel_box=(10, 20, 30, 41, 51, 61))  # ... 64 KiB is not
    assert type(cropped) is Volume and np.array_equal(cropped.data, head.data[30:62, 20:52, 10:42])
    assert np.allclose(cropped.affine @ [0, 0, 0, 1], head.affine @ [10, 20, 30, 1])
    # a box over the budget is copied into a store slab by slab (tests/test_chunked_filters.py),
    # within the budget: here a slab is over it too
    with pytest.raises(MemoryBudgetError, match=r"^VolumeCrop 'f': filtering the store chunk by chunk needs "
                                                r"about .* more than its memory budget of 0.1 MiB"):
        run("VolumeCrop", store, units="voxels", voxel_box=(0, 0, 0, 63, 63, 61))


@pytest.mark.parametrize("properties, name", [
    ({"crop_box": (-100, -100, -100, -50, -50, -50)}, "crop_box"),
    ({"crop_box": (10.0, 10.0, 10.0, 10.5, 10.5, 10.5)}, "crop_box"),  # between voxel centres
    ({"units": "voxels", "voxel_box": (64, 0, 0, 70, 5, 5)}, "voxel_box")])
def test_an_empty_crop_box_is_named(head, properties, name):
    with pytest.raises(PropertyError, match=rf"^f\.{name}: the box .* holds no voxel"):
        run("VolumeCrop", head, **properties)


def test_crop_box_min_above_max_is_named(head):
    with pytest.raises(PropertyError, match=r"f\.voxel_box: each min must be at most its max"):
        run("VolumeCrop", head, units="voxels", voxel_box=(10, 0, 0, 5, 5, 5))
    with pytest.raises(PropertyError, match=r"f\.crop_box: .*each min <= its max"):
        run("VolumeCrop", head, crop_box=(10, 0, 0, 5, 5, 5))


# --- VolumeResample -----------------------------------------------------------------------------
@pytest.mark.parametrize("interpolation", ["linear", "cubic"])
@pytest.mark.parametrize("size", [(32, 48, 50), (70, 40, 120)])
def test_resample_to_a_size_equals_scipy_zoom(head, interpolation, size):
    resampled = run("VolumeResample", head, mode="size", size=size, interpolation=interpolation)
    zoom = np.array(size[::-1]) / np.array(head.data.shape)
    reference = ndimage.zoom(head.data.astype(np.float64), zoom, order=ORDERS[interpolation], grid_mode=True,
                             mode="mirror" if interpolation == "cubic" else "nearest")
    assert resampled.data.dtype == np.float32 and resampled.dims == size
    assert_close(resampled.data, reference)
    # the voxel cells cover the input's: same box corners in world units
    cells = lambda v: (v.voxel_to_world((-0.5,) * 3), v.voxel_to_world(np.array(v.dims) - 0.5))  # noqa: E731
    assert np.allclose(cells(resampled), cells(head))


@pytest.mark.parametrize("interpolation", list(ORDERS))
@pytest.mark.parametrize("direction", [None, TILT])
def test_resample_to_a_spacing_samples_the_input_at_each_voxels_world_position(head, interpolation, direction):
    volume = head if direction is None else head.with_overrides(direction=direction)
    resampled = run("VolumeResample", volume, spacing=(2.5, 1.7, 2.2), interpolation=interpolation)
    assert resampled.spacing == (2.5, 1.7, 2.2) and resampled.dims == (82, 120, 63)  # round(n s / 2.5) ...
    assert resampled.direction == volume.direction
    reference = sampled_at(volume, voxel_centres(resampled), ORDERS[interpolation],
                           "mirror" if interpolation == "cubic" else "nearest")
    if interpolation == "nearest":
        assert resampled.data.dtype == np.int16 and np.array_equal(resampled.data, reference)
    else:
        assert_close(resampled.data, reference)
    centre = lambda v: v.voxel_to_world((np.array(v.dims) - 1) / 2)  # noqa: E731
    assert np.allclose(centre(resampled), centre(volume))


def test_zero_sizes_huge_grids_and_mixing_labels_are_named(head):
    with pytest.raises(PropertyError, match=r"^f\.size: each of x, y, z must be above 0"):
        run("VolumeResample", head, mode="size", size=(0, 10, 10))
    with pytest.raises(PropertyError, match=r"^f\.spacing: each of x, y, z must be above 0"):
        run("VolumeResample", head, spacing=(0.0, 1.0, 1.0))
    with pytest.raises(PropertyError, match=r"^f\.spacing: invalid value"):
        run("VolumeResample", head, spacing=(-1.0, 1.0, 1.0))
    with pytest.raises(PropertyError, match=r"^f\.spacing: the new grid would hold 204800 x 204800 x 139500 voxels"):
        run("VolumeResample", head, spacing=(0.001, 0.001, 0.001))
    labels = head.with_data((head.data > 500).astype(np.uint8), holds_labels=True)
    with pytest.raises(PropertyError, match=r"^f\.filter: median filtering mixes label values"):
        run("VolumeSmooth", labels, filter="median")
    with pytest.raises(PropertyError, match=r"^f\.interpolation: linear interpolation mixes label values"):
        run("VolumeResample", labels, spacing=(2.0, 2.0, 2.0))
    assert run("VolumeResample", labels, spacing=(2.0, 2.0, 2.0), interpolation="nearest").holds_labels


# --- VolumeSmooth -------------------------------------------------------------------------------
def test_gaussian_sigma_in_world_units_equals_scipy_on_anisotropic_spacing(head):
    smoothed = run("VolumeSmooth", head, sigma=(3.2, 6.4, 3.0))  # 1, 2, 2 voxels along x, y, z
    reference = ndimage.gaussian_filter(head.data.astype(np.float64), (2.0, 2.0, 1.0))
    assert smoothed.data.dtype == np.float32 and smoothed.value_range == head.value_range
    assert_close(smoothed.data, reference)
    assert np.array_equal(smoothed.affine, head.affine)


def test_gaussian_spreads_an_impulse_by_sigma_in_every_world_direction():
    impulse = np.zeros((41, 33, 25))
    impulse[20, 16, 12] = 1.0
    volume = Volume(impulse, spacing=(3.0, 2.0, 1.0))
    smoothed = run("VolumeSmooth", volume, sigma=(4.0, 4.0, 4.0)).data
    for index, spacing in zip(np.indices(impulse.shape)[::-1], volume.spacing):
        centre = (smoothed * index).sum() / smoothed.sum()
        spread = np.sqrt((smoothed * (index - centre) ** 2).sum() / smoothed.sum()) * spacing
        assert spread == pytest.approx(4.0, rel=1e-3)


def test_median_size_in_world_units_equals_scipy(head):
    smoothed = run("VolumeSmooth", head, filter="median", size=(6.4, 3.2, 4.5))
    # the odd voxel count nearest size / spacing: x 6.4 / 3.2 = 2 -> 3 (ties up), y 1 -> 1, z 3 -> 3
    reference = ndimage.median_filter(head.data, size=(3, 1, 3))
    assert smoothed.data.dtype == np.int16 and np.array_equal(smoothed.data, reference)


def test_smoothing_replaces_nan_by_the_range_end_with_a_warning():
    data = np.arange(8 * 8 * 8, dtype=np.float32).reshape(8, 8, 8)
    data[4, 4, 4] = np.nan
    with pytest.warns(VGraphWarning, match=r"VolumeSmooth 'f': 1 NaN/Inf voxels replaced"):
        smoothed = run("VolumeSmooth", Volume(data), sigma=(1.0, 1.0, 1.0))
    assert np.isfinite(smoothed.data).all()
    assert_close(smoothed.data, ndimage.gaussian_filter(np.nan_to_num(data.astype(np.float64), nan=0.0), 1.0))


def test_bad_smoothing_sizes_are_named(head):
    with pytest.raises(PropertyError, match=r"^f\.sigma: invalid value \(-1\.0, 1\.0, 1\.0\)"):
        run("VolumeSmooth", head, sigma=(-1.0, 1.0, 1.0))
    with pytest.raises(PropertyError, match=r"^f\.sigma: the kernel reaches 125 voxels along x, more "
                                            r"than the volume's 64"):
        run("VolumeSmooth", head, sigma=(100.0, 1.0, 1.0))
    with pytest.raises(PropertyError, match=r"^f\.size: the kernel reaches 94 voxels along z"):
        run("VolumeSmooth", head, filter="median", size=(1.0, 1.0, 282.0))


# --- VolumeThreshold ----------------------------------------------------------------------------
def test_manual_threshold_to_a_mask_and_to_labels(head):
    lower, upper = 500 / 3926, 1150 / 3926  # skin and bone levels of the VTK example, data units
    mask = run("VolumeThreshold", head, lower=lower, upper=upper)
    assert mask.data.dtype == np.uint8 and mask.holds_labels and mask.value_range == (0.0, 1.0)
    assert np.array_equal(mask.data, (head.data >= 500) & (head.data <= 1150))
    labels = run("VolumeThreshold", head, output="labels", lower=lower, upper=upper)
    assert np.array_equal(labels.data, np.digitize(head.data, [500, 1150.5]))
    assert np.array_equal(labels.affine, head.affine)


def test_otsu_threshold_equals_scikit_image(head):
    values = head.data.astype(np.float64)  # floats: scikit-image bins them in 256 bins over min .. max
    mask = run("VolumeThreshold", head, method="otsu")
    assert np.array_equal(mask.data, head.data >= threshold_otsu(values, nbins=256))
    labels = run("VolumeThreshold", head, method="otsu", output="labels", classes=4)
    assert np.array_equal(labels.data, np.digitize(head.data, threshold_multiotsu(values, classes=4, nbins=256)))
    assert labels.value_range == (0.0, 3.0)


def test_threshold_levels_are_checked(head):
    with pytest.raises(PropertyError, match=r"^f\.lower: lower \(0\.6\) must not be above upper \(0\.4\)"):
        run("VolumeThreshold", head, lower=0.6, upper=0.4)
    with pytest.raises(PropertyError, match=r"^f\.upper: invalid value 1\.5"):
        run("VolumeThreshold", head, upper=1.5)
    flat = Volume(np.full((4, 4, 4), 7.0, dtype=np.float32))
    with pytest.raises(PropertyError, match=r"^f\.method: Otsu's method needs more than one value"):
        run("VolumeThreshold", flat, method="otsu")


# --- in a network -------------------------------------------------------------------------------
def test_filters_chain_in_a_network_and_errors_name_the_processor():
    network = Network()
    network.add("FunctionSelector", id="src", function="sphere", resolution=32)
    network.add("VolumeCrop", id="crop", units="voxels", voxel_box=(4, 4, 4, 27, 27, 27))
    network.add("VolumeSmooth", id="smooth", sigma=(0.05, 0.05, 0.05))
    network.add("VolumeThreshold", id="threshold", lower=0.5)
    network.connect("src.volume", "crop.volume")
    network.connect("crop.volume", "smooth.volume")
    network.connect("smooth.volume", "threshold.volume")
    mask = network.evaluate("threshold.volume")
    assert mask.shape == (24, 24, 24) and 0 < mask.sum() < mask.size
    assert {cls.category for cls in map(registry.get, ["VolumeCrop", "VolumeResample", "VolumeSmooth",
                                                      "VolumeThreshold"])} == {"Volume filters"}
    network.set("smooth.sigma", (50.0, 0.05, 0.05))
    with pytest.raises(ProcessorError, match=r"'smooth' \(VolumeSmooth\): smooth\.sigma: the kernel reaches"):
        network.evaluate("threshold.volume")


def test_coefficients_are_refused_by_name(head):
    coefficients = head.with_data(head.data.astype(np.float32), is_spline_coefficients=True)
    for name in ("VolumeCrop", "VolumeResample", "VolumeSmooth", "VolumeThreshold"):
        with pytest.raises(VGraphError, match=rf"{name} 'f' needs voxel samples"):
            run(name, coefficients)


def test_vgraph_run_crops_and_smooths_a_file_and_names_a_bad_value_in_one_line(head, tmp_path, capsys):
    from helpers.paths import DATA
    from vgraph.cli import main
    network = {"format": "vgraph-network", "version": 3, "processors": [
        {"id": "source", "type": "VolumeSource", "properties": {"path": str(DATA / "ct_head_headsq/quarter.nhdr")}},
        {"id": "crop", "type": "VolumeCrop", "properties": {"units": "voxels", "voxel_box": [8, 0, 10, 55, 63, 80]}},
        {"id": "smooth", "type": "VolumeSmooth", "properties": {"sigma": [3.2, 3.2, 3.0]}}],
        "connections": [{"from": "source.volume", "to": "crop.volume"}, {"from": "crop.volume", "to": "smooth.volume"}],
        "links": []}
    (tmp_path / "smooth.json").write_text(json.dumps(network))
    args = ["run", str(tmp_path / "smooth.json"), "--port", "smooth.volume"]
    assert main([*args, "--data", str(tmp_path / "s.npy"), "--data", str(tmp_path / "s.nii.gz")]) == 0
    reference = ndimage.gaussian_filter(head.data[10:81, :, 8:56].astype(np.float64), (2.0, 1.0, 1.0))
    assert_close(np.load(tmp_path / "s.npy"), reference)
    written = read_volume(tmp_path / "s.nii.gz")  # the grid goes into the file: world positions kept
    assert np.allclose(written.affine @ [0, 0, 0, 1], head.affine @ [8, 0, 10, 1])
    assert np.allclose(written.spacing, head.spacing)
    capsys.readouterr()
    assert main([*args, "--data", str(tmp_path / "bad.npy"), "--set", "smooth.sigma=[-1, 1, 1]"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "vgraph: error: smooth.sigma: invalid value [-1, 1, 1]: 0: Input should be greater than or equal to 0"
    assert not (tmp_path / "bad.npy").exists()
