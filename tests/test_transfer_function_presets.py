"""Transfer functions in normalised, data and percentile positions; presets by name and TF files:
exact round trips, errors that name the file and the problem."""

import json
import re

import numpy as np
import pytest

import vgraph
from vgraph.camera import Camera
from vgraph.errors import NetworkFileError, PropertyError, VGraphError
from vgraph.network import Network
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import PRESETS, TransferFunction
from vgraph.volume import Volume


def hounsfield_ct(shape=(24, 24, 24), air=-1000, tissue=40, bone=1000):
    """A CT-like int16 volume in Hounsfield units: air around a soft-tissue ball holding a bone core."""
    z, y, x = np.indices(shape) - (np.array(shape) - 1)[:, None, None, None] / 2
    radius = np.sqrt(x * x + y * y + z * z)
    data = np.where(radius < 4, bone, np.where(radius < 9, tissue, air)).astype(np.int16)
    return Volume(data)


@pytest.mark.parametrize("name", list(PRESETS))
def test_presets_show_something_and_hide_the_background(name):
    preset = PRESETS[name]
    volume = hounsfield_ct() if preset.space != "normalized" else Volume(np.linspace(0, 1, 8).reshape(2, 2, 2))
    lut = preset.for_volume(volume).lut()
    assert lut[:, 3].max() > 0.2            # something is visible ...
    assert lut[0, 3] == 0.0                 # ... and the lowest intensities (air, background) are not


def test_ct_presets_mean_the_same_hounsfield_units_on_every_ct():
    bone, tissue = PRESETS["ct-bone"], PRESETS["ct-soft-tissue"]
    for volume in (hounsfield_ct(), hounsfield_ct(bone=3000), hounsfield_ct(air=-1024, bone=600)):
        low, high = volume.value_range
        at = lambda tf, hu: tf.for_volume(volume)((hu - low) / (high - low))
        assert at(bone, 40)[3] == 0.0 < at(tissue, 40)[3]      # bone hides soft tissue
        assert at(bone, 300)[3] == pytest.approx(0.25, abs=1e-9)  # "bone at 300 HU" everywhere
        assert at(bone, 600)[3] > 0.6


def test_data_positions_outside_the_value_range_are_cut_with_the_tf_values_at_the_ends():
    tf = TransferFunction(space="data", points=[(-100.0, 0, 0, 0, 0), (100.0, 1, 1, 1, 1)])
    resolved = tf.for_volume(Volume(np.array([0.0, 50.0]).reshape(1, 1, 2)))
    assert resolved.space == "normalized"
    assert resolved.points == [(0.0, 0.5, 0.5, 0.5, 0.5), (1.0, 0.75, 0.75, 0.75, 0.75)]
    step = TransferFunction(space="data", points=[(10.0, 0, 0, 0, 0), (10.0, 1, 0, 0, 1)])
    assert step.for_volume(Volume(np.array([0.0, 20.0]).reshape(1, 1, 2)))(np.array([0.49, 0.51]))[:, 3].tolist() == [0, 1]


def test_percentile_positions_follow_the_data():
    data = np.concatenate([np.zeros(500), np.linspace(100, 200, 500)]).reshape(10, 10, 10)
    tf = TransferFunction(space="percentile", points=[(40.0, 0, 0, 0, 0), (75.0, 1, 1, 1, 1)])
    resolved = tf.for_volume(Volume(data))
    positions = [p[0] for p in resolved.points]
    # The 40th percentile is among the zeros (to the histogram's resolution, 200 / 65536) ...
    assert positions[0] == 0.0 and positions[1] == pytest.approx(0.0, abs=200 / 65536 / 200)
    # ... the 75th is np.percentile's.
    assert positions[-1] == 1.0 and resolved.points[-1][1:] == (1.0, 1.0, 1.0, 1.0)
    assert resolved(np.percentile(data, 75) / 200.0)[3] == pytest.approx(1.0, abs=1e-4)
    # Between two points the TF is linear in data values (not in percent).
    assert resolved(np.percentile(data, 75) / 2 / 200.0)[3] == pytest.approx(0.5, abs=1e-4)
    with pytest.raises(ValueError, match="for_volume"):
        tf(0.5)


@pytest.mark.parametrize("space, points, problem", [
    ("normalized", [(1.5, 0, 0, 0, 0)], "a normalized position must lie in [0, 1]"),
    ("percentile", [(101.0, 0, 0, 0, 0)], "a percentile position must lie in [0, 100]"),
    ("data", [(-2000.0, 0, 0, 0, 0), (-3000.0, 0, 0, 0, 0)], "non-decreasing"),
    ("data", [(0.0, 0, 2, 0, 0)], "r, g, b, a in [0, 1]"),
    ("hounsfield", [(0.0, 0, 0, 0, 0)], "space"),
])
def test_impossible_points_and_spaces_are_refused(space, points, problem):
    with pytest.raises(ValueError, match=re.escape(problem)):
        TransferFunction(space=space, points=points)


def test_a_property_takes_a_preset_name_or_a_file_relative_to_the_network(tmp_path):
    network = Network(base_dir=tmp_path)
    network.add("RayCaster", id="rc", transfer_function="ct-bone")
    assert network.get("rc.transfer_function") == PRESETS["ct-bone"]
    PRESETS["rainbow"].save(tmp_path / "mine.json")
    network.set("rc.transfer_function", "mine.json")
    assert network.get("rc.transfer_function") == PRESETS["rainbow"]
    with pytest.raises(PropertyError, match="rc.transfer_function: .*'bone' is neither a preset "
                                            r"\(auto, grayscale, ct-bone"):
        network.set("rc.transfer_function", "bone")


def test_a_network_file_names_a_preset_and_a_tf_file_next_to_it(tmp_path):
    PRESETS["hot-metal"].save(tmp_path / "tfs" / "metal.json") if (tmp_path / "tfs").mkdir() is None else None
    document = {"format": "vgraph-network", "version": 1, "processors": [
        {"id": "a", "type": "RayCaster", "properties": {"transfer_function": "mri-brain"}},
        {"id": "b", "type": "RayCaster", "properties": {"transfer_function": "tfs/metal.json"}},
        {"id": "c", "type": "RayCaster", "properties": {"transfer_function": "tfs/missing.json"}}]}
    (tmp_path / "net.json").write_text(json.dumps(document))
    with pytest.raises(NetworkFileError) as error:
        vgraph.load(tmp_path / "net.json")
    assert "processors[2].properties.transfer_function" in str(error.value)
    assert "'tfs/missing.json' is neither a preset" in str(error.value)
    document["processors"].pop()
    (tmp_path / "net.json").write_text(json.dumps(document))
    network = vgraph.load(tmp_path / "net.json")
    assert network.get("a.transfer_function") == PRESETS["mri-brain"]
    assert network.get("b.transfer_function") == PRESETS["hot-metal"]


def test_a_data_tf_renders_the_same_structure_whatever_the_file_range():
    """Bone at >= 300 HU stays the same object when the air is -1000 or -3024 (the padding some
    scanners store): in normalised positions the same TF would show something else."""
    camera = Camera.looking_at_box((0, 0, 0), (23, 23, 23), direction=(0, 0, -1), projection="orthographic")
    images = []
    for air in (-1000, -3024):
        network = ray_caster_network(hounsfield_ct(air=air), camera, transfer_function="ct-bone")
        images.append(network.evaluate("rc.image", size=(48, 48)))
    assert images[0][..., :3].max() > 0.3
    assert np.abs(images[0] - images[1]).max() < 2e-3


@pytest.mark.parametrize("name", list(PRESETS))
def test_save_then_load_is_exact(tmp_path, name):
    path = tmp_path / "tf.json"
    PRESETS[name].save(path)
    assert TransferFunction.load(path) == PRESETS[name]
    expected = {"points": [list(p) for p in PRESETS[name].points]}
    if PRESETS[name].space != "normalized":
        expected["space"] = PRESETS[name].space
    assert json.loads(path.read_text()) == expected


def test_save_keeps_floats_exact_and_replaces_the_file(tmp_path):
    path = tmp_path / "tf.json"
    path.write_text("old")
    odd = TransferFunction(points=[(0.1 + 0.2, 1 / 3, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0, np.float64(2 / 7))])
    odd.save(path)
    assert TransferFunction.load(path) == odd
    assert [p.name for p in tmp_path.iterdir()] == ["tf.json"]   # no temporary file left behind


@pytest.mark.parametrize("text, problem", [
    ("{not json", "not valid JSON"),
    ('{"points": []}', "points: List should have at least 1 item"),
    ('{"points": [[0.5, 1, 1, 1]]}', "points: Value error, point 0 needs 5 numbers [position, r, g, b, a]"),
    ('{"points": [[0.5, 1, 1, 1, 1], [0.2, 0, 0, 0, 0]]}', "positions must be non-decreasing"),
    ('{"points": [[0, 0, 0, 0, 0]], "colour": 1}', "colour: Extra inputs are not permitted"),
    ('[[0, 0, 0, 0, 0]]', "not a transfer function"),
])
def test_load_errors_name_the_file_and_the_problem(tmp_path, text, problem):
    path = tmp_path / "broken.json"
    path.write_text(text)
    with pytest.raises(VGraphError) as error:
        TransferFunction.load(path)
    message = str(error.value)
    assert message.startswith(f"{path}: ") and problem in message


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(VGraphError, match=f"{tmp_path / 'nope.json'}: cannot read"):
        TransferFunction.load(tmp_path / "nope.json")
