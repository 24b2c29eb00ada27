"""The OME-Zarr store (vgraph.bricks.store) and BrickedVolume: what vgraph convert writes reads
back as exactly ArrayPyramid's levels and brick ranges; other tools' OME-Zarr images open with
time and channel selection; bad stores are refused naming the store; VolumeSource opens a .zarr
without reading voxels and refuses the whole array over its memory budget."""

import json

import numpy as np
import pytest
import zarr

from vgraph.io.convert import convert
from vgraph.bricks.pyramid import ArrayPyramid, block_ranges
from vgraph.bricks.store import BrickStore
from vgraph.bricks.volume import BrickedVolume, MemoryBudgetError
from vgraph.errors import ProcessorError, VGraphError, VolumeFileError
from vgraph.io import TimeStepError, read_volume
from vgraph.network import Network

BRICK = (8, 8, 8)
SPACING, ORIGIN = (0.5, 1.25, 2.0), (-3.0, 4.0, 10.5)


def odd_volume(dtype) -> np.ndarray:
    """70 x 45 x 33 voxels (x, y, z): every axis odd or not a multiple of the brick."""
    rng = np.random.default_rng(7)
    data = (rng.random((33, 45, 70)) * 3000).astype(dtype)
    if data.dtype.kind == "f":
        data[3, 4, 5] = np.nan
        data[24:, :, :8] = np.nan  # whole bricks without a finite voxel
        data[0, 0, 1] = np.inf
    return data


def write_mhd(folder, data: np.ndarray, name="volume"):
    """A MetaImage with raw data (streamed by convert) carrying spacing and origin."""
    element = {"uint16": "MET_USHORT", "float32": "MET_FLOAT", "uint8": "MET_UCHAR"}[data.dtype.name]
    (folder / f"{name}.raw").write_bytes(np.ascontiguousarray(data).tobytes())
    header = folder / f"{name}.mhd"
    header.write_text(f"NDims = 3\nDimSize = {data.shape[2]} {data.shape[1]} {data.shape[0]}\n"
                      f"ElementSpacing = {' '.join(map(str, SPACING))}\n"
                      f"Offset = {' '.join(map(str, ORIGIN))}\nElementType = {element}\n"
                      f"ElementDataFile = {name}.raw\n")
    return header


def assert_same_pyramid(store, reference) -> None:
    assert store.brick == reference.brick
    assert store.levels == reference.levels
    for k, level in enumerate(reference.levels):
        np.testing.assert_array_equal(store.read(k, (0, 0, 0), level.shape),
                                      reference.read(k, (0, 0, 0), level.shape))
        for stored, expected in zip(store.brick_ranges(k), reference.brick_ranges(k)):
            np.testing.assert_array_equal(stored, expected)


@pytest.mark.parametrize("dtype", ["uint16", "float32"])
def test_a_converted_volume_reads_back_as_array_pyramid_level_by_level(tmp_path, dtype):
    data = odd_volume(dtype)
    report = convert(write_mhd(tmp_path, data), tmp_path / "v.zarr", brick=BRICK, progress=False)
    assert report.how.startswith("streamed")
    store = BrickStore(tmp_path / "v.zarr")
    reference = ArrayPyramid(data, SPACING, ORIGIN, brick=BRICK)
    assert len(store.levels) == len(reference.levels) == 5
    assert_same_pyramid(store, reference)
    assert store.value_range == reference.value_range
    assert store.dtype == np.dtype(dtype)
    if dtype == "float32":
        assert np.isnan(store.brick_ranges(0)[0]).any()  # empty bricks are known unread
        assert store.nonfinite == 1 + 1 + 9 * 45 * 8


def test_read_is_clamped_to_the_level(tmp_path):
    data = odd_volume("uint16")
    convert(write_mhd(tmp_path, data), tmp_path / "v.zarr", brick=BRICK, progress=False)
    store = BrickStore(tmp_path / "v.zarr")
    np.testing.assert_array_equal(store.read(0, (-4, 40, 60), (5, 99, 999)), data[0:5, 40:, 60:])
    assert store.read(1, (30, 0, 0), (40, 5, 5)).shape == (0, 5, 5)


def test_the_bonsai_at_small_bricks_equals_array_pyramid(tmp_path, data_dir):
    path = data_dir / "ct_bonsai" / "bonsai.nii.gz"
    report = convert(path, tmp_path / "bonsai.zarr", brick=(32, 32, 32), progress=False)
    assert report.how.startswith("read whole") and [s for s in report.shapes] == \
        [(256, 256, 256), (128, 128, 128), (64, 64, 64), (32, 32, 32)]
    volume = read_volume(path)
    assert_same_pyramid(BrickStore(tmp_path / "bonsai.zarr"),
                        ArrayPyramid.from_volume(volume, brick=(32, 32, 32)))


# --- OME-Zarr written by other tools ----------------------------------------------------------------
def foreign_store(path, data5d: np.ndarray, zarr_format=3):
    """An image as another tool writes it: axes t, c, z, y, x with units, two levels (the second
    by striding, as some tools do), chunks that are not vgraph's."""
    group = zarr.open_group(str(path), mode="w", zarr_format=zarr_format)
    levels = [data5d, data5d[:, :, ::2, ::2, ::2]]
    for k, level in enumerate(levels):
        group.create_array(str(k), shape=level.shape, chunks=(1, 1, 4, 5, 6), dtype=level.dtype)[...] = level
    axes = [{"name": "t", "type": "time", "unit": "second"}, {"name": "c", "type": "channel"}] + \
        [{"name": n, "type": "space", "unit": "micrometer"} for n in "zyx"]
    datasets = [{"path": str(k), "coordinateTransformations": [
        {"type": "scale", "scale": [1.0, 1.0, 2.0 * 2**k, 0.5 * 2**k, 0.25 * 2**k]},
        {"type": "translation", "translation": [0.0, 0.0, 10.0, 20.0, 30.0]}]} for k in range(2)]
    image = {"axes": axes, "datasets": datasets}
    if zarr_format == 3:
        group.attrs["ome"] = {"version": "0.5", "multiscales": [image]}
    else:
        group.attrs["multiscales"] = [{"version": "0.4", **image}]
    return path


@pytest.mark.parametrize("zarr_format", [3, 2])
def test_another_tools_ome_zarr_opens_with_time_and_channel_selection(tmp_path, zarr_format):
    data = np.random.default_rng(3).integers(0, 1000, (2, 3, 9, 10, 11)).astype("int16")
    path = foreign_store(tmp_path / "other.zarr", data, zarr_format)
    store = BrickStore(path, time=1, channel=2)
    assert (store.time_steps, store.channels, store.unit) == (2, 3, "micrometer")
    assert store.brick == (18, 20, 16)  # chunks of 6 x 5 x 4 grown to whole chunks of at least 16
    assert store.levels[0].spacing == (0.25, 0.5, 2.0) and store.levels[0].origin == (30.0, 20.0, 10.0)
    assert store.levels[1].shape == (5, 5, 6) and store.levels[1].spacing == (0.5, 1.0, 4.0)
    np.testing.assert_array_equal(store.read(0, (0, 0, 0), (9, 10, 11)), data[1, 2])
    for got, expected in zip(store.brick_ranges(0), block_ranges(data[1, 2], store.brick)):
        np.testing.assert_array_equal(got, expected)
    # no vgraph attributes: the range of the finest level small enough to read whole (level 0)
    assert store.value_range == (float(data[1, 2].min()), float(data[1, 2].max()))
    volume = BrickedVolume(store)
    assert volume.dims == (11, 10, 9) and volume.time_steps == 2
    np.testing.assert_array_equal(volume.data, data[1, 2])


def test_time_and_channel_out_of_range_name_the_store(tmp_path):
    path = foreign_store(tmp_path / "other.zarr", np.zeros((2, 3, 4, 4, 4), "uint8"))
    with pytest.raises(TimeStepError, match="other.zarr.*time step 2 is out of range"):
        BrickStore(path, time=2)
    with pytest.raises(VolumeFileError, match=r"other.zarr \[channel\].*3 channel"):
        BrickStore(path, channel=3)


# --- refused stores ----------------------------------------------------------------------------------
def test_a_missing_store_is_named(tmp_path):
    with pytest.raises(VolumeFileError, match="nothing.zarr: store does not exist"):
        BrickStore(tmp_path / "nothing.zarr")


def test_a_folder_that_is_not_zarr_is_refused(tmp_path):
    (tmp_path / "plain.zarr").mkdir()
    with pytest.raises(VolumeFileError, match=r"plain.zarr \[zarr.json\]: not a zarr group"):
        BrickStore(tmp_path / "plain.zarr")


def test_a_zarr_group_without_multiscales_is_not_an_ome_zarr(tmp_path):
    group = zarr.open_group(str(tmp_path / "bare.zarr"), mode="w")
    group.create_array("0", shape=(4, 4, 4), dtype="uint8")
    with pytest.raises(VolumeFileError, match=r"bare.zarr \[multiscales\]: not an OME-Zarr image"):
        BrickStore(tmp_path / "bare.zarr")


def test_an_image_with_one_spatial_axis_is_refused_naming_its_axes(tmp_path):
    """(A 2D image opens as one slice: tests/test_foreign_ome_zarr.py.)"""
    group = zarr.open_group(str(tmp_path / "line.zarr"), mode="w")
    group.create_array("0", shape=(3, 5), dtype="uint8")
    group.attrs["ome"] = {"version": "0.5", "multiscales": [{
        "axes": [{"name": "c", "type": "channel"}, {"name": "x", "type": "space"}],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1]}]}]}]}
    with pytest.raises(VolumeFileError, match=r"line.zarr \[multiscales.axes\]: an image with 1 spatial "
                                              r"axes \(x\): vgraph reads images with two"):
        BrickStore(tmp_path / "line.zarr")


def test_our_store_layout_is_ngff_0_5(tmp_path):
    convert(write_mhd(tmp_path, odd_volume("uint16")), tmp_path / "v.zarr", brick=BRICK, progress=False)
    attributes = json.loads((tmp_path / "v.zarr" / "zarr.json").read_text())["attributes"]
    image = attributes["ome"]["multiscales"][0]
    assert attributes["ome"]["version"] == "0.5"
    assert [a["name"] for a in image["axes"]] == ["z", "y", "x"]
    assert image["datasets"][1]["coordinateTransformations"] == [
        {"type": "scale", "scale": [4.0, 2.5, 1.0]},
        {"type": "translation", "translation": [11.5, 4.625, -2.75]}]
    assert attributes["vgraph"]["brick"] == list(BRICK)
    assert zarr.open_array(str(tmp_path / "v.zarr" / "vgraph" / "min" / "0")).shape == (5, 6, 9)


# --- BrickedVolume through VolumeSource ----------------------------------------------------------------
@pytest.fixture
def store_path(tmp_path):
    """A store of 1.2 MiB at full resolution (VolumeSource's smallest budget is 1 MiB)."""
    data = np.tile(np.arange(128, dtype=np.uint16), (40, 128, 1)) * 3
    convert(write_mhd(tmp_path, data), tmp_path / "s.zarr", brick=(16, 16, 16), progress=False)
    return tmp_path / "s.zarr", data


def source_output(path, **properties):
    network = Network()
    network.add("VolumeSource", id="src", path=str(path), **properties)
    network.update("src.volume")
    return network.output("src.volume")


def test_volume_source_opens_a_store_without_reading_voxels(store_path, monkeypatch):
    path, data = store_path
    monkeypatch.setattr(BrickStore, "read", lambda *a: pytest.fail("a voxel was read"))
    volume = source_output(path)
    assert isinstance(volume, BrickedVolume) and volume.bricks is not None
    assert volume.dims == (128, 128, 40) and volume.spacing == SPACING and volume.origin == ORIGIN
    assert volume.value_range == (0.0, 381.0) and volume.nonfinite_count == 0
    overridden = source_output(path, spacing=[1, 1, 1], value_range=[0, 1000])
    assert overridden.bricks.levels[1].spacing == (2.0, 2.0, 2.0)
    assert overridden.bricks.levels[1].origin == (ORIGIN[0] + 0.5, ORIGIN[1] + 0.5, ORIGIN[2] + 0.5)
    assert overridden.value_range == (0.0, 1000.0)


def test_a_plain_volume_has_no_bricks(store_path):
    assert read_volume(store_path[0].parent / "volume.mhd").bricks is None


def test_data_within_the_budget_loads_and_statistics_match_numpy(store_path):
    path, data = store_path
    volume = source_output(path, memory_budget=2)
    np.testing.assert_array_equal(volume.percentiles([0, 25, 50, 99]), np.percentile(data, [0, 25, 50, 99]))
    np.testing.assert_array_equal(volume.data, data)


def test_data_over_the_budget_is_refused_naming_size_budget_and_remedies(store_path):
    path, _ = store_path
    volume = source_output(path, memory_budget=1)
    with pytest.raises(MemoryBudgetError, match=r"s.zarr: the whole array \(128 x 128 x 40 voxels of "
                                                r"uint16, 1.2 MiB at full resolution\) exceeds the "
                                                r"memory budget of 1 MiB.*BrickedRayCaster"):
        volume.data
    network = Network()
    network.add("VolumeSource", id="src", path=str(path), memory_budget=1)
    network.add("CubicSplineProcessor", id="spline")
    network.connect("src.volume", "spline.volume")
    with pytest.raises(ProcessorError, match="spline.*memory budget of 1 MiB"):
        network.update("spline.volume")


def test_a_bricked_volume_budget_must_be_positive(store_path):
    with pytest.raises(Exception, match="memory_budget_mb must be a positive number"):
        BrickedVolume(BrickStore(store_path[0]), memory_budget_mb=0)


def test_volume_source_accepts_the_stores_zarr_json_and_its_time_axis(store_path, tmp_path):
    volume = source_output(store_path[0] / "zarr.json")  # what a file dialog can pick
    assert isinstance(volume, BrickedVolume) and volume.source == str(store_path[0])
    data = np.arange(2 * 1 * 4 * 4 * 4, dtype=np.uint8).reshape(2, 1, 4, 4, 4)
    path = foreign_store(tmp_path / "series.zarr", data)
    second = source_output(path, time_step=1)
    assert second.time_steps == 2 and second.value_range == (64.0, 127.0)  # level 0 of time point 1
    with pytest.raises(VGraphError, match=r"src.time_step: time step 2 is out of range: .*series.zarr "
                                          r"holds 2 time points"):
        source_output(path, time_step=2)


def test_vgraph_run_renders_a_store_within_and_over_its_budget(store_path, tmp_path, monkeypatch):
    """Within the budget the RayCaster uploads the whole array; over it the RayCaster draws the
    store brick by brick (processors/raycaster.py), never loading the array: the same picture."""
    import PIL.Image
    from vgraph.cli import main
    assert main(["run", str(store_path[0]), "-o", str(tmp_path / "fits.png"), "--size", "32x32"]) == 0
    monkeypatch.setattr(BrickedVolume, "_load", lambda self: pytest.fail("the whole array was loaded"))
    assert main(["run", str(store_path[0]), "-o", str(tmp_path / "over.png"), "--size", "32x32",
                 "--set", "source.memory_budget=1"]) == 0
    fits, over = (np.asarray(PIL.Image.open(tmp_path / name), dtype=int) for name in ("fits.png", "over.png"))
    assert fits.max() > 0 and np.abs(fits - over).max() <= 3
