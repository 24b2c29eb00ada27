"""The plug-in ray caster of docs/guide/plugins.md (tests/plugin_raycaster: a depth-coloured MIP
built from vgraph's components plus its own part) renders what it says, in a script and from the
command line with --plugin."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.registry import registry
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.paths import REPO

PLUGIN = REPO / "tests" / "plugin_raycaster"
N = 32
WHITE = (1.0, 1.0, 1.0, 1.0)


@pytest.fixture
def plugin(monkeypatch):
    """The plug-in loaded as `--plugin vgraph_depth_mip` loads it, for one test."""
    monkeypatch.syspath_prepend(str(PLUGIN))
    registry.ensure_loaded()
    monkeypatch.setattr(registry, "types", dict(registry.types))
    monkeypatch.setattr(registry, "plugins", list(registry.plugins))
    registry.load_plugin("vgraph_depth_mip")


def ridge() -> Volume:
    """A bright sheet whose depth changes with x: at voxel x its maximum is at z = 4 + 0.75 x."""
    z, _, x = np.meshgrid(*[np.arange(N, dtype=np.float64)] * 3, indexing="ij")
    return Volume(np.exp(-((z - (4.0 + 0.75 * x)) / 1.5) ** 2).astype(np.float32))


def top_camera() -> Camera:
    """Orthographic, looking down -z at the voxel centres' box [0, N - 1]^3."""
    centre = (N - 1) / 2
    return Camera(projection="orthographic", position=(centre, centre, N + 10.0), focus=(centre, centre, centre),
                  near=1.0, far=100.0, parallel_scale=N / 2)


def test_the_brightness_is_the_raycasters_mip(plugin):
    volume, camera = ridge(), top_camera()
    mip = ray_caster_network(volume, camera, "DepthColouredMip", near_colour=WHITE, far_colour=WHITE)
    ramp = TransferFunction(points=[(0.0, 1, 1, 1, 0), (1.0, 1, 1, 1, 1)])  # colour (m, m, m) over black
    reference = ray_caster_network(volume, camera, "RayCaster", compositing="mip", transfer_function=ramp,
                                   shading="none")
    got = np.asarray(mip.evaluate("rc.image", size=(40, 40)))[..., :3]
    want = np.asarray(reference.evaluate("rc.image", size=(40, 40)))[..., :3]
    assert want.max() > 0.9
    np.testing.assert_allclose(got, want, atol=2e-3)  # the RayCaster classifies through a 4096-entry LUT


def test_the_colour_says_where_the_maximum_lies(plugin):
    network = ray_caster_network(ridge(), top_camera(), "DepthColouredMip", near_colour=(1.0, 0.0, 0.0, 1.0),
                                 far_colour=(0.0, 0.0, 1.0, 1.0))
    image = np.asarray(network.evaluate("rc.image", size=(N, N)))  # one pixel per voxel column
    hit = image[..., 3] > 0.5
    where = image[..., 2] / (image[..., 0] + image[..., 2])  # 0 at the entry (top, z = N - 1), 1 at the exit
    columns = np.broadcast_to(np.arange(N, dtype=np.float64), (N, N))
    expected = (N - 1 - (4.0 + 0.75 * columns)) / (N - 1)
    assert hit[:, 2:-2].all()
    np.testing.assert_allclose(where[hit], expected[hit], atol=0.04)  # a step and the sheet's width


def test_a_network_file_runs_it_from_the_command_line_with_plugin(tmp_path):
    np.save(tmp_path / "ridge.npy", ridge().data)
    document = {
        "format": "vgraph-network", "version": 3,
        "processors": [
            {"id": "source", "type": "VolumeSource", "properties": {"path": "ridge.npy"}},
            {"id": "eep", "type": "EntryExitPoints", "properties": {"camera": json.loads(top_camera().model_dump_json())}},
            {"id": "mip", "type": "DepthColouredMip"},
            {"id": "canvas", "type": "Canvas", "properties": {"size": [24, 24]}}],
        "connections": [{"from": "source.volume", "to": "eep.volume"}, {"from": "source.volume", "to": "mip.volume"},
                        {"from": "eep.entry", "to": "mip.entry"}, {"from": "eep.exit", "to": "mip.exit"},
                        {"from": "mip.image", "to": "canvas.image"}],
        "links": [{"from": "eep.camera", "to": "mip.camera"}]}
    (tmp_path / "mip.json").write_text(json.dumps(document))
    done = subprocess.run([sys.executable, "-m", "vgraph", "run", "--plugin", "vgraph_depth_mip",
                           str(tmp_path / "mip.json"), "--npy", str(tmp_path / "out.npy")],
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(PLUGIN)})
    assert done.returncode == 0, done.stderr
    image = np.load(tmp_path / "out.npy")
    assert image[..., 3].max() > 0.9 and (image[..., 0] > image[..., 2]).any() and (image[..., 2] > image[..., 0]).any()
