"""RegionStatistics on labels made from the shared CT head (headsq, 64 x 64 x 93 int16, spacing
3.2 x 3.2 x 1.5 mm; the shared data holds no label volume, so the labels are the connected
components of its bone, > 1150, the VTK example's level: 64 regions from 1 to 33845 voxels, and
the tissue classes air / soft tissue / bone), as read and turned: equal to numpy and to
scikit-image's regionprops and marching cubes; the mask rule; bad input named; CSV from the
command line."""

import csv
import json

import numpy as np
import pytest
from scipy import ndimage
from skimage.measure import marching_cubes, mesh_surface_area, regionprops

from helpers.headsq import read_head, turned
from vgraph import PropertyError, VGraphError, VGraphWarning
from vgraph.cli import main
from vgraph.io import read_volume
from vgraph.registry import registry

BONE, SKIN = 1150, 500  # the VTK Medical example's levels for headsq


@pytest.fixture(scope="module", params=["as_read", "turned"])
def head(request):
    volume = read_head()
    return turned(volume) if request.param == "turned" else volume


@pytest.fixture(scope="module")
def bones(head):
    """The connected components of the bone, as a label volume on the head's grid."""
    components, count = ndimage.label(head.data > BONE)
    assert count == 64
    return head.with_data(components.astype(np.int32), holds_labels=True)


def statistics(labels, volume=None, **properties):
    return registry.get("RegionStatistics")("s", **properties).process(labels=labels, volume=volume)


def test_statistics_per_label_equal_regionprops_and_numpy(head, bones):
    table = statistics(bones, head, percentiles="2.5, 50, 90")
    voxel = 3.2 * 3.2 * 1.5
    props = regionprops(bones.data, head.data.astype(np.float64), spacing=(1.5, 3.2, 3.2))
    assert table["label"].tolist() == [p.label for p in props] == list(range(1, 65))
    assert table["count"].tolist() == [p.num_pixels for p in props]
    assert np.allclose(table["volume"], [p.area for p in props], rtol=1e-12)  # regionprops' area is a volume in 3D
    assert np.allclose(table["volume"], table["count"] * voxel, rtol=1e-12)
    for ours, theirs in (("mean", "intensity_mean"), ("std", "intensity_std"), ("min", "intensity_min"),
                         ("max", "intensity_max")):
        assert np.allclose(table[ours], [getattr(p, theirs) for p in props], rtol=1e-12, atol=0), ours
    for label in (1, 17, 64):
        inside = head.data[bones.data == label].astype(np.float64)
        row = label - 1
        assert np.allclose([table["p2_5"][row], table["p50"][row], table["p90"][row]],
                           np.percentile(inside, [2.5, 50, 90]), rtol=1e-12)
    assert table.names == ["label", "count", "volume", "mean", "std", "min", "max", "p2_5", "p50", "p90",
                           "surface_area"]
    assert table.column("volume").unit == "world^3" and table.column("surface_area").unit == "world^2"


def test_surface_area_equals_marching_cubes_of_each_whole_padded_mask(head, bones):
    table = statistics(bones, percentiles="")
    assert table.names == ["label", "count", "volume", "surface_area"]  # no intensity volume
    for label in (1, 2, 40):
        mask = np.pad((bones.data == label).astype(np.float32), 1)
        vertices, faces, _, _ = marching_cubes(mask, level=0.5, spacing=(1.5, 3.2, 3.2))
        assert np.isclose(table["surface_area"][label - 1], mesh_surface_area(vertices, faces), rtol=1e-6)  # theirs summed in float32
    single = table["surface_area"][table["count"] == 1]
    assert np.allclose(single, single[0])  # every one-voxel region has the same area


def test_a_sphere_of_voxels_has_its_volume_and_the_stated_excess_area():
    from vgraph.volume import Volume
    spacing = (0.5, 0.4, 0.3)  # anisotropic: the area must be measured in world units
    k, j, i = np.indices((120, 100, 80))
    world = np.stack([i * spacing[0], j * spacing[1], k * spacing[2]], axis=-1)
    ball = np.linalg.norm(world - (20.0, 20.0, 18.0), axis=-1) <= 10.0
    table = statistics(Volume(ball.astype(np.uint8), spacing=spacing))
    assert abs(table["volume"][0] / (4 / 3 * np.pi * 1000) - 1) < 0.01
    # marching cubes of a 0/1 mask follows the voxels' staircase: about 9 % above a smooth
    # surface's area, however fine the voxels (vgraph.measure_regions says so)
    assert 0.06 < table["surface_area"][0] / (4 * np.pi * 100) - 1 < 0.11


def test_tissue_classes_and_the_mask_rule(head):
    classes = head.with_data(np.digitize(head.data, [SKIN, BONE]).astype(np.uint8), holds_labels=True)
    table = statistics(classes, head, percentiles="50", surface_area=False)
    assert table["label"].tolist() == [1, 2]  # 0 (air) is the background
    assert table["count"].tolist() == [np.count_nonzero(classes.data == c) for c in (1, 2)]
    assert table["min"][0] >= SKIN and table["max"][0] < BONE <= table["min"][1]  # digitize: [500, 1150), [1150, ...)
    mask = statistics(classes, head, regions="mask", percentiles="50", surface_area=False)
    tissue = head.data[head.data >= SKIN].astype(np.float64)
    assert mask["label"].tolist() == [1] and mask["count"][0] == tissue.size
    assert np.isclose(mask["mean"][0], tissue.mean(), rtol=1e-12) and mask["p50"][0] == np.median(tissue)


def test_nan_intensities_are_left_out_with_a_warning(head, bones):
    values = head.data.astype(np.float32)
    values[bones.data == 2] = np.nan  # label 2 is a single voxel
    values[tuple(np.argwhere(bones.data == 1)[:100].T)] = np.nan  # and 100 voxels of label 1
    with pytest.warns(VGraphWarning, match=r"^RegionStatistics 's': 101 NaN/Inf voxels of the intensity volume"):
        table = statistics(bones, head.with_data(values), percentiles="50", surface_area=False)
    assert np.isnan(table["mean"][1]) and np.isnan(table["p50"][1])
    finite = values[(bones.data == 1) & np.isfinite(values)].astype(np.float64)
    assert np.isclose(table["mean"][0], finite.mean(), rtol=1e-12) and table["count"][0] == 33845


def test_bad_input_is_refused_by_name(head, bones):
    with pytest.raises(VGraphError, match=r"^RegionStatistics 's': labels: no labels present: every voxel"):
        statistics(bones.with_data(np.zeros_like(bones.data)))
    with pytest.raises(VGraphError, match=r"^RegionStatistics 's': labels must be whole numbers"):
        statistics(head.with_data(head.data / 7.0))
    other = head.with_overrides(spacing=(3.2, 3.2, 1.6))
    with pytest.raises(VGraphError, match=r"^RegionStatistics 's': volume: the intensity volume .* lies on "
                                          r"another grid than the labels"):
        statistics(bones, other)
    cropped = head.with_data(head.data[:, :, :60])
    with pytest.raises(VGraphError, match=r"another grid than the labels"):
        statistics(bones, cropped)
    with pytest.raises(PropertyError, match=r"^s\.percentiles: percentiles must lie in \[0, 100\], got 101"):
        statistics(bones, head, percentiles="50, 101")
    with pytest.raises(PropertyError, match=r"^s\.percentiles: expected numbers in \[0, 100\] separated by commas"):
        statistics(bones, head, percentiles="median")
    with pytest.raises(PropertyError, match=r"^s\.percentiles: a percentile is given twice"):
        statistics(bones, head, percentiles="50, 50.0")


def test_vgraph_run_writes_the_statistics_as_csv(tmp_path):
    from helpers.paths import DATA
    path = DATA / "ct_head_headsq" / "quarter.nhdr"
    network = {"format": "vgraph-network", "version": 3, "processors": [
        {"id": "source", "type": "VolumeSource", "properties": {"path": str(path)}},
        {"id": "stats", "type": "RegionStatistics", "properties": {"regions": "mask", "percentiles": "50"}}],
        "connections": [{"from": "source.volume", "to": "stats.labels"},
                        {"from": "source.volume", "to": "stats.volume"}], "links": []}
    file = tmp_path / "stats.json"
    file.write_text(json.dumps(network))
    out = tmp_path / "stats.csv"
    assert main(["run", str(file), "--port", "stats.table", "--data", str(out)]) == 0
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["label", "count", "volume [world^3]", "mean", "std", "min", "max", "p50",
                       "surface_area [world^2]"]
    data = read_volume(path).data
    inside = data[data != 0].astype(np.float64)
    assert int(rows[1][1]) == inside.size and float(rows[1][3]) == inside.mean()
    assert float(rows[1][2]) == inside.size * 3.2 * 3.2 * 1.5


def test_the_shared_engine_labels_equal_regionprops_and_marching_cubes():
    """networks/data/engine_labels.nrrd (bench/make_label_volume.py: casing 1, dense parts 2) over
    the engine CT it was made from (shared/data/ct_engine), on the same grid."""
    from helpers.paths import DATA, REPO
    if not (DATA / "ct_engine" / "engine.nii.gz").is_file():
        pytest.skip("shared data set ct_engine not found")
    labels = read_volume(REPO / "networks" / "data" / "engine_labels.nrrd")
    engine = read_volume(DATA / "ct_engine" / "engine.nii.gz")
    table = statistics(labels, engine, percentiles="10, 50, 90")
    props = regionprops(labels.data, engine.data, spacing=labels.spacing[::-1])
    assert table["label"].tolist() == [1, 2] and table["count"].tolist() == [p.num_pixels for p in props]
    for ours, theirs in (("mean", "intensity_mean"), ("std", "intensity_std"), ("min", "intensity_min"),
                         ("max", "intensity_max")):
        assert np.allclose(table[ours], [getattr(p, theirs) for p in props], rtol=1e-12, atol=0), ours
    for row, label in enumerate((1, 2)):
        inside = engine.data[labels.data == label]
        assert np.array_equal([table["p10"][row], table["p50"][row], table["p90"][row]],
                              np.percentile(inside, [10, 50, 90]))
        vertices, faces, _, _ = marching_cubes(np.pad((labels.data == label).astype(np.float32), 1), 0.5)
        assert np.isclose(table["surface_area"][row], mesh_surface_area(vertices, faces), rtol=1e-6)  # theirs summed in float32


def test_names_from_the_label_table_linked_from_the_label_ray_caster(tmp_path):
    """networks/labels_engine.json names the engine's labels in its LabelRayCaster's table
    (casing 1, dense parts 2): linked to RegionStatistics' label_table they become a name column
    beside label, in the table and its CSV; the default table names no region: no column."""
    import vgraph
    from helpers.paths import REPO
    from vgraph.labels import LabelEntry, LabelTable
    network = vgraph.load(REPO / "networks" / "labels_engine.json")
    network.add("RegionStatistics", id="stats", surface_area=False)
    network.connect("source.volume", "stats.labels")
    assert "name" not in network.evaluate("stats.table").dtype.names
    network.link("labels.label_table", "stats.label_table")
    network.update("stats.table")
    table = network.output("stats.table")
    labels = network.output("source.volume").data
    assert table.names == ["label", "name", "count", "volume"]
    assert table["name"].tolist() == ["casing", "dense parts"]
    assert table["count"].tolist() == [int((labels == 1).sum()), int((labels == 2).sum())]
    renamed = network.get("labels.label_table").labels
    network.set("labels.label_table", LabelTable(labels=tuple(e for e in renamed if e.value != 2)
                                                 + (LabelEntry(value=2, name="inserts, dense"),)))
    network.update("stats.table")
    assert network.output("stats.table").column("count") is table.column("count")   # renamed, not measured again
    network.output("stats.table").to_csv(tmp_path / "stats.csv")
    rows = list(csv.reader(open(tmp_path / "stats.csv")))
    assert rows[0][:2] == ["label", "name"] and [row[1] for row in rows[1:]] == ["casing", "inserts, dense"]
    network.set("stats.regions", "mask")              # one region of all labels: no name
    assert "name" not in network.evaluate("stats.table").dtype.names


def test_the_gui_shows_the_rows_and_the_profile_in_the_nodes_status(data_dir):
    """What a node shows after the GUI's render side drew the view (vgraph.live.evaluator: the
    canvas with the profile's plot, and the statistics as a leaf of the graph; the node's data from
    Processor.frame_summary): the statistics' rows; the profile's samples, length and values."""
    import vgraph
    from helpers.paths import REPO
    from vgraph.live.evaluator import evaluate_view, processor_status
    network = vgraph.load(REPO / "networks" / "measure_engine.json")
    outcome = evaluate_view(network)
    assert {"stats", "profile", "canvas"} <= set(outcome.ran)
    rows = processor_status(network, network["stats"]).data.splitlines()
    assert rows[0].split() == ["label", "count", "volume", "[world^3]", "mean", "std", "min", "max", "p5", "p50",
                               "p95", "surface_area", "[world^2]"]
    assert rows[1].split()[:2] == ["1", "1062973"] and rows[2].split()[:2] == ["2", "68326"]
    assert processor_status(network, network["profile"]).data == \
        "400 samples over 226.274 world units; values -0.861919 to 259.06"
