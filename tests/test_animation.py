"""vgraph animate / vgraph.animation.animate: frame counts and sizes read back with imageio, frame 0
is `vgraph run`'s image, a full orbit comes back to the start, linked cameras turn once, sweeps
over integer properties, and errors before anything is rendered."""

import argparse

import imageio.v2 as imageio2
import imageio.v3 as iio
import numpy as np
import PIL.Image
import pytest

import vgraph
from vgraph import IntProperty, Outport, Processor, animation, cli
from vgraph.image import Image
from vgraph.volume import Volume

from helpers.paths import REPO

SPHERE = REPO / "networks" / "raycast_sphere.json"
TORUS = REPO / "networks" / "curvature_torus.json"


@vgraph.register
class SeriesToy(Processor):
    """A volume with `steps` time steps and an image whose grey is time_step / 10."""

    category = "Test"
    outports = [Outport("volume", Volume), Outport("image", Image)]
    time_step = IntProperty(0, min=0)
    steps = IntProperty(4, min=1)
    fail_at = IntProperty(-1, min=-1)

    def process(self):
        if self.time_step == self.fail_at:
            raise vgraph.VGraphError("deliberate failure")
        volume = Volume(np.full((2, 2, 2), self.time_step, np.float32), time_steps=self.steps)
        grey = np.full((16, 24), self.time_step / 10, np.float32)
        return {"volume": volume, "image": Image.from_numpy(self.gl, grey)}


@pytest.fixture
def vgraph_main(monkeypatch):
    """vgraph.cli.main with the animate command, whether or not cli.py adds it yet."""
    commands = next(a for a in cli.build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    if "animate" not in commands.choices:
        original = cli.build_parser

        def build_parser():
            parser = original()
            subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
            animation.add_parser(subparsers)
            return parser
        monkeypatch.setattr(cli, "build_parser", build_parser)
    return cli.main


def png(path) -> np.ndarray:
    return np.asarray(PIL.Image.open(path))


def toy_network(**properties) -> vgraph.Network:
    net = vgraph.Network()
    net.add("SeriesToy", id="toy", **properties)
    return net


def test_mp4_has_the_frames_size_and_rate_asked_for(vgraph_main, tmp_path):
    out = tmp_path / "turn.mp4"
    assert vgraph_main(["animate", str(SPHERE), "-o", str(out), "--frames", "6", "--size", "64x48",
                        "--fps", "12", "--quiet"]) == 0
    reader = imageio2.get_reader(out, format="FFMPEG")
    assert reader.get_meta_data()["fps"] == 12 and reader.get_meta_data()["codec"] == "h264"
    frames = list(reader.iter_data())  # list(reader) would ask len(), which is inf for ffmpeg
    reader.close()
    assert len(frames) == 6 and all(f.shape == (48, 64, 3) for f in frames)
    assert vgraph_main(["run", str(SPHERE), "-o", str(tmp_path / "run.png"), "--size", "64x48"]) == 0
    lossy = np.abs(frames[0].astype(float) - png(tmp_path / "run.png")[..., :3]).mean()
    assert lossy < 2.0  # H.264 at CRF 18: about a grey level on average
    assert not list(tmp_path.glob(".*tmp*"))  # the temporary file became turn.mp4


def test_png_sequence_frame_0_is_exactly_vgraph_runs_image(vgraph_main, tmp_path):
    common = ["--size", "64x48", "--set", "rc.sampling_rate=2"]
    assert vgraph_main(["run", str(SPHERE), "-o", str(tmp_path / "run.png"), *common]) == 0
    assert vgraph_main(["animate", str(SPHERE), "-o", str(tmp_path / "frames"), "--frames", "3",
                        "--quiet", *common]) == 0
    names = sorted(p.name for p in (tmp_path / "frames").iterdir())
    assert names == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    assert np.array_equal(png(tmp_path / "frames" / "frame_0000.png"), png(tmp_path / "run.png"))


def test_view_starts_the_orbit_where_vgraph_run_view_looks(vgraph_main, tmp_path):
    common = ["--size", "48x40", "--view", "left"]
    assert vgraph_main(["run", str(TORUS), "-o", str(tmp_path / "run.png"), *common]) == 0
    assert vgraph_main(["animate", str(TORUS), "-o", str(tmp_path / "frames"), "--frames", "2",
                        "--quiet", *common]) == 0
    assert np.array_equal(png(tmp_path / "frames" / "frame_0000.png"), png(tmp_path / "run.png"))


def test_a_pattern_names_the_frames(vgraph_main, tmp_path):
    pattern = tmp_path / "out" / "turn_{:03d}.png"
    assert vgraph_main(["animate", str(SPHERE), "-o", str(pattern), "--frames", "2", "--size", "32x32",
                        "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["turn_000.png", "turn_001.png"]


def test_gif_loops_with_the_frame_time_of_fps(vgraph_main, tmp_path):
    out = tmp_path / "turn.gif"
    assert vgraph_main(["animate", str(SPHERE), "-o", str(out), "--frames", "4", "--size", "40x30",
                        "--fps", "10", "--quiet"]) == 0
    frames = iio.imread(out)
    assert frames.shape == (4, 30, 40, 3)
    meta = iio.immeta(out)
    assert meta["loop"] == 0 and meta["duration"] == 100


def test_a_full_orbit_comes_back_to_the_start_and_the_network_is_restored(tmp_path):
    net = vgraph.load(TORUS)
    before = {address: net.get(address) for address in ("eep.camera", "curvature.camera")}
    assert animation.animate(net, tmp_path / "seq", orbit=720, frames=4, size=(48, 40)) == 4
    frames = [png(tmp_path / "seq" / f"frame_{i:04d}.png").astype(int) for i in range(4)]
    assert np.abs(frames[2] - frames[0]).max() <= 1      # 360 degrees
    assert np.abs(frames[1] - frames[0]).mean() > 5      # 180 degrees: another view of the torus
    assert {address: net.get(address) for address in before} == before


def test_linked_cameras_are_set_once_per_frame():
    net = vgraph.load(SPHERE)
    assert animation.camera_leaders(net) == ["eep.camera"]  # rc.camera follows through the link
    changes = []
    net.subscribe(lambda event, **details: changes.append(details.get("name"))
                  if event == "property_changed" else None)
    orbit = animation.CameraOrbit(net)
    orbit.turn(30.0)
    assert changes == ["camera", "camera"]  # eep's, then rc's through the link
    assert net.get("rc.camera") == net.get("eep.camera") != orbit.start["eep.camera"]
    unlinked = vgraph.load(SPHERE)
    unlinked.unlink("eep.camera", "rc.camera")
    assert animation.camera_leaders(unlinked) == ["eep.camera", "rc.camera"]


def test_over_an_integer_property_takes_the_volumes_time_steps(tmp_path):
    net = toy_network(steps=5)
    assert animation.animate(net, tmp_path / "seq", over="toy.time_step", target="toy.image") == 5
    greys = [png(tmp_path / "seq" / f"frame_{i:04d}.png")[0, 0, 0] for i in range(5)]
    assert greys == [round(255 * i / 10) for i in range(5)]
    assert net.get("toy.time_step") == 0  # put back


def test_over_a_range_includes_both_ends_and_can_count_down(vgraph_main, tmp_path):
    net = toy_network()
    assert animation.animate(net, tmp_path / "up", over="toy.time_step=2:4", target="toy.image") == 3
    assert animation.animate(net, tmp_path / "down", over=("toy.time_step", [3, 1]), target="toy.image") == 2
    assert png(tmp_path / "down" / "frame_0001.png")[0, 0, 0] == round(255 * 0.1)


def test_a_volume_source_time_series(tmp_path):
    """A 4D NIfTI read by VolumeSource: one frame per time step."""
    import nibabel
    data = np.zeros((16, 16, 16, 3), np.float32)
    for t in range(3):
        data[4:12, 4:12, 4 + t:8 + t, t] = 1.0  # a block moving along z
    nibabel.save(nibabel.Nifti1Image(data, np.eye(4)), tmp_path / "series.nii.gz")
    net = vgraph.load(SPHERE)
    net.remove("source")
    net.add("VolumeSource", id="source", path=str(tmp_path / "series.nii.gz"), value_range=[0.0, 1.0],
            spacing=[2 / 15] * 3, origin=[-1.0] * 3)  # where the sphere network's camera looks
    net.connect("source.volume", "eep.volume")
    net.connect("source.volume", "rc.volume")
    assert animation.animate(net, tmp_path / "seq", over="source.time_step", size=(32, 32)) == 3
    frames = [png(tmp_path / "seq" / f"frame_{i:04d}.png") for i in range(3)]
    assert not np.array_equal(frames[0], frames[2])


def test_a_failure_halfway_leaves_no_video_and_no_temporary_file(tmp_path):
    net = toy_network(fail_at=2)
    with pytest.raises(vgraph.ProcessorError, match="deliberate failure"):
        animation.animate(net, tmp_path / "series.gif", over="toy.time_step=0:3", target="toy.image")
    assert list(tmp_path.iterdir()) == []
    assert net.get("toy.time_step") == 0


@pytest.mark.parametrize("args, message", [
    (["-o", "turn.avi"], "cannot write '.avi' animations"),
    (["-o", "frames/turn_{}.txt"], "a frame pattern must end in .png"),
    (["-o", "no/such/folder/turn.mp4"], "does not exist"),
    (["-o", "turn.mp4", "--size", "63x48"], "needs an even width and height, got 63x48"),
    (["-o", "turn.gif", "--over", "rc.nope"], "rc.nope: RayCaster has no property 'nope'"),
    (["-o", "turn.gif", "--over", "rc.sampling_rate"], "rc.sampling_rate: is a float property"),
    (["-o", "turn.gif", "--over", "source.resolution=0:3"], "source.resolution: invalid value 0"),
    (["-o", "turn.gif", "--over", "source.resolution=16:x"], "expected ID.PROPERTY or ID.PROPERTY=START:STOP"),
    (["-o", "turn.gif", "--over", "source.resolution=16:18", "--frames", "5"], "frames is 5 but"),
    (["-o", "turn.gif", "--frames", "0"], "frames must be a positive integer"),
    (["-o", "turn.gif", "--fps", "0"], "fps must be a positive number"),
    (["-o", "turn.gif", "--port", "canvas.image"], "no outport 'image'"),
])
def test_bad_requests_are_refused_naming_the_problem(vgraph_main, tmp_path, monkeypatch, capsys,
                                                     args, message):
    monkeypatch.chdir(tmp_path)
    assert vgraph_main(["animate", str(SPHERE), "--quiet", *args]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []  # refused before anything was written


def test_a_network_with_an_odd_canvas_size_is_refused_for_mp4_at_the_first_frame(tmp_path):
    net = toy_network()  # 24 x 16 would do; make it odd
    net["toy"].process = lambda: {"volume": None, "image": Image.from_numpy(net["toy"].gl, np.zeros((15, 24)))}
    with pytest.raises(vgraph.VGraphError, match="even width and height, got 24x15"):
        animation.animate(net, tmp_path / "odd.mp4", frames=2, target="toy.image")
    assert list(tmp_path.iterdir()) == []


def test_the_command_line_prints_a_progress_bar_on_stderr(vgraph_main, tmp_path, capsys):
    assert vgraph_main(["animate", str(SPHERE), "-o", str(tmp_path / "t.gif"), "--frames", "2",
                        "--size", "32x32"]) == 0
    captured = capsys.readouterr()
    assert "2/2" in captured.err and "wrote 2 frames" in captured.err and captured.out == ""


def test_animate_is_listed_in_the_help(vgraph_main, capsys):
    with pytest.raises(SystemExit):
        vgraph_main(["animate", "--help"])
    assert "--over ID.PROPERTY[=START:STOP]" in capsys.readouterr().out
