"""An empty (one-colour) picture names what emptied it, checked in order: the value range or the
renderer's transfer function / iso level / label table, then the clip planes and crop box, then a
slice off the volume, then the camera (vgraph.blank_causes); the causes after the one named are
not blamed. Before (issue 28, defect 7), a clip plane that removed everything gave "100% of the
voxels are visible" and blamed the camera and the value range, and a 4D file showed t = 0
without saying it had more time points."""

import json
import re
import warnings

import nibabel as nib
import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.clipping import ClipPlane
from vgraph.network import Network
from vgraph.registry import registry
from vgraph.scheduler import BlankImageWarning, blank_image_warning
from vgraph.shown_content import voxels_under
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.time_series import TimeSeriesWarning
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

N = 24
SIZE = (32, 32)
CAMERA = Camera(position=(11.5, 11.5, 60.0), focus=(11.5, 11.5, 11.5))
AWAY = Camera(position=(11.5, 11.5, 60.0), focus=(11.5, 11.5, 100.0))  # the ball is behind it
RAMP = {"points": [[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 1.0]]}
HIGH_ONLY = {"points": [[0.0, 1, 1, 1, 0.0], [0.6, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 1.0]]}
TRANSPARENT = {"points": [[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 0.0]]}
FROM_045 = {"points": [[0.0, 1, 1, 1, 0.0], [0.45, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 1.0]]}  # x 5 .. 18 of ball()
X_BEYOND_300 = [{"normal": [1, 0, 0], "point": [300, 0, 0]}]
OTHER_CAUSES = ("camera", "clip_planes", "crop_box", "lies below its value range", "lies above its value range",
                "transfer_function", "iso_level")


def ball(scale=1.0) -> np.ndarray:
    """Intensities 1 at the centre falling to 0 at radius 12 (the visible voxels span 5 .. 18)."""
    z, y, x = np.mgrid[0:N, 0:N, 0:N]
    radius = np.sqrt((x - 11.5) ** 2 + (y - 11.5) ** 2 + (z - 11.5) ** 2)
    return (np.clip(1.0 - radius / 12.0, 0.0, 1.0) * scale).astype(np.float32)


def ball_network(camera: Camera = CAMERA, volume: Volume | None = None, **properties) -> Network:
    """GivenVolume 'src' -> EntryExitPoints 'eep' -> RayCaster 'rc', its TF FROM_045 unless given."""
    properties.setdefault("transfer_function", FROM_045)
    return ray_caster_network(volume or Volume(ball()), camera, **properties)


def blank_warning(network: Network, target: str = "rc.image") -> str:
    """The one BlankImageWarning of evaluating ``target`` (whose image must be one colour)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = network.evaluate(target, size=SIZE)
    assert np.all(image == image[:1, :1])
    messages = [str(w.message) for w in caught if issubclass(w.category, BlankImageWarning)]
    assert len(messages) == 1, [str(w.message) for w in caught]
    return messages[0]


def blames_only(message: str, *named: str) -> None:
    """``message`` names each of ``named`` and none of the other causes."""
    for words in named:
        assert words in message, message
    for words in OTHER_CAUSES:
        if not any(words in n for n in named):
            assert words not in message, f"{words!r} blamed too: {message}"


# --- 1. the value range and the transfer function ----------------------------------------------
def test_a_transfer_function_opaque_only_where_no_value_lies_is_named_with_where_the_values_are():
    volume = Volume(ball(0.4), declared_range=(0.0, 1.0))  # intensities 0 .. 0.37
    message = blank_warning(ray_caster_network(volume, CAMERA, transfer_function=HIGH_ONLY))
    assert message.startswith("rc (RayCaster) rendered an empty image: rc.transfer_function gives "
                              "opacity only to intensities 0.6")
    assert "holds intensities 0 .. 0.3711 of its value range [0, 1]" in message
    blames_only(message, "rc.transfer_function")


def test_a_transparent_transfer_function_is_named_and_not_the_camera_that_looks_away_too():
    message = blank_warning(ray_caster_network(Volume(ball()), AWAY, transfer_function=TRANSPARENT))
    assert "rc.transfer_function is transparent at every intensity" in message
    blames_only(message, "rc.transfer_function")


def test_an_image_with_one_pixel_of_another_colour_is_not_blank_wherever_it_lies():
    """The check looks at every 7th pixel of every 7th row first, then at every pixel: a pixel off
    that grid that differs still makes the image not blank."""
    network = ray_caster_network(Volume(ball()), CAMERA, transfer_function=TRANSPARENT)
    with pytest.warns(BlankImageWarning):
        pixels = np.asarray(network.evaluate("rc.image", size=SIZE)).copy()
    assert "rc.transfer_function is transparent" in blank_image_warning(network, "rc.image", pixels)
    pixels[10, 19, 2] += 0.5  # row 10 and column 19: neither on the grid of every 7th
    assert blank_image_warning(network, "rc.image", pixels) is None
    pixels[10, 19, 2] -= 0.5
    pixels[14, 21, 0] += 0.5  # on it
    assert blank_image_warning(network, "rc.image", pixels) is None


def test_values_beyond_the_value_range_name_the_value_range():
    volume = Volume(ball(100.0), declared_range=(200.0, 300.0))
    message = blank_warning(ray_caster_network(volume, CAMERA, transfer_function=RAMP))
    assert "every value of its volume (in memory) lies below its value range [200, 300] (the range " \
           "the data declares): the values span 0 .. 92.78" in message
    blames_only(message, "lies below its value range", "rc.transfer_function")  # the TF's end it takes


def test_vgraph_run_names_the_value_range_property_that_excludes_the_data(tmp_path, capsys):
    path = tmp_path / "ball.npy"
    np.save(path, ball(100.0))
    assert main(["run", str(path), "-o", str(tmp_path / "b.png"), "--set", "source.value_range=[200, 300]",
                 "--set", f"rc.transfer_function={json.dumps(RAMP)}"]) == 0
    err = capsys.readouterr().err
    assert "vgraph: warning: rc (RayCaster) rendered an empty image: every value of its volume" in err
    assert "lies below its value range [200, 300] (set by source.value_range)" in err
    assert "set source.value_range to cover 0 .. 92.78" in err
    assert "camera" not in err and "clip" not in err


@pytest.mark.parametrize("processor, properties", [("RayCaster", {"compositing": "iso"}),
                                                   ("CurvatureRaycaster", {"derivatives": "central"})])
def test_an_iso_level_above_every_value_is_named(processor, properties):
    volume = Volume(ball(0.4), declared_range=(0.0, 1.0))
    network = ray_caster_network(volume, CAMERA, processor=processor, iso_level=0.9, **properties)
    message = blank_warning(network)
    assert message.startswith(f"rc ({processor}) rendered an empty image: ")
    assert "rc.iso_level 0.9 lies above every value" in message
    assert "lower rc.iso_level below 0.3711" in message
    blames_only(message, "rc.iso_level")


def test_a_label_table_that_hides_every_label_is_named():
    labels = np.zeros((N, N, N), np.uint8)
    labels[4:12, 4:12, 4:12], labels[12:20, 12:20, 12:20] = 1, 2
    network = ray_caster_network(Volume(labels), CAMERA, processor="LabelRayCaster", id="lrc",
                                 inport="labels", label_table={"labels": [], "unlisted": "hidden"})
    message = blank_warning(network, "lrc.image")
    assert "lrc.label_table hides every label its labels (in memory) holds (0, 1, 2)" in message
    assert "camera" not in message and "clip" not in message


def test_each_channel_of_a_multi_volume_ray_caster_says_why_it_shows_nothing():
    network = Network()
    network.add("EntryExitPoints", id="eep", camera=CAMERA)
    network.add("MultiVolumeRayCaster", id="mv", transfer_function1=TRANSPARENT, transfer_function2=HIGH_ONLY)
    network.link("eep.camera", "mv.camera")
    for n, (port, volume) in enumerate((("volume", Volume(ball())),
                                        ("volume2", Volume(ball(0.4), declared_range=(0.0, 1.0)))), start=1):
        network.add(GivenVolume(id=f"src{n}", volume=volume))
        network.connect(f"src{n}.volume", f"mv.volume{n}")
        network.connect(f"src{n}.volume", f"eep.{port}")
    network.connect("eep.entry", "mv.entry")
    network.connect("eep.exit", "mv.exit")
    message = blank_warning(network, "mv.image")
    assert "volume1: mv.transfer_function1 is transparent at every intensity" in message
    assert "volume2: mv.transfer_function2 gives opacity only to intensities 0.6" in message
    assert "camera" not in message


# --- 2. clip planes and the crop box -----------------------------------------------------------
def test_a_clip_plane_that_removes_everything_is_named_and_the_camera_is_not_blamed():
    network = ball_network()
    network.set("eep.clip_planes", X_BEYOND_300)
    message = blank_warning(network)
    assert message == ("rc (RayCaster) rendered an empty image: eep.clip_planes[0] removes every voxel rc "
                       "shows (it keeps x >= 300; they lie at x 5 .. 18); move it or turn its normal around")
    blames_only(message, "clip_planes")
    assert "% of the voxels are visible" not in message


def test_the_clip_plane_is_named_first_when_the_camera_looks_away_as_well():
    network = ball_network(AWAY)
    network.set("eep.clip_planes", [{"normal": [0, 0, -1], "point": [0, 0, -5]}])
    message = blank_warning(network)
    assert "eep.clip_planes[0] removes every voxel rc shows (it keeps z <= -5; they lie at z 5 .. 18)" in message
    blames_only(message, "clip_planes")


def test_an_oblique_clip_plane_is_written_as_its_inequality():
    network = ball_network()
    network.set("eep.clip_planes", [{"normal": [0, 0, 1], "point": [0, 0, 1]},
                                    {"normal": [1, 1, 0], "point": [40, 40, 0]}])
    message = blank_warning(network)
    assert "eep.clip_planes[1] removes every voxel rc shows (it keeps 0.7071 x + 0.7071 y >= 56.57; " \
           "they lie at 0.7071 x + 0.7071 y = 9.899 .. 22.63)" in message


def test_clip_planes_that_keep_nothing_only_together_are_named_together():
    network = ball_network()
    network.set("eep.clip_planes", [{"normal": [1, 0, 0], "point": [15, 0, 0]},
                                    {"normal": [-1, 0, 0], "point": [8, 0, 0]}])
    message = blank_warning(network)
    assert "eep.clip_planes together keep no voxel rc shows, though each alone keeps some" in message
    blames_only(message, "clip_planes")


def test_a_crop_box_beside_the_volume_is_named():
    network = ball_network()
    network.set("eep.crop_box", (50.0, 50.0, 50.0, 60.0, 60.0, 60.0))
    message = blank_warning(network)
    assert "eep.crop_box holds no voxel rc shows (it keeps x 50 .. 60, y 50 .. 60, z 50 .. 60; they " \
           "lie at x 5 .. 18, y 5 .. 18, z 5 .. 18)" in message
    blames_only(message, "crop_box")


def test_a_clip_plane_before_the_visible_voxels_is_named_though_it_keeps_part_of_the_box():
    """It keeps x >= 20: the box (0 .. 23) is cut, not removed, but every visible voxel is."""
    network = ball_network()
    network.set("eep.clip_planes", [{"normal": [1, 0, 0], "point": [20, 0, 0]}])
    message = blank_warning(network)
    assert "eep.clip_planes[0] removes every voxel rc shows (it keeps x >= 20; they lie at x 5 .. 18)" in message


@pytest.mark.parametrize("processor, inport, properties", [
    ("BrickedRayCaster", "volume", {}),
    ("LabelRayCaster", "labels", {}),
    ("CurvatureVolumeRaycaster", "volume", {"derivatives": "central"}),
])
def test_every_ray_caster_names_the_clip_plane(processor, inport, properties):
    if processor != "LabelRayCaster":
        properties["transfer_function"] = FROM_045
    data = (ball() > 0.3).astype(np.uint8) if processor == "LabelRayCaster" else ball()
    network = ray_caster_network(Volume(data), CAMERA, processor=processor, inport=inport, **properties)
    network.set("eep.clip_planes", X_BEYOND_300)
    message = blank_warning(network)
    assert message.startswith(f"rc ({processor}) rendered an empty image: eep.clip_planes[0] removes "
                              f"every voxel rc shows (it keeps x >= 300")
    blames_only(message, "clip_planes")


def test_a_store_over_its_memory_budget_is_judged_from_its_box_without_loading_it(tmp_path):
    """The RayCaster draws it brick by brick; the diagnosis does not read it whole either: its box
    (x 0 .. 23) stands in for where the visible voxels lie."""
    from vgraph.io.convert import convert
    from vgraph.bricks.volume import BrickedVolume
    np.save(tmp_path / "ball.npy", (ball() * 65535).astype(np.uint16))
    convert(tmp_path / "ball.npy", tmp_path / "ball.zarr", brick=8, progress=False)
    store = BrickedVolume.open(tmp_path / "ball.zarr", memory_budget_mb=0.01)
    network = ball_network(volume=store)
    network.set("eep.clip_planes", X_BEYOND_300)
    message = blank_warning(network)
    assert "eep.clip_planes[0] removes every voxel rc shows (it keeps x >= 300; they lie at x 0 .. 23)" in message
    network.set("eep.clip_planes", [])
    network.set("rc.transfer_function", TRANSPARENT)
    assert "rc.transfer_function is transparent at every intensity" in blank_warning(network)
    assert store._data is None  # never read whole


def test_vgraph_run_names_the_clip_plane_on_stderr(tmp_path, capsys):
    path = tmp_path / "ball.npy"
    np.save(path, ball())
    assert main(["run", str(path), "-o", str(tmp_path / "b.png"),
                 "--set", f"eep.clip_planes={json.dumps(X_BEYOND_300)}"]) == 0
    err = capsys.readouterr().err
    assert "vgraph: warning: rc (RayCaster) rendered an empty image: eep.clip_planes[0] removes every " \
           "voxel rc shows (it keeps x >= 300; they lie at x " in err
    assert "camera" not in err


# --- 3. a slice off the volume -------------------------------------------------------------------
def slice_network(**properties) -> Network:
    network = Network()
    network.add(GivenVolume(id="src", volume=Volume(ball())))
    network.add("SliceViewer", id="sv", **properties)
    network.connect("src.volume", "sv.volume")
    return network


def test_a_slice_off_the_volume_names_the_cursor():
    message = blank_warning(slice_network(cursor=(11.5, 11.5, 300.0)), "sv.image")
    assert message == ("sv (SliceViewer) rendered an empty image: its slice misses the volume: the plane "
                       "lies at z = 300, and the volume's cells span z -0.5 .. 23.5; move sv.cursor into "
                       "the volume (None: its centre)")


def test_a_slice_through_a_transparent_transfer_function_names_it_not_the_cursor():
    message = blank_warning(slice_network(mapping="tf", transfer_function=TRANSPARENT), "sv.image")
    assert "sv.transfer_function is transparent at every intensity" in message
    assert "cursor" not in message


def test_a_slice_through_the_volume_does_not_warn(recwarn):
    slice_network().evaluate("sv.image", size=SIZE)
    assert not [w for w in recwarn if issubclass(w.category, BlankImageWarning)]


# --- 4. the camera -----------------------------------------------------------------------------
@pytest.mark.parametrize("camera, where", [
    (AWAY, "behind the camera"),
    (Camera(position=(11.5, 11.5, 60.0), focus=(11.5, 11.5, 11.5), near=1.0, far=20.0),
     "beyond its far plane (far = 20)"),
    (Camera(position=(200.0, 11.5, 60.0), focus=(200.0, 11.5, 11.5)), "left of its view"),
    (Camera(position=(11.5, 11.5, 60.0), focus=(11.5, 11.5, 11.5), near=56.0, far=100.0),
     "nearer than its near plane (near = 56)"),
])
def test_a_camera_that_does_not_see_the_visible_voxels_is_named_with_where_they_lie(camera, where):
    message = blank_warning(ball_network(camera))
    assert re.match(r"rc \(RayCaster\) rendered an empty image although \d+% of the voxels are visible "
                    r"under the transfer function: seen from eep\.camera \(at ", message), message
    assert f"they lie {where}, at x 5 .. 18, y 5 .. 18, z 5 .. 18; turn eep.camera toward them" in message
    blames_only(message, "camera")


def test_a_camera_that_sees_the_volume_as_a_speck_says_so():
    volume = Volume(ball(), spacing=(1e-4,) * 3)
    message = blank_warning(ball_network(Camera(position=(0.0, 0.0, 100.0)), volume))
    assert "seen from eep.camera" in message and "under one pixel across" in message


def test_a_mesh_seen_from_behind_names_the_renderers_own_camera():
    network = Network()
    network.add(GivenVolume(id="src", volume=Volume(ball())))
    network.add("VolumeToTetMesh", id="tets")
    network.add("ProjectedTetrahedra", id="pt", camera=AWAY)
    network.connect("src.volume", "tets.volume")
    network.connect("tets.mesh", "pt.mesh")
    message = blank_warning(network, "pt.image")
    assert "% of the tetrahedra are visible under the transfer function: seen from pt.camera" in message
    assert "they lie behind the camera" in message
    network.set("pt.transfer_function", TRANSPARENT)
    message = blank_warning(network, "pt.image")
    assert "pt.transfer_function is transparent at every intensity" in message and "camera" not in message


# --- where the shown voxels lie -----------------------------------------------------------------
def test_the_shown_voxels_lie_where_the_volumes_direction_puts_them():
    """A volume turned 90 degrees about z (index x along world y, index y along world -x)."""
    turned = Volume(ball(), direction=((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                    origin=(100.0, 0.0, 0.0))
    shown = voxels_under("volume", turned, TransferFunction(**RAMP))
    presence = shown.presence([ClipPlane(normal=(1, 0, 0), point=(90, 0, 0))], None)
    # world x = 100 - j, y = i, z = k; every index 0 .. 23 holds a voxel above 0 on each axis
    np.testing.assert_array_equal(presence.low, [77.0, 0.0, 0.0])
    np.testing.assert_array_equal(presence.high, [100.0, 23.0, 23.0])
    assert presence.reach[0] == (-13.0, 10.0) and presence.kept > 0  # x >= 90 keeps the side near the origin


# --- time series -------------------------------------------------------------------------------
def four_d_nifti(path, steps=5):
    data = np.stack([ball(t + 1.0) for t in range(steps)])  # [t, z, y, x]
    nib.save(nib.Nifti1Image(np.ascontiguousarray(data.T), np.eye(4)), str(path))
    return path


def test_vgraph_run_of_a_4d_file_says_once_which_time_point_it_shows(tmp_path, capsys):
    path = four_d_nifti(tmp_path / "series.nii.gz")
    assert main(["run", str(path), "-o", str(tmp_path / "s.png")]) == 0
    lines = capsys.readouterr().err.splitlines()
    note = (f"vgraph: warning: source shows t = 0 of 5 time points of {path}; choose with "
            f"source.time_step (0 .. 4)")
    assert lines.count(note) == 1, lines
    assert main(["run", str(path), "-o", str(tmp_path / "s.png"), "--set", "source.time_step=3"]) == 0
    assert "vgraph: warning: source shows t = 3 of 5 time points" in capsys.readouterr().err


def test_a_3d_file_says_nothing_of_time(tmp_path, capsys):
    path = tmp_path / "ball.nii.gz"
    nib.save(nib.Nifti1Image(np.ascontiguousarray(ball().T), np.eye(4)), str(path))
    assert main(["run", str(path), "-o", str(tmp_path / "b.png")]) == 0
    assert "time point" not in capsys.readouterr().err


def test_the_gui_status_of_the_source_names_the_time_point(tmp_path):
    import vgraph
    from vgraph.live.evaluator import data_summary
    from vgraph.time_series import time_series_notes
    network = vgraph.load(four_d_nifti(tmp_path / "series.nii.gz"))
    network.set("source.time_step", 2)
    network.update("rc.image", size=SIZE)
    assert "t = 2 of 5 time points; choose with source.time_step (0 .. 4)" in data_summary(network["source"])
    assert time_series_notes(network, skip="source.time_step") == []  # an animation over it says nothing
    assert issubclass(TimeSeriesWarning, vgraph.VGraphWarning)


# --- what each volume renderer says it shows (vgraph.gl.raycasting.shown_volume) -----------------
@pytest.mark.parametrize("type_name, properties, rule", [
    ("RayCaster", {"compositing": "dvr"}, "transfer_function"),
    ("RayCaster", {"compositing": "iso", "iso_level": 0.3}, "iso_level"),
    ("CurvatureRaycaster", {"iso_level": 0.3}, "iso_level"),
    ("CurvatureVolumeRaycaster", {}, "transfer_function"),
    ("SweepPlaneRenderer", {}, "transfer_function"),
])
def test_each_volume_renderer_says_what_its_volume_shows(type_name, properties, rule):
    processor = registry.get(type_name)(id="r", **properties)
    assert processor.visible_content() is None and processor.shown_content() == []  # no input yet
    if rule == "transfer_function":
        processor.transfer_function = TransferFunction(**HIGH_ONLY)
    processor.inputs = {"volume": Volume(ball())}  # as the scheduler hands them over
    (shown,) = processor.shown_content()
    assert (shown.port, shown.rule, shown.control) == ("volume", rule, rule)
    said = processor.visible_content()
    assert said == ("the volume's values cross the iso level 0.3" if rule == "iso_level"
                    else f"{shown.share():.0%} of the voxels are visible under the transfer function")
    assert 0.0 < shown.share() < 1.0
