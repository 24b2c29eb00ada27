"""LineProfile: a line between two world points through the shared CT head (headsq, 64 x 64 x 93
int16, spacing 3.2 x 3.2 x 1.5 mm: anisotropic), as read and turned (a non-identity direction with a
moved origin), equals scipy.ndimage.map_coordinates at the same points (voxel coordinates from the
inverse of the affine, computed here); distances and points along the line; NaN with a warning
outside; bad values named; the table as CSV from the command line; the plot image."""

import csv
import json
import warnings

import numpy as np
import pytest
from scipy import ndimage

from helpers.headsq import read_head, turned
from vgraph import Network, PropertyError, VGraphError, VGraphWarning
from vgraph.cli import main
from vgraph.io import read_volume
from vgraph.registry import registry
from vgraph.table import Table
from vgraph.testing import GivenVolume

ORDERS = {"nearest": 0, "linear": 1, "cubic": 3}
# voxel coordinates (i, j, k) of the ends of a line well inside the head, off every grid plane
INNER_ENDS = ((3.3, 5.7, 10.2), (55.1, 40.4, 80.9))


@pytest.fixture(scope="module", params=["as_read", "turned"])
def head(request):
    volume = read_head()
    return turned(volume) if request.param == "turned" else volume


def world(volume, ijk):
    """World point of voxel coordinates through the affine (not the code under test)."""
    return (volume.affine @ np.append(ijk, 1.0))[:3]


def reference(volume, points, order):
    """map_coordinates at world points (n, 3): scipy's own prefilter for the cubic B-spline."""
    ijk = (np.c_[points, np.ones(len(points))] @ np.linalg.inv(volume.affine).T)[:, :3]
    data = volume.data if order == 0 else volume.data.astype(np.float64)
    return ndimage.map_coordinates(data, ijk[:, ::-1].T, order=order, mode="mirror")


def profile(volume, **properties) -> Table:
    return registry.get("LineProfile")("p", **properties).process(volume=volume)["table"]


@pytest.mark.parametrize("interpolation", list(ORDERS))
def test_the_profile_equals_map_coordinates_on_the_same_line(head, interpolation):
    start, end = (world(head, ijk) for ijk in INNER_ENDS)
    table = profile(head, start=tuple(start), end=tuple(end), samples=173, interpolation=interpolation)
    points = np.stack([table["x"], table["y"], table["z"]], axis=1)
    expected = reference(head, points, ORDERS[interpolation])
    if interpolation == "nearest":
        assert np.array_equal(table["value"], expected)
    else:  # cubic: float32 coefficients (vgraph.numerics.bspline.prefilter) against scipy's float64
        assert np.abs(table["value"] - expected).max() <= 1e-6 * np.abs(expected).max()
    assert np.ptp(table["value"]) > 500  # the line crosses skin and bone: the test can tell


def test_samples_are_evenly_spaced_on_the_line_with_both_ends(head):
    start, end = (world(head, ijk) for ijk in INNER_ENDS)
    table = profile(head, start=tuple(start), end=tuple(end), samples=11)
    length = np.linalg.norm(end - start)
    assert table.names == ["distance", "x", "y", "z", "value"]
    assert [c.unit for c in table.columns] == ["world"] * 4 + [""]
    assert np.allclose(table["distance"], np.linspace(0.0, length, 11), rtol=0, atol=1e-12)
    points = np.stack([table["x"], table["y"], table["z"]], axis=1)
    assert np.allclose(points, start + np.linspace(0, 1, 11)[:, None] * (end - start), rtol=0, atol=1e-9)


def test_a_step_in_world_units_reaches_the_end_only_on_a_whole_step(head):
    start = world(head, INNER_ENDS[0])
    end = world(head, np.add(INNER_ENDS[0], (0.0, 0.0, 20.0 / 1.5)))  # 20 world units along k
    assert np.allclose(profile(head, start=tuple(start), end=tuple(end), spacing_mode="step",
                               step=2.5)["distance"], np.arange(9) * 2.5)
    assert np.allclose(profile(head, start=tuple(start), end=tuple(end), spacing_mode="step",
                               step=3.0)["distance"], np.arange(7) * 3.0)  # 18, not 20


def test_points_outside_the_volume_are_nan_with_a_warning_naming_the_processor(head):
    start, end = world(head, (-10.0, 20.3, 30.2)), world(head, (40.0, 20.3, 30.2))  # 160 world units
    with pytest.warns(VGraphWarning, match=r"^LineProfile 'p': 20 of 101 samples \(distance 0 to 30\.4\) "
                                           r"lie outside the volume's box of voxel centres: their values are NaN"):
        table = profile(head, start=tuple(start), end=tuple(end), samples=101)
    outside = np.isnan(table["value"])
    assert outside.sum() == 20 and outside[:20].all()
    points = np.stack([table["x"], table["y"], table["z"]], axis=1)[~outside]
    assert np.abs(table["value"][~outside] - reference(head, points, 1)).max() < 1e-9
    with pytest.warns(VGraphWarning, match=r"^LineProfile 'p': the whole line lies outside"):
        assert np.isnan(profile(head, start=(1e4, 0.0, 0.0), end=(1e4, 10.0, 0.0))["value"]).all()


def test_cubic_on_spline_coefficients_equals_cubic_on_the_samples(head):
    coefficients = registry.get("CubicSplineProcessor")("s").process(volume=head)
    start, end = (tuple(world(head, ijk)) for ijk in INNER_ENDS)
    on_samples = profile(head, start=start, end=end, interpolation="cubic")["value"]
    assert np.array_equal(profile(coefficients, start=start, end=end, interpolation="cubic")["value"], on_samples)
    with pytest.raises(VGraphError, match=r"^LineProfile 'p': the volume holds B-spline coefficients"):
        profile(coefficients, start=start, end=end, interpolation="linear")


def test_bad_lines_are_refused_by_name(head):
    with pytest.raises(PropertyError, match=r"^p\.end: the line has zero length: end equals start \[1\.0, 2\.0, 3\.0\]"):
        profile(head, start=(1.0, 2.0, 3.0), end=(1.0, 2.0, 3.0))
    with pytest.raises(PropertyError, match=r"^p\.samples: invalid value 1"):
        profile(head, samples=1)
    with pytest.raises(PropertyError, match=r"^p\.start: invalid value"):
        profile(head, start=(float("nan"), 0.0, 0.0))
    with pytest.raises(PropertyError, match=r"^p\.step: must be above 0, got 0\.0"):
        profile(head, spacing_mode="step", step=0.0)
    with pytest.raises(PropertyError, match=r"^p\.step: step 20 is longer than the line \(10 world units\)"):
        profile(head, spacing_mode="step", step=20.0)
    with pytest.raises(PropertyError, match=r"^p\.step: step 1e-09 gives 10000000001 samples"):
        profile(head, spacing_mode="step", step=1e-9)
    labels = head.with_data((head.data > 500).astype(np.uint8), holds_labels=True)
    with pytest.raises(PropertyError, match=r"^p\.interpolation: linear interpolation mixes label values"):
        profile(labels)
    start, end = (tuple(world(head, ijk)) for ijk in INNER_ENDS)
    assert set(np.unique(profile(labels, start=start, end=end, interpolation="nearest")["value"])) == {0.0, 1.0}


def test_the_plot_draws_the_profile_at_the_canvas_size(gl, head):
    network = Network()
    network.add(GivenVolume(id="src", volume=head))
    network.add("LineProfile", id="p", start=tuple(world(head, INNER_ENDS[0])), end=tuple(world(head, INNER_ENDS[1])))
    network.add("Canvas", id="canvas", size=(320, 200))
    network.connect("src.volume", "p.volume")
    network.connect("p.plot", "canvas.image")
    network.evaluate()
    pixels = network.output("p.plot").to_numpy()
    assert pixels.shape == (200, 320, 4) and np.all(pixels[..., 3] == 1.0)
    blue = (pixels[..., 2] > 0.6) & (pixels[..., 0] < 0.3)  # the line's colour on white
    assert blue.sum() > 200
    assert (pixels[..., :3].min(axis=-1) > 0.95).mean() > 0.5  # mostly white paper


def test_vgraph_run_writes_the_table_as_csv(tmp_path, capsys):
    from helpers.paths import DATA
    start, end = (read_volume(DATA / "ct_head_headsq" / "quarter.nhdr").voxel_to_world(ijk) for ijk in INNER_ENDS)
    network = {"format": "vgraph-network", "version": 3, "processors": [
        {"id": "source", "type": "VolumeSource", "properties": {"path": str(DATA / "ct_head_headsq" / "quarter.nhdr")}},
        {"id": "profile", "type": "LineProfile",
         "properties": {"start": list(start), "end": list(end), "samples": 25, "interpolation": "cubic"}}],
        "connections": [{"from": "source.volume", "to": "profile.volume"}], "links": []}
    path = tmp_path / "profile.json"
    path.write_text(json.dumps(network))
    out = tmp_path / "profile.csv"
    assert main(["run", str(path), "--port", "profile.table", "--data", str(out)]) == 0
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["distance [world]", "x [world]", "y [world]", "z [world]", "value"]
    values = np.array(rows[1:], dtype=np.float64)
    assert values.shape == (25, 5)
    as_read = read_volume(DATA / "ct_head_headsq" / "quarter.nhdr")
    assert np.abs(values[:, 4] - reference(as_read, values[:, 1:4], 3)).max() <= 1e-6 * np.abs(values[:, 4]).max()
    capsys.readouterr()
    assert main(["run", str(path), "--port", "profile.table", "-o", str(tmp_path / "t.png")]) == 2
    assert "profile.table carries a table; a table is written as CSV: use --data OUT.csv" in capsys.readouterr().err


def test_the_table_type_round_trips_through_csv_and_refuses_ragged_columns(tmp_path):
    from vgraph.table import Column
    values = np.array([0.1, 1 / 3, np.nan, 2e-300])
    table = Table((Column("label", np.arange(1, 5)), Column("length", values, "world")), source="test")
    table.to_csv(tmp_path / "t.csv")
    rows = list(csv.reader((tmp_path / "t.csv").open()))
    assert rows[0] == ["label", "length [world]"] and [r[0] for r in rows[1:]] == ["1", "2", "3", "4"]
    back = np.array([float(r[1]) for r in rows[1:]])
    assert np.array_equal(back, values, equal_nan=True)  # every digit kept
    array = table.to_numpy()
    assert array.dtype.names == ("label", "length") and array["label"].tolist() == [1, 2, 3, 4]
    assert table.lines(max_rows=2)[-1] == "... 2 more rows" and table.lines()[2].split() == ["2", "0.333333"]
    with pytest.raises(VGraphError, match=r"^table from test: columns of different lengths"):
        Table((Column("a", np.arange(3)), Column("b", np.arange(4))), source="test")
    with pytest.raises(VGraphError, match=r"^table column 'Bad name': names must be snake_case"):
        Column("Bad name", np.arange(3))
    with pytest.raises(VGraphError, match=r"^table from test has no column 'c' \(its columns: label, length\)"):
        table["c"]


def test_nan_voxels_are_named_before_the_prefilter_and_stay_nan_in_nearest(head):
    data = head.data.astype(np.float32)
    data[40, 30, 20] = np.nan
    volume = head.with_data(data)
    start, end = (tuple(world(head, ijk)) for ijk in ((20.0, 30.0, 30.0), (20.0, 30.0, 50.0)))  # through the NaN
    with pytest.warns(VGraphWarning, match=r"^LineProfile 'p': 1 NaN/Inf voxels replaced by the value range's ends"):
        cubic = profile(volume, start=start, end=end, samples=21, interpolation="cubic")["value"]
    assert np.isfinite(cubic).all()
    nearest = profile(volume, start=start, end=end, samples=21, interpolation="nearest")["value"]
    assert np.isnan(nearest).sum() == 1 and np.isnan(nearest[10])  # k = 40 is the middle sample


def ruler_network(head, ends):
    """The head through a LineProfile whose markups are linked to a Markups processor's."""
    from vgraph.markups import Markup, Markups
    network = Network()
    network.add(GivenVolume(id="src", volume=head))
    network.add("Markups", id="mk")
    network.add("LineProfile", id="p")
    network.connect("src.volume", "p.volume")
    network.set("mk.markups", Markups(markups=(Markup(name="width", kind="ruler", points=ends),)))
    network.link("mk.markups", "p.markups")
    network.set("p.ruler", "width")
    network.set("p.samples", 64)
    return network


def test_a_profile_linked_to_a_ruler_follows_it_when_it_moves(head):
    from vgraph.markups import Markup, Markups
    start, end = (tuple(world(head, ijk)) for ijk in INNER_ENDS)
    network = ruler_network(head, (start, end))
    table = network.evaluate("p.table")
    expected = profile(head, start=start, end=end, samples=64)
    assert np.array_equal(table["value"], expected["value"])
    assert "start" in network["p"].inapplicable() and "end" in network["p"].inapplicable()
    # the ruler moves (as a drag or the table does): the profile follows through the link
    moved = tuple(world(head, (30.0, 30.0, 40.0)))
    network.set("mk.markups", Markups(markups=(Markup(name="width", kind="ruler", points=(start, moved)),)))
    table = network.evaluate("p.table")
    np.testing.assert_allclose([table["x"][-1], table["y"][-1], table["z"][-1]], moved, atol=1e-9)
    assert np.array_equal(table["value"], profile(head, start=start, end=moved, samples=64)["value"])


def test_a_ruler_that_is_not_there_or_not_a_ruler_is_refused_by_name(head):
    from vgraph.markups import Markup, Markups
    start, end = (tuple(world(head, ijk)) for ijk in INNER_ENDS)
    network = ruler_network(head, (start, end))
    network.set("p.ruler", "height")
    with pytest.raises(VGraphError, match=r"p\.ruler: no ruler named 'height'.*rulers there: width"):
        network.evaluate("p.table")
    network.set("mk.markups", Markups(markups=(
        Markup(name="height", kind="angle", points=(start, end, (0.0, 0.0, 0.0))),)))
    with pytest.raises(VGraphError, match=r"p\.ruler: 'height' is an angle, not a ruler"):
        network.evaluate("p.table")


def test_a_store_over_its_memory_budget_is_read_only_where_the_line_runs(tmp_path):
    """A BrickedVolume whose whole array exceeds its budget: nearest and linear profiles read
    the boxes around the line's runs of samples from level 0 (never the whole array) and equal
    the in-memory profile bit for bit; cubic needs the whole array and is refused by name."""
    from vgraph.bricks.volume import BrickedVolume, MemoryBudgetError
    from vgraph.io.convert import convert
    from vgraph.volume import Volume
    z, y, x = np.mgrid[0:30, 0:36, 0:40]
    data = (np.sin(x / 3.0) * np.cos(y / 5.0) + z / 7.0).astype(np.float32)
    np.save(tmp_path / "wave.npy", data)
    convert(tmp_path / "wave.npy", tmp_path / "wave.zarr", brick=8, progress=False)
    store = BrickedVolume.open(tmp_path / "wave.zarr", memory_budget_mb=0.01)   # the array is 0.16 MiB
    memory = Volume(data, spacing=store.spacing, origin=store.origin)
    boxes, read = [], store.bricks.read
    store.bricks.read = lambda level, start, stop: boxes.append((level, start, stop)) or read(level, start, stop)
    lines = [dict(start=(0.0, 0.0, 0.0), end=(39.0, 35.0, 29.0), samples=301),       # corner to corner
             dict(start=(-5.0, 17.3, 12.6), end=(45.0, 18.1, 13.2), samples=97),       # ends outside
             dict(start=(10.5, 3.25, 0.0), end=(10.5, 3.25, 29.0), samples=58)]        # along z
    for line in lines:
        for interpolation in ("nearest", "linear"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", VGraphWarning)   # the points outside
                ours = profile(store, interpolation=interpolation, **line)["value"]
                theirs = profile(memory, interpolation=interpolation, **line)["value"]
            assert np.array_equal(ours, theirs, equal_nan=True), (line, interpolation)
    assert store._data is None and boxes and all(level == 0 for level, _, _ in boxes)
    assert max(np.prod(np.subtract(stop, start)) for _, start, stop in boxes) <= 12 ** 3   # a brick's run + 2 around
    with pytest.raises(MemoryBudgetError, match="exceeds the memory budget"):
        profile(store, interpolation="cubic", **lines[0])
