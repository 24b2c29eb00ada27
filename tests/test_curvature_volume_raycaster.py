"""CurvatureVolumeRaycaster: compositing equals the RayCaster's dvr when curvature gives one colour
(the cylinder's K = 0), colour at each sample is the colour map of the normalised curvature of the
level set through it (camera inside a sphere's distance field, opaque TF), linear and exponential
normalisation, skipping, define sets, refused volume kinds, the shipped network."""

import json

import numpy as np
import pytest

from vgraph import ProcessorError
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.gl.shaders import programs
from vgraph.implicit import sample
from vgraph.transfer_function import TransferFunction

from helpers.paths import REPO
from helpers.curvature import TORUS_CAMERA, coefficients_of, colormap, curvature_network
from helpers.networks import rendering_network

SIZE = (64, 64)
BAND = [(0.0, 0.0), (0.46, 0.0), (0.5, 0.3), (0.54, 0.05), (1.0, 0.05)]  # (position, alpha)


def tf(rgb, alphas=BAND):
    return TransferFunction(points=[(x, *rgb, a) for x, a in alphas])


def volume_network(volume, camera, **properties):
    return curvature_network(volume, camera, processor="CurvatureVolumeRaycaster", **properties)


@pytest.fixture(scope="module")
def torus():
    samples = sample("torus", 48, "float32")
    return samples, coefficients_of(samples)


@pytest.mark.parametrize("rate", [1.0, 1.5])
def test_one_colour_composites_like_the_raycasters_dvr(rate):
    """Level sets of the cylinder's distance field have K = 0: with the exponential map every
    defined sample is JET(0.5); the image is then the RayCaster's dvr with that colour in the TF
    (the same samples, trilinear values and opacity correction)."""
    volume = sample("cylinder", 40, "float32")
    camera = Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(-0.3, -0.4, -1.0))
    green = tuple(colormap(np.array(0.5), "jet"))
    ours = volume_network(volume, camera, derivatives="central", curvature="gaussian",
                          normalization="exponential", attenuation=1e-3, sampling_rate=rate,
                          transfer_function=tf((1, 1, 1))).evaluate("cr.image", size=SIZE)
    theirs = rendering_network(volume, camera, sampling_rate=rate,
                               transfer_function=tf(green)).evaluate("rc.image", size=SIZE)
    assert theirs[..., 1].max() > 0.5  # the cylinder is in the picture
    np.testing.assert_allclose(ours, theirs, atol=1e-5)


@pytest.mark.parametrize("classification", [{"gradient_opacity": {"points": [[0.0, 0.0], [1.0, 0.5]]}},
                                            {"transfer_function_2d": "two-materials"}])
def test_gradient_classification_composites_like_the_raycasters(classification):
    """As above, with the RayCaster's gradient opacity or 2D TF alpha (its colour is curvature's):
    the RayCaster's image with them matches the CPU reference (test_gradient_classification)."""
    volume = sample("cylinder", 40, "float32")
    camera = Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(-0.3, -0.4, -1.0))
    green = tuple(colormap(np.array(0.5), "jet"))
    ours = volume_network(volume, camera, derivatives="central", curvature="gaussian",
                          normalization="exponential", attenuation=1e-3, transfer_function=tf((1, 1, 1)),
                          **classification).evaluate("cr.image", size=SIZE)
    if "transfer_function_2d" in classification:  # the 2D TF in the RayCaster's colour
        from vgraph.transfer_function_2d import PRESETS
        classification = {"transfer_function_2d": PRESETS["two-materials"].model_copy(update={"primitives": [
            primitive.with_color((*green, primitive.color[3]))
            for primitive in PRESETS["two-materials"].primitives]})}
    theirs = rendering_network(volume, camera, transfer_function=tf(green),
                               **classification).evaluate("rc.image", size=SIZE)
    plain = rendering_network(volume, camera, transfer_function=tf(green)).evaluate("rc.image", size=SIZE)
    assert theirs[..., 1].max() > 0.05 and np.abs(theirs - plain).max() > 0.05  # visible, and classified
    np.testing.assert_allclose(ours, theirs, atol=1e-5)


def test_gradient_classification_is_refused_for_spline_coefficients(torus):
    _, coefficients = torus
    network = volume_network(coefficients, TORUS_CAMERA, derivatives="tricubic", gradient_opacity="boundaries")
    with pytest.raises(ProcessorError, match=r"cr.derivatives: gradient_opacity and transfer_function_2d "
                                             r"read the gradients of voxel samples"):
        network.evaluate("cr.image", size=SIZE)


@pytest.mark.parametrize("normalization", ["exponential", "linear"])
def test_sample_colour_is_the_colour_map_of_its_curvature(normalization):
    """Inside the sphere's distance field f = r - |p| the level set through p is the sphere of
    radius |p|: k1 = k2 = 1/|p|. With the camera inside and an opaque TF each ray stops at its
    first sample, on the near plane: its colour is JET(k_n(1/|p|)); linear normalisation takes
    kmax = max 1/|p| over the image (kmin = 0, all positive). Measured max colour error 5.5e-4
    (exponential), 1.5e-3 (linear: JET is steep near 1), from the spline's curvature error."""
    coefficients = coefficients_of(sample("sphere", 64, "float32"))
    camera = Camera(position=(0.0, 0.0, 0.0), focus=(1.0, 0.3, 0.2), near=0.5, far=5.0, fov=50)
    network = volume_network(coefficients, camera, derivatives="tricubic", curvature="k1",
                             normalization=normalization, attenuation=0.2,
                             transfer_function=tf((1, 1, 1), [(0.0, 1.0), (1.0, 1.0)]))
    image = network.evaluate("cr.image", size=SIZE)
    depth = network.evaluate("cr.depth", size=SIZE)
    assert np.all(depth[..., 2] == 1.0) and np.all(depth[..., 1] < 1e-6)  # one sample, on the near plane
    origins, _ = camera.rays(*SIZE)
    k = 1.0 / np.linalg.norm(origins, axis=-1)
    kn = (0.5 + 0.5 * k / k.max() if normalization == "linear"
          else 1.0 - 0.5 * np.exp(-k * 0.2))
    np.testing.assert_allclose(image[..., :3], colormap(kn, "jet"), atol=4e-3)
    assert np.all(image[..., 3] == 1.0)


@pytest.mark.parametrize("mode", ["tricubic", "central"])
def test_empty_space_skipping_changes_no_pixel(torus, mode):
    volume = torus[1] if mode == "tricubic" else torus[0]
    images = [volume_network(volume, TORUS_CAMERA, derivatives=mode, empty_space_skipping=skipping)
              .evaluate("cr.image", size=SIZE) for skipping in (True, False)]
    assert images[0][..., :3].max() > 0.3
    np.testing.assert_array_equal(images[0], images[1])


def test_outputs_are_finite_and_the_depth_marks_the_first_visible_sample(torus):
    network = volume_network(torus[1], TORUS_CAMERA)
    image = network.evaluate("cr.image", size=SIZE)
    depth = network.evaluate("cr.depth", size=SIZE)
    assert np.isfinite(image).all() and np.isfinite(depth).all()
    covered = depth[..., 3] == 1.0
    assert 0 < covered.sum() < SIZE[0] * SIZE[1]
    assert np.all(image[~covered] == [0.0, 0.0, 0.0, 1.0])  # nothing with opacity: background
    assert np.all(image[covered, :3].max(axis=-1) > 0.0)


def test_define_sets_and_recompiles(torus):
    network = volume_network(torus[1], TORUS_CAMERA, derivatives="tricubic_fast")
    processor = network["cr"]
    network.set("cr.shading", "blinn_phong")
    network.evaluate("cr.image", size=(16, 16))
    range_pass, colour_pass = (one.defines for one in processor.passes)
    assert range_pass["RANGE_PASS"] and not colour_pass["RANGE_PASS"]
    assert "SHADING_BLINN_PHONG" not in range_pass and colour_pass["SHADING_BLINN_PHONG"]
    assert not colour_pass["OPACITY_CORRECTION"]
    network.set("cr.sampling_rate", 2.0)
    network.evaluate("cr.image", size=(16, 16))
    assert processor.passes[1][1]["OPACITY_CORRECTION"]
    before = programs.compile_count
    network.set("cr.attenuation", 3.0)  # uniforms and textures only
    network.set("cr.colormap", "viridis")
    network.set("cr.transfer_function", tf((1, 1, 1), [(0.0, 0.0), (0.45, 0.0), (0.5, 0.5), (1.0, 0.1)]))
    network.evaluate("cr.image", size=(16, 16))
    assert programs.compile_count == before
    network.set("cr.normalization", "exponential")  # one pass, a new define set
    network.evaluate("cr.image", size=(16, 16))
    assert programs.compile_count == before + 1


def test_wrong_volume_kinds_are_refused(torus):
    with pytest.raises(ProcessorError, match="insert a CubicSplineProcessor"):
        volume_network(torus[0], TORUS_CAMERA, derivatives="tricubic").evaluate("cr.image", size=(8, 8))
    with pytest.raises(ProcessorError, match="disable or remove the CubicSplineProcessor"):
        volume_network(torus[1], TORUS_CAMERA, derivatives="filtered").evaluate("cr.image", size=(8, 8))


def test_curvature_volume_network_renders_from_the_cli(tmp_path):
    path = REPO / "networks" / "curvature_volume.json"
    document = json.loads(path.read_text())
    assert [p["type"] for p in document["processors"]] == [
        "FunctionSelector", "CubicSplineProcessor", "EntryExitPoints", "CurvatureVolumeRaycaster",
        "Canvas"]
    out = tmp_path / "image.npy"
    assert main(["run", str(path), "--size", "96x80", "--npy", str(out)]) == 0
    image = np.load(out)
    assert image.shape == (80, 96, 4) and np.isfinite(image).all()
    assert image[25:55, 30:66, :3].max() > 0.5
    np.testing.assert_allclose(image[[0, 0, -1, -1], [0, -1, 0, -1], :3], 0.0, atol=1e-6)
