"""VolumeInfo and Histogram (issue 35) against numpy: the grid against the file's header and a
hand-made affine, the values and percentiles against np.percentile / np.nanpercentile of the
voxels read independently (np.fromfile of the raw file), the histogram image column by column
against np.histogram, the transfer function's curve pixel by pixel; a store is described without
being read whole."""

import json
from fractions import Fraction

import numpy as np
import pytest

import vgraph
from vgraph import Network
from vgraph.testing import GivenVolume
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

PERCENTS = (1.0, 25.0, 50.0, 75.0, 99.0)


@pytest.fixture
def mri(data_dir):
    """The tiny MRI head as VolumeSource reads it, and its voxels read with numpy from the raw file
    the header names (DimSize 48 62 42, MET_UCHAR, ElementSpacing 4)."""
    header = data_dir / "mri_head_tiny" / "HeadMRVolume.mhd"
    voxels = np.fromfile(header.with_suffix(".raw"), np.uint8).reshape(42, 62, 48)
    return header, voxels


def info_network(volume=None, path=None, **values):
    network = Network()
    if path is not None:
        network.add("VolumeSource", id="source", path=str(path))
    else:
        network.add(GivenVolume(id="source", volume=volume))
    network.add("VolumeInfo", id="info", **values)
    network.connect("source.volume", "info.volume")
    return network


def info_of(network):
    network.update("info.info")
    return network.output("info.info")


def test_volume_info_of_the_mri_head_equals_numpy_on_its_raw_voxels(mri):
    from vgraph.live.evaluator import processor_status
    header, voxels = mri
    network = info_network(path=header)
    info = info_of(network)
    assert info.dims == (48, 62, 42) and info.spacing == (4.0, 4.0, 4.0) and info.dtype == "uint8"
    np.testing.assert_array_equal(info.affine, np.diag([4.0, 4.0, 4.0, 1.0]))
    assert (info.minimum, info.maximum) == (float(voxels.min()), float(voxels.max()))
    # integer data over at most 65536 values: np.percentile's linear method, exactly
    assert list(info.percentiles.values()) == list(np.percentile(voxels, PERCENTS))
    assert info.time_steps == 1 and not info.from_summary
    # what the GUI's inspector shows under the node (the render side's status of the processor)
    shown = processor_status(network, network.processors["info"]).data
    assert shown.splitlines() == info.lines()
    assert shown.splitlines()[0] == "48 \u00d7 62 \u00d7 42 uint8 (124,992 voxels)"
    assert f"percentiles 1%: {np.percentile(voxels, 1):g}, 25%: {np.percentile(voxels, 25):g}" in shown


def test_volume_info_of_an_oriented_float_volume_with_nans_and_time_points():
    rng = np.random.default_rng(35)
    data = rng.normal(100.0, 30.0, (9, 11, 13)).astype(np.float32)
    data[0, 0, :4] = np.nan
    direction = ((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    volume = Volume(data, spacing=(0.5, 2.0, 1.25), origin=(-3.0, 4.0, 10.0), direction=direction, time_steps=3)
    info = info_of(info_network(volume, percentiles=(0.0, 10.0, 50.0, 90.0, 100.0)))
    affine = np.eye(4)
    affine[:3, :3] = np.array(direction) @ np.diag([0.5, 2.0, 1.25])  # column c: index axis c in the world
    affine[:3, 3] = (-3.0, 4.0, 10.0)
    np.testing.assert_allclose(info.affine, affine, atol=1e-12)
    assert info.dims == (13, 11, 9) and info.nonfinite_count == 4 and info.time_steps == 3
    assert (info.minimum, info.maximum) == (float(np.nanmin(data)), float(np.nanmax(data)))
    # float data: within (max - min) / 65536 of np.nanpercentile (Volume.percentiles' stated bound)
    reference = np.nanpercentile(data.astype(np.float64), (0.0, 10.0, 50.0, 90.0, 100.0))
    np.testing.assert_allclose(list(info.percentiles.values()), reference,
                               atol=(np.nanmax(data) - np.nanmin(data)) / 65536)
    lines = info.lines()
    assert lines[2] == "affine rows 0, -2, 0, -3; 0.5, 0, 0, 4; 0, 0, 1.25, 10"
    assert lines[3].startswith("values ") and lines[3].endswith(", 4 not finite")
    assert lines[-1] == "one of 3 time points"
    assert json.loads(json.dumps(info.as_dict()))["percentiles"]["50"] == info.percentiles[50.0]


def test_a_volume_without_finite_values_has_no_percentiles():
    info = info_of(info_network(Volume(np.full((3, 4, 5), np.nan, np.float32))))
    assert info.minimum is None and info.nonfinite_count == 60 and info.percentiles == {}
    assert "no finite values" in info.lines() and not any(line.startswith("percentiles") for line in info.lines())


def test_volume_info_of_a_store_over_its_memory_budget_reads_it_from_its_summary(tmp_path):
    from vgraph.bricks.volume import BrickedVolume
    from vgraph.io.convert import convert
    data = (np.arange(40 * 36 * 30, dtype=np.uint16).reshape(30, 36, 40) % 1000)
    np.save(tmp_path / "ramp.npy", data)
    convert(tmp_path / "ramp.npy", tmp_path / "ramp.zarr", brick=16, progress=False)
    store = BrickedVolume.open(tmp_path / "ramp.zarr", memory_budget_mb=0.01)  # the array is 0.08 MiB
    info = info_of(info_network(store))
    assert store._data is None  # not read whole
    assert info.dims == (40, 36, 30) and info.from_summary and info.dtype == "uint16"
    assert (info.minimum, info.maximum) == (0.0, 999.0)
    # the summary level is level 0 here (under SUMMARY_VOXELS): the percentiles are exact
    assert list(info.percentiles.values()) == list(np.percentile(data, PERCENTS))
    assert info.lines()[3].endswith("(of a summary level)")


def test_volume_info_refuses_b_spline_coefficients_by_name():
    volume = Volume(np.zeros((4, 4, 4), np.float32), is_spline_coefficients=True)
    with pytest.raises(vgraph.VGraphError, match="info needs voxel samples but received B-spline coefficients"):
        info_of(info_network(volume))


# --- Histogram ------------------------------------------------------------------------------------
def histogram_image(volume, size, **values):
    network = Network()
    network.add(GivenVolume(id="source", volume=volume))
    network.add("Histogram", id="histogram", **values)
    network.connect("source.volume", "histogram.volume")
    return network.evaluate("histogram.image", size=size), network.processors["histogram"]


def normalised(voxels, low, high):
    finite = voxels[np.isfinite(voxels)].astype(np.float64)
    return (finite - low) / (high - low)


def reference_bars(voxels, bins, width, height, log, value_range):
    """Bar height of each column: the count of the bin under the column's centre (np.histogram of the
    normalised intensities (v - low) / (high - low) over [0, 1]: an integer value on a bin's edge
    falls as that division rounds), or log(1 + count), over the tallest, times the height, rounded."""
    low, high = value_range
    counts = np.histogram(normalised(voxels, low, high), bins=bins, range=(0.0, 1.0))[0].astype(np.float64)
    values = np.log1p(counts) if log else counts
    column_bin = [min(bins - 1, int(Fraction(2 * x + 1, 2 * width) * bins)) for x in range(width)]  # exact
    return np.round(values[column_bin] / values.max() * height).astype(int)


@pytest.mark.parametrize("bins, log", [(64, False), (64, True), (300, False), (7, True)])
def test_histogram_bars_equal_numpy_histogram_of_the_mri_head(mri, bins, log):
    header, voxels = mri
    width, height = 150, 91
    volume = vgraph.io.read_volume(header)
    bar, background = (0.2, 0.3, 0.6, 1.0), (1.0, 1.0, 1.0, 1.0)
    image, processor = histogram_image(volume, (width, height), bins=bins, log=log, show_transfer_function=False,
                                       bar_color=bar, background=background)
    assert image.shape == (height, width, 4)
    is_bar = np.all(image == np.array(bar, np.float32), axis=-1)
    assert np.all(is_bar | np.all(image == 1.0, axis=-1))  # nothing but bars and background
    heights = is_bar.sum(axis=0)
    np.testing.assert_array_equal(heights, reference_bars(voxels, bins, width, height, log, (0, 255)))
    # bars stand on the bottom row: a column of n bar pixels has them in its n lowest rows
    assert all(is_bar[height - n:, x].all() for x, n in enumerate(heights))
    np.testing.assert_array_equal(processor.counts,
                                  np.histogram(normalised(voxels, 0, 255), bins=bins, range=(0.0, 1.0))[0])


def test_the_transfer_function_is_drawn_over_the_histogram_in_its_colours():
    rng = np.random.default_rng(3)
    voxels = rng.normal(0.0, 200.0, (20, 24, 28)).astype(np.float32)
    volume = Volume(voxels)
    low, high = volume.value_range
    tf = TransferFunction(space="data", points=[(-200.0, 1.0, 0.0, 0.0, 0.1), (0.0, 0.0, 1.0, 0.0, 0.9),
                                                (300.0, 0.0, 0.0, 1.0, 0.4)])
    width, height = 120, 80
    image, _ = histogram_image(volume, (width, height), transfer_function=tf, bins=50)
    # the reference: the TF in data units at each column's centre value
    centres = low + (np.arange(width) + 0.5) / width * (high - low)
    points = np.array(tf.points)
    opacity = np.interp(centres, points[:, 0], points[:, 4])
    colour = np.stack([np.interp(centres, points[:, 0], points[:, c]) for c in (1, 2, 3)], axis=-1)
    rows = np.round(opacity * (height - 1)).astype(int)
    for x in range(width):
        np.testing.assert_allclose(image[height - 1 - rows[x], x], [*colour[x], 1.0], atol=1e-6)
    # the curve spans the TF: 0.1 below -200, nearly 0.9 at the peak near 0
    assert rows.min() == round(0.1 * (height - 1)) and rows.max() >= round(0.85 * (height - 1))


@pytest.mark.parametrize("processor_type, name, value, reason", [
    ("Histogram", "bins", 1, "greater than or equal to 2"),
    ("Histogram", "bins", 5000, "less than or equal to 4096"),
    ("Histogram", "transfer_function", "no-such-preset", "no-such-preset"),
    ("VolumeInfo", "percentiles", (1.0, 50.0, 101.0, 2.0, 3.0), "less than or equal to 100"),
    ("VolumeInfo", "percentiles", (1.0, 50.0), "2: Field required"),
])
def test_bad_values_are_refused_naming_processor_and_property(processor_type, name, value, reason):
    network = Network()
    network.add(processor_type, id="stats")
    with pytest.raises(vgraph.PropertyError, match=rf"^stats\.{name}: .*{reason}"):
        network.set(f"stats.{name}", value)


# --- from the command line ------------------------------------------------------------------------
def test_vgraph_run_writes_volume_info_as_json_and_refuses_it_as_a_picture(mri, tmp_path, capsys):
    from vgraph.cli import main
    header, voxels = mri
    network = info_network(path=header)
    network.save(tmp_path / "info.json")
    assert main(["run", str(tmp_path / "info.json"), "--port", "info.info", "--data", str(tmp_path / "out.json")]) == 0
    written = json.loads((tmp_path / "out.json").read_text())
    assert written["dims"] == [48, 62, 42] and written["dtype"] == "uint8"
    assert written["percentiles"] == {f"{p:g}": float(np.percentile(voxels, p)) for p in PERCENTS}
    capsys.readouterr()
    assert main(["run", str(tmp_path / "info.json"), "--port", "info.info", "-o", str(tmp_path / "info.png")]) == 2
    assert "info.info carries volume statistics; volume statistics are written as JSON: use --data OUT.json" \
        in capsys.readouterr().err
    assert main(["run", str(tmp_path / "info.json"), "--port", "source.volume", "--data", str(tmp_path / "v.json")]) == 2
    assert ".json holds volume statistics only" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["info.json", "out.json"]  # nothing else written


def test_an_image_into_the_volume_port_is_refused_by_port_and_type():
    network = Network()
    network.add("Background", id="back")
    network.add("VolumeInfo", id="info")
    with pytest.raises(vgraph.PortError, match=r"back\.image carries Image but info\.volume takes Volume"):
        network.connect("back.image", "info.volume")


def test_histogram_labels_write_the_value_range_in_the_bottom_corners(mri):
    import PIL.Image
    import PIL.ImageDraw
    import PIL.ImageFont
    header, _ = mri
    volume = vgraph.io.read_volume(header)
    plain, _ = histogram_image(volume, (200, 100), bins=32)
    labelled, _ = histogram_image(volume, (200, 100), bins=32, labels=True, label_color=(1.0, 0.0, 0.0, 1.0))
    # the reference: "0" and "255" in Pillow's default font, 10 pixels (6 % of 100, at least 10), 2 from the corners
    mask = PIL.Image.new("L", (200, 100))
    draw = PIL.ImageDraw.Draw(mask)
    font = PIL.ImageFont.load_default(size=10)
    draw.text((2, 98), "0", fill=255, font=font, anchor="ld")
    draw.text((198, 98), "255", fill=255, font=font, anchor="rd")
    coverage = (np.asarray(mask) / 255.0)[..., None]
    expected = coverage * np.array([1.0, 0.0, 0.0, 1.0]) + (1 - coverage) * plain
    np.testing.assert_allclose(labelled, expected, atol=1e-6)
    assert (coverage[:, :100] > 0).any() and (coverage[:, 100:] > 0).any() and (coverage[:80] == 0).all()
