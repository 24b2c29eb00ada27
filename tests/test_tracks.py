"""Keyframe tracks (vgraph.tracks) and `vgraph animate --timeline`: the file's `tracks` load, save
and refuse bad tracks naming file, track and field; cameras turn on the sphere about their focus,
transfer functions and clip planes move point by point, numbers linearly, options stepwise, with
each easing; the CLI's frames are `vgraph run`'s images of the interpolated states."""

import copy
import json
import math

import numpy as np
import PIL.Image
import pytest

import vgraph
from vgraph import animation, cli
from vgraph.camera import Camera
from vgraph.clipping import ClipPlane
from vgraph.errors import NetworkFileError
from vgraph.fileformat import build_network, network_document, parse_document
from vgraph.tracks import Keyframe, Track, duration, eased, frame_times, make_track, value_at
from vgraph.transfer_function import TransferFunction

from helpers.paths import REPO

SPHERE = REPO / "networks" / "raycast_sphere.json"
ANIMATION = REPO / "networks" / "animation_torus.json"


def document(tracks) -> dict:
    data = json.loads(SPHERE.read_text())
    data["tracks"] = tracks
    return data


def load(tracks, file="anim.json") -> vgraph.Network:
    return build_network(parse_document(document(tracks), file), file)


def camera_json(camera: Camera) -> dict:
    return json.loads(camera.model_dump_json())


START = Camera(position=(0.0, 0.0, 4.0), focus=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
TF_A = {"points": [[0.0, 0, 0, 0, 0], [0.4, 1, 0, 0, 0.2], [1.0, 1, 1, 1, 1]]}
TF_B = {"points": [[0.2, 0, 0, 1, 0], [0.6, 0, 1, 0, 0.6], [1.0, 0, 0, 0, 1]], "tf_shift": 0.0}


def track(address, *keys):
    return {"property": address, "keyframes": [dict(zip(("time", "value", "easing"), key)) for key in keys]}


# --- interpolation by kind ------------------------------------------------------------------------
def test_a_camera_orbits_its_focus_on_the_sphere_and_the_distance_moves_linearly():
    quarter = START.rotate(math.radians(90), 0.0)
    net = load([track("eep.camera", (0, camera_json(START)), (2, camera_json(quarter)))])
    halfway = value_at(net.tracks[0], net._property("eep.camera"), 1.0)
    expected = START.rotate(math.radians(45), 0.0)  # the same turn, half as far
    np.testing.assert_allclose(halfway.position, expected.position, atol=1e-12)
    np.testing.assert_allclose(halfway.up, expected.up, atol=1e-12)
    assert halfway.distance == pytest.approx(4.0)   # on the sphere, not through it (chord: 2.83)

    closer = quarter.zoom(2.0)  # distance 2 at the end: 3 halfway, on the same 45-degree ray
    net = load([track("eep.camera", (0, camera_json(START)), (2, camera_json(closer)))])
    halfway = value_at(net.tracks[0], net._property("eep.camera"), 1.0)
    assert halfway.distance == pytest.approx(3.0)
    np.testing.assert_allclose(np.asarray(halfway.position) / 3.0,
                               np.asarray(expected.position) / 4.0, atol=1e-12)


def test_a_transfer_function_moves_point_by_point():
    net = load([track("rc.transfer_function", (0, TF_A), (1, TF_B))])
    tf = value_at(net.tracks[0], net._property("rc.transfer_function"), 0.25)
    a, b = np.array(TF_A["points"]), np.array(TF_B["points"])
    np.testing.assert_allclose(tf.points, a + 0.25 * (b - a), atol=1e-12)
    assert isinstance(tf, TransferFunction) and tf.space == "normalized"


def test_clip_planes_turn_their_normal_and_move_their_point():
    planes_a = [{"normal": [0, 0, 1], "point": [0, 0, -1]}]
    planes_b = [{"normal": [1, 0, 0], "point": [0, 0, 1]}]
    net = load([track("eep.clip_planes", (0, planes_a), (1, planes_b))])
    (plane,) = value_at(net.tracks[0], net._property("eep.clip_planes"), 0.5)
    assert isinstance(plane, ClipPlane)
    np.testing.assert_allclose(plane.normal, [math.sqrt(0.5), 0, math.sqrt(0.5)], atol=1e-12)
    np.testing.assert_allclose(plane.point, [0, 0, 0], atol=1e-12)


def test_numbers_and_vectors_move_linearly_options_and_booleans_step():
    net = load([track("rc.sampling_rate", (0, 1.0), (2, 3.0)),
                track("source.resolution", (0, 16), (1, 21)),
                track("rc.light_direction", (0, [1, 0, 0]), (1, [0, 1, 0])),
                track("rc.shading", (0, "none"), (1, "blinn_phong")),
                track("rc.empty_space_skipping", (0, True), (1, False))])
    rate, resolution, light, shading, skipping = net.tracks
    prop = net._property
    assert value_at(rate, prop("rc.sampling_rate"), 0.5) == pytest.approx(1.5)
    assert value_at(resolution, prop("source.resolution"), 0.5) == 18  # 18.5 rounded to even
    assert value_at(light, prop("rc.light_direction"), 0.25) == pytest.approx((0.75, 0.25, 0.0))
    assert value_at(shading, prop("rc.shading"), 0.99) == "none"
    assert value_at(shading, prop("rc.shading"), 1.0) == "blinn_phong"
    assert value_at(skipping, prop("rc.empty_space_skipping"), 0.5) is True


def test_a_field_of_a_camera_or_a_transfer_function_animates_alone(tmp_path):
    net = load([track("rc.transfer_function.tf_shift", (0, 0.0), (2, 0.5)),
                track("eep.camera.fov", (0, 30.0), (1, 60.0, "step"))])
    tf_before, camera_before = net.get("rc.transfer_function"), net.get("eep.camera")
    from vgraph.tracks import apply_tracks
    apply_tracks(net, net.tracks, 1.0)
    assert net.get("rc.transfer_function") == tf_before.model_copy(update={"tf_shift": 0.25})  # points kept
    assert net.get("eep.camera").fov == 60.0 and net.get("eep.camera").position == camera_before.position
    net.save(tmp_path / "fields.json")
    assert vgraph.load(tmp_path / "fields.json").tracks == net.tracks
    apply_tracks(net, net.tracks, 0.0)
    before = net.get("rc.transfer_function")
    assert animation.animate(net, tmp_path / "f", timeline=True, frames=2, size=(16, 16)) == 2
    assert net.get("rc.transfer_function") == before   # put back


@pytest.mark.parametrize("address, value, message", [
    ("rc.sampling_rate.x", 1.0, "tracks[0].property: a float property has no fields"),
    ("eep.camera.zoom", 1.0, "tracks[0].property: Camera has no field 'zoom' (its fields: projection, position"),
    ("eep.camera.fov", 200.0, "tracks[0].keyframes[0].value: invalid value 200.0: Input should be less than 180"),
    ("eep.camera.fov.x.y", 1.0, "tracks[0].property: 'eep.camera.fov.x.y' is not a track address: ID.PROPERTY or"),
])
def test_bad_field_tracks_are_refused(address, value, message):
    with pytest.raises(NetworkFileError, match="anim.json: tracks") as caught:
        load([track(address, (0, value))])
    assert message in str(caught.value)


def test_easings_and_the_ends_of_a_track():
    net = load([track("rc.sampling_rate", (1, 1.0, "ease-in-out"), (3, 3.0, "step"), (4, 5.0))])
    rate, prop = net.tracks[0], net._property("rc.sampling_rate")
    assert value_at(rate, prop, 0.0) == 1.0 and value_at(rate, prop, 9.0) == 5.0  # ends hold
    assert value_at(rate, prop, 1.5) == pytest.approx(1.0 + 2.0 * eased(0.25, "ease-in-out"))
    assert eased(0.25, "ease-in-out") == pytest.approx(0.15625) and eased(0.5, "ease-in-out") == 0.5
    assert value_at(rate, prop, 2.0) == pytest.approx(2.0)   # smoothstep is symmetric
    assert value_at(rate, prop, 3.9) == 3.0                  # step holds until the next keyframe
    assert value_at(rate, prop, 4.0) == 5.0


def test_frame_times_cover_the_tracks_from_0_to_the_last_keyframe():
    tracks = [Track("a.b", (Keyframe(0.0, 0), Keyframe(1.0, 1))), Track("c.d", (Keyframe(0.5, 0),))]
    assert duration(tracks) == 1.0 and duration([]) == 0.0
    assert frame_times(tracks, 4.0) == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert frame_times(tracks, 30.0, frames=3) == [0.0, 0.5, 1.0]


# --- the file -------------------------------------------------------------------------------------
def test_tracks_are_saved_and_read_back(tmp_path):
    tracks = [track("eep.camera", (0, camera_json(START), "ease-in-out"), (2, camera_json(START.zoom(2)))),
              track("rc.transfer_function", (0, TF_A, "step"), (1, TF_B))]
    net = load(tracks)
    net.save(tmp_path / "saved.json")
    saved = json.loads((tmp_path / "saved.json").read_text())
    assert [t["property"] for t in saved["tracks"]] == ["eep.camera", "rc.transfer_function"]
    assert [k["easing"] for k in saved["tracks"][0]["keyframes"]] == ["ease-in-out", "linear"]
    again = vgraph.load(tmp_path / "saved.json")
    assert again.tracks == net.tracks
    assert "tracks" not in network_document(vgraph.load(SPHERE))  # files without tracks keep their form


@pytest.mark.parametrize("tracks, where, message", [
    ([track("nope.camera", (0, 1))], "tracks[0].property", "no processor 'nope'"),
    ([track("rc.nothing", (0, 1))], "tracks[0].property", "RayCaster has no property 'nothing'"),
    ([track("rc.sampling_rate", (1, 1.0), (0.5, 2.0))], "tracks[0].keyframes[1].time",
     "keyframes must be in order of time"),
    ([track("rc.sampling_rate", (0, 1.0)), track("eep.camera", (0, "left"))],
     "tracks[1].keyframes[0].value", "invalid value 'left'"),
    ([track("rc.sampling_rate", (1e9, 1.0))], "tracks[0].keyframes[0].time",
     "Input should be less than or equal to 86400"),
    ([track("rc.shading", (0, "none", "bounce"))], "tracks[0].keyframes[0].easing",
     "'linear', 'ease-in-out' or 'step'"),
    ([track("rc.transfer_function", (0, TF_A), (1, {"points": TF_A["points"][:2]}))],
     "tracks[0].keyframes", "keyframes 0 and 1 of rc.transfer_function cannot be interpolated: the "
                            "transfer functions have 3 and 2 points"),
    ([track("rc.transfer_function", (0, TF_A), (1, {"space": "data", "points": TF_A["points"]}))],
     "tracks[0].keyframes", "different spaces (normalized and data)"),
    ([track("eep.clip_planes", (0, []), (1, [{"normal": [0, 0, 1]}]))], "tracks[0].keyframes",
     "0 and 1 clip planes"),
])
def test_bad_tracks_are_refused_naming_file_track_and_field(tracks, where, message):
    with pytest.raises(NetworkFileError) as caught:
        load(tracks, file="anim.json")
    assert f"anim.json: {where}: " in str(caught.value)
    assert message in str(caught.value)


def test_tracks_made_in_python_are_checked_as_a_files_are(tmp_path):
    net = vgraph.load(SPHERE)
    net.tracks = (make_track(net, "eep.camera", [(0, START), (2, START.rotate(math.radians(90), 0.0), "step")]),
                  make_track(net, "rc.transfer_function", [(0, "grayscale"), {"time": 1, "value": "grayscale"}]))
    assert net.tracks[0].keyframes[1].easing == "step" and isinstance(net.tracks[1].keyframes[0].value,
                                                                      TransferFunction)
    assert animation.animate(net, tmp_path / "f", timeline=True, frames=2, size=(16, 16)) == 2
    with pytest.raises(NetworkFileError, match=r"<python>: tracks\[0\].keyframes\[1\].time: keyframes must"):
        make_track(net, "rc.sampling_rate", [(1, 1.0), (1, 2.0)])


def test_stepped_keyframes_need_not_match(tmp_path):
    net = load([track("rc.transfer_function", (0, TF_A, "step"), (1, {"points": TF_A["points"][:2]}))])
    assert len(net.tracks) == 1


# --- vgraph animate --timeline --------------------------------------------------------------------
def png(path) -> np.ndarray:
    return np.asarray(PIL.Image.open(path))


def test_timeline_frames_are_vgraph_runs_images_of_the_interpolated_states(tmp_path):
    path = tmp_path / "anim.json"
    quarter = START.rotate(math.radians(90), 0.0)
    data = document([track("eep.camera", (0, camera_json(START)), (1, camera_json(quarter))),
                     track("rc.transfer_function", (0, TF_A), (1, TF_B)),
                     track("eep.clip_planes", (0, [{"normal": [0, 0, -1], "point": [0, 0, 1]}]),
                           (1, [{"normal": [0, 0, -1], "point": [0, 0, 0]}]))])
    path.write_text(json.dumps(data))
    size = ["--size", "48x40"]
    assert cli.main(["animate", str(path), "--timeline", "--frames", "3", "-o",
                     str(tmp_path / "frames"), "--quiet", *size]) == 0
    assert sorted(p.name for p in (tmp_path / "frames").iterdir()) == [f"frame_000{i}.png" for i in range(3)]
    halfway = {"eep.camera": camera_json(START.rotate(math.radians(45), 0.0)),
               "rc.transfer_function": {"points": (0.5 * (np.array(TF_A["points"]) +
                                                          np.array(TF_B["points"]))).tolist()},
               "eep.clip_planes": [{"normal": [0, 0, -1], "point": [0, 0, 0.5]}]}
    sets = [arg for address, value in halfway.items() for arg in ("--set", f"{address}={json.dumps(value)}")]
    assert cli.main(["run", str(path), "-o", str(tmp_path / "half.png"), *size, *sets]) == 0
    frame = png(tmp_path / "frames" / "frame_0001.png").astype(int)
    # the CLI's halfway state differs from the interpolated one only by float rounding of the camera
    assert np.abs(frame - png(tmp_path / "half.png")).max() <= 1
    assert np.abs(frame - png(tmp_path / "frames" / "frame_0000.png")).max() > 50  # something moved


def test_the_timeline_puts_the_network_back_and_counts_frames_by_fps(tmp_path):
    net = vgraph.load(ANIMATION)
    before = {t.address: net.get(t.address) for t in net.tracks}
    assert animation.animate(net, tmp_path / "f", timeline=True, fps=1.0, size=(16, 16)) == 5  # 0..4 s
    assert {t.address: net.get(t.address) for t in net.tracks} == before


@pytest.mark.parametrize("args, message", [
    (["--orbit", "90"], "--timeline plays the network's tracks: leave out --orbit and --over"),
    (["--frames", "0"], "frames must be a positive integer"),
    (["--fps", "1e9"], "4 s at 1e+09 frames per second are 4000000001 frames, more than 1000000"),
])
def test_timeline_requests_are_refused_naming_the_problem(tmp_path, capsys, args, message):
    assert cli.main(["animate", str(ANIMATION), "--timeline", "-o", str(tmp_path / "x.gif"),
                     "--quiet", *args]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.gif").exists()


def test_validate_counts_the_tracks(capsys):
    assert cli.main(["validate", str(ANIMATION)]) == 0
    assert "valid (4 processors, 5 connections, 1 links, 3 tracks)" in capsys.readouterr().out


def test_a_network_without_tracks_or_with_a_bad_one_exits_2_with_one_line(tmp_path, capsys):
    assert cli.main(["animate", str(SPHERE), "--timeline", "-o", str(tmp_path / "x.gif"), "--quiet"]) == 2
    assert "the network has no tracks to play" in capsys.readouterr().err
    bad = copy.deepcopy(document([track("rc.sampling_rate", (0, "fast"))]))
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    assert cli.main(["animate", str(tmp_path / "bad.json"), "--timeline", "-o", str(tmp_path / "x.gif")]) == 2
    err = capsys.readouterr().err
    assert "bad.json: tracks[0].keyframes[0].value: invalid value 'fast'" in err
    assert "Traceback" not in err
