"""tf_shift and tf_scale on transfer functions (data units, pivot at the data value 0): the LUT of a
moved TF is the LUT of the TF whose points were moved by hand, every renderer and the CPU
references see it, the defaults change nothing, the .json round trip, named errors."""

import json

import numpy as np
import pytest

import vgraph
from vgraph.camera import Camera
from vgraph.errors import NetworkFileError, PropertyError, VGraphError
from vgraph.network import Network
from vgraph.numerics import reference_raycast
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.transfer_function import PRESETS, TransferFunction, ValueScale
from vgraph.volume import Volume

from helpers.more_raycaster_cases import field, multivolume_network, oblique
from helpers.raycaster_cases import OBLIQUE, curvature_network

SIZE = (40, 32)
SHIFT, SCALE = 150.0, 1.25


def hounsfield_ct(shape=(24, 24, 24)):
    """A CT-like int16 volume: air, a soft-tissue ball, a bone core with a ramp through it."""
    z, y, x = np.indices(shape) - (np.array(shape) - 1)[:, None, None, None] / 2
    radius = np.sqrt(x * x + y * y + z * z)
    data = np.where(radius < 5, 300 + 60 * (5 - radius) ** 2, np.where(radius < 10, 40, -1000))
    return Volume(data.astype(np.int16))


def by_hand(tf: TransferFunction, shift=SHIFT, scale=SCALE) -> TransferFunction:
    """The data-unit TF with each point moved to x * scale + shift, written out."""
    assert tf.space == "data"
    return TransferFunction(space="data", points=[(p[0] * scale + shift, *p[1:]) for p in tf.points])


def moved(tf: TransferFunction, shift=SHIFT, scale=SCALE) -> TransferFunction:
    return TransferFunction(space=tf.space, points=tf.points, tf_shift=shift, tf_scale=scale)


# --- the LUT ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["ct-bone", "ct-soft-tissue"])
@pytest.mark.parametrize("shift, scale", [(SHIFT, 1.0), (-80.0, 1.0), (0.0, SCALE), (SHIFT, 0.8)])
def test_the_lut_of_a_moved_data_tf_is_that_of_the_points_moved_by_hand(name, shift, scale):
    volume = hounsfield_ct()
    preset = PRESETS[name]
    lut = moved(preset, shift, scale).for_volume(volume).lut()
    np.testing.assert_array_equal(lut, by_hand(preset, shift, scale).for_volume(volume).lut())
    assert not np.array_equal(lut, preset.for_volume(volume).lut())


def test_a_shift_moves_a_threshold_by_that_many_data_units():
    volume = hounsfield_ct()   # value range -1000 .. 1800
    step = TransferFunction(space="data", points=[(300.0, 1, 1, 1, 0), (300.0, 1, 1, 1, 1)], tf_shift=200.0)
    low, high = volume.value_range
    x = (np.array([499.0, 501.0]) - low) / (high - low)
    np.testing.assert_allclose(step.for_volume(volume)(x)[:, 3], [0.0, 1.0])


@pytest.mark.parametrize("name", ["grayscale", "hot-metal", "auto", "mri-brain"])
def test_normalised_and_percentile_tfs_move_in_data_units_too(name):
    volume = hounsfield_ct()
    preset = PRESETS[name]
    low, high = volume.value_range
    positions = np.array([p[0] for p in preset.points])
    data = (volume.percentiles(positions) if preset.space == "percentile" else low + positions * (high - low))
    hand = TransferFunction(space="data", points=[(d * SCALE + SHIFT, *p[1:]) for d, p in zip(data, preset.points)])
    np.testing.assert_allclose(moved(preset).for_volume(volume).lut(), hand.for_volume(volume).lut(), atol=1e-6)


@pytest.mark.parametrize("name", list(PRESETS))
def test_the_defaults_change_nothing(name):
    volume = hounsfield_ct()
    preset = PRESETS[name]
    explicit = TransferFunction(space=preset.space, points=preset.points, tf_shift=0.0, tf_scale=1.0)
    assert explicit == preset and not explicit.is_moved
    np.testing.assert_array_equal(explicit.for_volume(volume).lut(), preset.for_volume(volume).lut())
    if preset.space == "normalized":
        assert preset.for_volume(volume) is preset


def test_a_moved_normalised_tf_needs_the_volume():
    tf = moved(PRESETS["grayscale"])
    assert tf.needs_volume
    with pytest.raises(ValueError, match="shifted or scaled in data units: use tf.for_volume"):
        tf.lut()


# --- renderers ----------------------------------------------------------------------------------
def slice_network(volume, tf):
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("SliceViewer", id="rc", mapping="tf", transfer_function=tf)
    network.connect("src.volume", "rc.volume")
    return network


def sweep_network(volume, tf):
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("SweepPlaneRenderer", id="rc", transfer_function=tf,
                camera=Camera.looking_at_box((-0.5,) * 3, (23.5,) * 3, direction=(-0.4, -0.3, -1.0)))
    network.connect("src.volume", "rc.volume")
    return network


def tets_network(volume, tf):
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("VolumeToTetMesh", id="tets")
    network.add("ProjectedTetrahedra", id="rc", transfer_function=tf,
                camera=Camera.looking_at_box((-0.5,) * 3, (23.5,) * 3, direction=(-0.4, -0.3, -1.0)))
    network.connect("src.volume", "tets.volume")
    network.connect("tets.mesh", "rc.mesh")
    return network


def ct_in(volume_range):
    """field() (values 0..1) as a CT in Hounsfield units, so the CT presets show it."""
    low, high = volume_range
    base = field((37, 29, 41))
    return Volume((low + base.data * (high - low)).astype(np.float32), spacing=base.spacing, origin=base.origin)


RENDERERS = {
    "RayCaster": lambda tf: ray_caster_network(hounsfield_ct(), Camera.looking_at_box(
        (-0.5,) * 3, (23.5,) * 3, direction=(-0.45, -0.35, -1.0)), "RayCaster", transfer_function=tf),
    "BrickedRayCaster": lambda tf: ray_caster_network(ct_in((-1000, 1800)), oblique(field((37, 29, 41))),
                                                      "BrickedRayCaster", brick_size=16, lod_bias=-16.0,
                                                      transfer_function=tf),
    "CurvatureVolumeRaycaster": lambda tf: curvature_network("CurvatureVolumeRaycaster", "central", OBLIQUE,
                                                             transfer_function=tf),
    "MultiVolumeRayCaster": lambda tf: multivolume_network(1, transfer_function1=tf),
    "SliceViewer": lambda tf: slice_network(hounsfield_ct(), tf),
    "SweepPlaneRenderer": lambda tf: sweep_network(hounsfield_ct(), tf),
    "ProjectedTetrahedra": lambda tf: tets_network(hounsfield_ct(), tf),
}


def renderer_tf(name: str) -> TransferFunction:
    """A data-unit TF that shows each renderer's test volume (the tori hold signed distances,
    about -1.07 .. 0.21; the CT volumes are in Hounsfield units)."""
    if name in ("CurvatureVolumeRaycaster", "MultiVolumeRayCaster"):
        return TransferFunction(space="data", points=[(-0.6, 0.9, 0.5, 0.2, 0.0), (-0.2, 0.9, 0.8, 0.6, 0.4),
                                                      (0.2, 1.0, 1.0, 1.0, 0.9)])
    return PRESETS["ct-bone"]


@pytest.mark.parametrize("name", list(RENDERERS))
def test_every_renderer_draws_a_moved_tf_as_the_points_moved_by_hand(name):
    tf = renderer_tf(name)
    shift, scale = (-0.15, 0.9) if tf.points[-1][0] < 2 else (SHIFT, SCALE)
    images = [RENDERERS[name](t).evaluate("rc.image", size=SIZE)
              for t in (moved(tf, shift, scale), by_hand(tf, shift, scale), tf)]
    np.testing.assert_array_equal(images[0], images[1])
    assert np.abs(images[0] - images[2]).max() > 0.02   # the move shows
    assert images[0][..., 3].max() > 0.1                 # and something is drawn


def test_the_cpu_reference_sees_the_move_and_agrees_with_the_gl_ray_caster():
    volume = hounsfield_ct()
    camera = Camera.looking_at_box((-0.5,) * 3, (23.5,) * 3, direction=(-0.45, -0.35, -1.0))
    tf = moved(PRESETS["ct-bone"])
    cpu = reference_raycast.render(volume, camera, tf, SIZE)
    np.testing.assert_array_equal(cpu, reference_raycast.render(volume, camera, by_hand(PRESETS["ct-bone"]), SIZE))
    assert np.abs(cpu - reference_raycast.render(volume, camera, PRESETS["ct-bone"], SIZE)).max() > 0.02
    network = ray_caster_network(volume, camera, "RayCaster", transfer_function=tf, shading="none")
    gl = network.evaluate("rc.image", size=SIZE)
    assert np.abs(gl - cpu).max() < 0.02   # the GL/CPU agreement of tests/test_reference_raycast.py


def test_the_colour_bar_places_the_moved_tf_on_its_value_range_without_a_volume():
    from vgraph.processors.color_bar import resolved_transfer_function
    placed = resolved_transfer_function(moved(PRESETS["ct-bone"]), None, (-1000.0, 1800.0), "bar.transfer_function")
    assert placed == by_hand(PRESETS["ct-bone"]).over_range(-1000.0, 1800.0)
    assert placed != PRESETS["ct-bone"].over_range(-1000.0, 1800.0)


# --- files --------------------------------------------------------------------------------------
def test_a_network_file_gives_a_preset_with_a_shift_and_saves_it_only_when_set(tmp_path):
    document = {"format": "vgraph-network", "version": 3, "processors": [
        {"id": "a", "type": "RayCaster", "properties": {"transfer_function": {"preset": "ct-bone", "tf_shift": 150}}},
        {"id": "b", "type": "RayCaster", "properties": {"transfer_function": "ct-bone"}}]}
    (tmp_path / "net.json").write_text(json.dumps(document))
    network = vgraph.load(tmp_path / "net.json")
    assert network.get("a.transfer_function") == moved(PRESETS["ct-bone"], 150.0, 1.0)
    network.save(tmp_path / "again.json")
    saved = json.loads((tmp_path / "again.json").read_text())
    properties = {p["id"]: p["properties"]["transfer_function"] for p in saved["processors"]}
    assert properties["a"]["tf_shift"] == 150.0 and "tf_scale" not in properties["a"]
    assert "tf_shift" not in properties["b"] and "tf_scale" not in properties["b"]
    reloaded = vgraph.load(tmp_path / "again.json")
    assert reloaded.get("a.transfer_function") == network.get("a.transfer_function")
    assert reloaded.get("b.transfer_function") == PRESETS["ct-bone"]


def test_a_tf_file_keeps_its_shift_and_scale_exactly(tmp_path):
    tf = moved(PRESETS["mri-brain"], 0.1 + 0.2, 1 / 3)
    tf.save(tmp_path / "tf.json")
    assert TransferFunction.load(tmp_path / "tf.json") == tf
    PRESETS["mri-brain"].save(tmp_path / "plain.json")
    assert "tf_" not in (tmp_path / "plain.json").read_text()


@pytest.mark.parametrize("value, problem", [
    ({"preset": "ct-bone", "tf_shift": float("nan")}, "tf_shift: Input should be a finite number"),
    ({"preset": "ct-bone", "tf_shift": float("inf")}, "tf_shift: Input should be a finite number"),
    ({"preset": "ct-bone", "tf_scale": 0.0}, "tf_scale: Input should be greater than 0"),
    ({"preset": "ct-bone", "tf_scale": -2.0}, "tf_scale: Input should be greater than 0"),
    ({"preset": "ct-bone", "tf_scale": True}, "tf_scale: Value error, expected a number, not a boolean"),
    ({"preset": "ct-bone", "shift": 3}, "keys preset, tf_shift and tf_scale, not 'shift'"),
    ({"preset": "bone", "tf_shift": 3}, "'bone' is neither a preset"),
])
def test_bad_values_are_named_errors(value, problem):
    network = Network()
    network.add("RayCaster", id="rc")
    with pytest.raises(PropertyError, match=r"rc\.transfer_function: invalid value .*" + problem.replace("(", r"\(")):
        network.set("rc.transfer_function", value)


def test_a_bad_shift_in_a_network_file_names_the_file_processor_and_field(tmp_path):
    document = {"format": "vgraph-network", "version": 3, "processors": [
        {"id": "rc", "type": "RayCaster",
         "properties": {"transfer_function": {"preset": "ct-bone", "tf_scale": -1}}}]}
    (tmp_path / "net.json").write_text(json.dumps(document))
    with pytest.raises(NetworkFileError) as error:
        vgraph.load(tmp_path / "net.json")
    text = str(error.value)
    assert "net.json" in text and "processors[0].properties.transfer_function" in text
    assert "tf_scale: Input should be greater than 0" in text


def test_a_bad_shift_in_a_tf_file_names_the_file(tmp_path):
    (tmp_path / "tf.json").write_text('{"points": [[0, 0, 0, 0, 0]], "tf_shift": NaN}')
    with pytest.raises(VGraphError, match=r"tf\.json: not a transfer function: tf_shift: Input should be a finite"):
        TransferFunction.load(tmp_path / "tf.json")


def test_the_value_scale_maps_data_values_both_ways():
    scale = ValueScale.of(field((20, 18, 22)))  # continuous values: percentiles invert
    for space in ("normalized", "data", "percentile"):
        positions = {"normalized": [0.1, 0.7], "data": [0.3, 0.8], "percentile": [20.0, 95.0]}[space]
        np.testing.assert_allclose(scale.from_data(scale.to_data(positions, space), space), positions, atol=1e-9)


def test_the_command_line_moves_a_preset_and_names_a_bad_scale(tmp_path, capsys):
    from vgraph.cli import main
    from helpers.paths import REPO
    sphere = str(REPO / "networks" / "raycast_sphere.json")
    images = []
    for value in ('{"preset": "hot-metal", "tf_shift": 0.3}', "hot-metal"):
        out = tmp_path / f"{len(images)}.npy"
        assert main(["run", sphere, "--set", f"rc.transfer_function={value}", "--size", "40x32",
                     "--npy", str(out)]) == 0
        images.append(np.load(out))
    assert np.abs(images[0] - images[1]).max() > 0.02
    assert main(["run", sphere, "--set", 'rc.transfer_function={"preset": "hot-metal", "tf_scale": 0}']) == 2
    assert "rc.transfer_function: invalid value" in capsys.readouterr().err


def test_the_shipped_networks_keep_their_transfer_functions_exactly():
    """Files saved before tf_shift existed load as before and save the same TF values back."""
    from helpers.paths import REPO
    from vgraph.fileformat import network_document
    checked = 0
    for path in sorted((REPO / "networks").glob("*.json")):
        document = json.loads(path.read_text())
        saved = {p["id"]: p["properties"] for p in network_document(vgraph.load(path))["processors"]}
        for processor in document["processors"]:
            for name, value in processor.get("properties", {}).items():
                if isinstance(value, dict) and "points" in value:
                    again = saved[processor["id"]][name]
                    assert "tf_shift" not in again and "tf_scale" not in again
                    assert TransferFunction.model_validate(again) == TransferFunction.model_validate(value)
                    checked += 1
    assert checked > 0
