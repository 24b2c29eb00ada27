"""Values at the edges of what numbers and the GL can hold: refused with a named error, or rendered
as the same scene at ordinary magnitudes. Before, a camera `far` of 1e999 or a float64 volume beyond
float32 rendered black with exit 0, and a constant volume at 3.4e38 raised ZeroDivisionError."""

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

import vgraph
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.gl_context import get_context
from vgraph.scheduler import BlankImageWarning
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume
from helpers.paths import REPO

N = 24
CAMERA = Camera(position=(11.5, 11.5, 60.0), focus=(11.5, 11.5, 11.5))


def ball() -> np.ndarray:
    z, y, x = np.mgrid[0:N, 0:N, 0:N]
    radius = np.sqrt((x - 11.5) ** 2 + (y - 11.5) ** 2 + (z - 11.5) ** 2)
    return np.clip(1.0 - radius / 12.0, 0.0, 1.0).astype(np.float32)


def render(data, mode: str, camera=CAMERA) -> np.ndarray:
    network = ray_caster_network(Volume(data), camera, compositing=mode)
    return network.evaluate("rc.image", size=(48, 48))


EXTREMES = {
    "float32 near its maximum": lambda b: b * np.float32(3.0e38),
    "float32 subnormal": lambda b: (b.astype(np.float64) * 1e-40).astype(np.float32),
    "float64 beyond float32": lambda b: b.astype(np.float64) * 1e300,
    "float64 with a huge offset": lambda b: b.astype(np.float64) * 1e300 - 5e299,
}


@pytest.mark.parametrize("mode", ["dvr", "mip", "iso"])
@pytest.mark.parametrize("name", list(EXTREMES))
def test_extreme_magnitudes_render_like_ordinary_ones(name, mode):
    expected = render(ball(), mode)
    image = render(EXTREMES[name](ball()), mode)
    # Subnormal float32 keeps ~17 bits of the ball's values; the others keep all of float32's.
    assert np.abs(image - expected).max() < (1e-4 if "subnormal" in name else 2e-6)
    assert image[..., :3].max() > 0.1


def test_a_constant_volume_at_the_float32_limit_renders_without_error():
    image = render(np.full((N, N, N), 3.4e38, np.float32), "dvr")
    assert np.isfinite(image).all()


@pytest.mark.parametrize("field, value, reason", [
    ("far", json.loads("1e999"), "finite"),
    ("parallel_scale", "Infinity", "finite"),
    ("near", float("nan"), "finite"),
    ("position", (1e300, 1e300, 1e300), "must lie within"),
    ("focus", (0.0, 0.0, -1e16), "must lie within"),
])
def test_camera_values_that_are_not_finite_or_representable_are_refused(field, value, reason):
    with pytest.raises(vgraph.PropertyError, match=rf"eep\.camera.*{field}|{reason}") as error:
        vgraph.Network().add("EntryExitPoints", id="eep", camera={**CAMERA.model_dump(), field: value})
    assert reason in str(error.value)


def test_a_network_file_with_an_infinite_camera_far_is_refused_naming_the_field(tmp_path):
    text = (REPO / "networks" / "raycast_sphere.json").read_text()
    document = json.loads(text)
    document["processors"][1]["properties"]["camera"]["far"] = 1.0
    path = tmp_path / "far.json"
    path.write_text(json.dumps(document).replace('"far": 1.0', '"far": 1e999'))
    assert main(["validate", str(path)]) == 2
    with pytest.raises(vgraph.NetworkFileError, match=r"processors\[1\]\.properties\.camera.*finite"):
        vgraph.load(path)


def test_a_huge_light_direction_lights_like_a_unit_one():
    def shaded(direction):
        network = ray_caster_network(Volume(ball()), CAMERA, compositing="iso", shading="blinn_phong",
                                     light="direction", light_direction=direction)
        return network.evaluate("rc.image", size=(48, 48))
    assert np.abs(shaded((1e308, 1e308, 1e308)) - shaded((1.0, 1.0, 1.0))).max() < 1e-6


@pytest.mark.parametrize("field, value", [("spacing", (1e308, 1.0, 1.0)), ("spacing", (1e-20, 1.0, 1.0)),
                                          ("origin", (0.0, 0.0, 1e20))])
def test_volume_geometry_outside_float32_world_coordinates_is_refused(field, value):
    with pytest.raises(vgraph.VGraphError, match=f"{field}.*outside what GL's float32"):
        Volume(ball(), **{field: value})


def test_a_volume_wider_than_the_gl_texture_limit_is_drawn_brick_by_brick_or_refused_naming_the_limit():
    """One texture cannot hold it: the texture upload names the limit; the RayCaster draws it brick
    by brick (docs/explanations/bricked-ray-casting.md) and refuses, naming the field, the modes bricks lack."""
    limit = get_context().info["GL_MAX_3D_TEXTURE_SIZE"]
    volume = Volume(np.zeros((4, 4, limit + 1), np.uint8), source="long.raw")
    with pytest.raises(vgraph.VGraphError, match=rf"long.raw: {limit + 1} x 4 x 4 voxels .* limit of "
                                                 rf"{limit} per axis \(GL_MAX_3D_TEXTURE_SIZE\)"):
        volume.texture(get_context())
    network = ray_caster_network(volume, CAMERA)
    assert network.evaluate("rc.image", size=(16, 16)).shape == (16, 16, 4)
    assert network["rc"].last_frame  # drawn from bricks (dvr: in one pass, vgraph.bricks.methods)
    network.set("rc.compositing", "first_hit")
    with pytest.raises(vgraph.ProcessorError, match=rf"rc.compositing: long.raw is drawn brick by brick "
                                                    rf"\({limit + 1} x 4 x 4 voxels") as error:
        network.update("rc.image", size=(16, 16))
    assert not error.value.internal  # exit code 2: bad input, not a bug


def test_an_empty_render_of_visible_content_warns_naming_the_renderer():
    away = Camera(position=(11.5, 11.5, 60.0), focus=(11.5, 11.5, 100.0))
    network = ray_caster_network(Volume(ball()), away)
    with pytest.warns(BlankImageWarning, match=r"rc \(RayCaster\) rendered an empty image although "
                                               r"\d+% of the voxels are visible"):
        network.evaluate("rc.image", size=(32, 32))


def test_an_empty_render_of_what_the_transfer_function_hides_names_the_transfer_function():
    hidden = {"points": [[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 0.0]]}
    network = ray_caster_network(Volume(ball()), CAMERA, transfer_function=hidden)
    with pytest.warns(BlankImageWarning, match=r"rc \(RayCaster\) rendered an empty image: "
                                               r"rc\.transfer_function is transparent at every intensity"):
        network.evaluate("rc.image", size=(32, 32))


# Found by the red team (issue 27): a TF that starts rising just after intensity 0 made the
# histogram bin of a constant volume count as visible: "100% of the voxels are visible".
RISING_AFTER_ZERO = {"points": [[0.0, 1, 1, 1, 0.0], [0.001, 1, 1, 1, 1.0], [1.0, 1, 1, 1, 1.0]]}


@pytest.mark.parametrize("value, dtype", [(7.0, np.float32), (0.0, np.uint8), (1.7e308, np.float64),
                                          (-3.4e38, np.float32)])
def test_an_empty_render_of_a_constant_volume_says_the_volume_is_constant(value, dtype):
    network = ray_caster_network(Volume(np.full((N, N, N), value, dtype)), CAMERA,
                                 transfer_function=RISING_AFTER_ZERO)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = network.evaluate("rc.image", size=(32, 32))
    assert np.all(image == image[:1, :1])
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1, messages  # no RuntimeWarning of numpy's either (1.7e308 overflowed)
    assert issubclass(caught[0].category, BlankImageWarning)
    assert f"rc (RayCaster) rendered an empty image: its volume (in memory) is constant, every " \
           f"finite voxel is {value:.7g} (intensity 0 of its value range" in messages[0]
    assert "visible" not in messages[0]


def test_a_constant_volume_the_transfer_function_shows_renders_it():
    further = Camera(position=(11.5, 11.5, 120.0), focus=(11.5, 11.5, 11.5))
    network = ray_caster_network(Volume(np.full((N, N, N), 7.0, np.float32), declared_range=(6.0, 8.0)),
                                 further, transfer_function=RISING_AFTER_ZERO)
    image = network.evaluate("rc.image", size=(32, 32))
    assert np.all(image[16, 16] == 1.0) and np.all(image[0, 0, :3] == 0.0)  # the box, opaque white


def test_vgraph_run_of_a_constant_volume_file_warns_that_it_is_constant(tmp_path):
    path = tmp_path / "constant.npy"
    np.save(path, np.full((N, N, N), 7.0, np.float32))
    run = subprocess.run([sys.executable, "-m", "vgraph", "run", str(path), "-o", str(tmp_path / "c.png")],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert f"vgraph: warning: rc (RayCaster) rendered an empty image: its volume ({path}) is constant" \
        in run.stderr
    assert "Warning" not in run.stderr.replace("vgraph: warning", "")  # no numpy warnings


def test_vgraph_run_warns_on_stderr_when_the_camera_looks_away(tmp_path, capsys):
    away = '{"position": [0, 0, -300], "focus": [0, 0, -400]}'
    assert main(["run", str(REPO / "networks" / "raycast_sphere.json"), "-o", str(tmp_path / "a.png"),
                 "--set", f"eep.camera={away}"]) == 0
    assert "vgraph: warning: rc (RayCaster) rendered an empty image" in capsys.readouterr().err


def test_b_spline_coefficients_of_values_beyond_float32_give_the_ordinary_curvature_image():
    def curvature(data):
        network = ray_caster_network(Volume(data), CAMERA, processor="CurvatureRaycaster", iso_level=0.5)
        network.add("CubicSplineProcessor", id="spline")
        for connection in network.connections_of("src"):
            network.disconnect(connection)
            network.connect("spline.volume", f"{connection.target}.{connection.inport}")
        network.connect("src.volume", "spline.volume")
        return network.evaluate("rc.curvature", size=(48, 48))
    expected, image = curvature(ball()), curvature(ball().astype(np.float64) * 1e300)
    assert np.isfinite(image).all() and (image[..., 3] == 1.0).sum() > 100
    np.testing.assert_allclose(image, expected, atol=1e-3 * np.abs(expected).max())


def test_a_flat_depth_image_is_no_reason_to_warn(recwarn):
    network = ray_caster_network(Volume(ball()), Camera(position=(11.5, 11.5, 60.0), focus=(11.5, 11.5, 100.0)))
    network.evaluate("rc.depth", size=(16, 16))
    assert not [w for w in recwarn if issubclass(w.category, BlankImageWarning)]
