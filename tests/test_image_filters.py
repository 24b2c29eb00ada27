"""The image filters (ImageBlur, EdgeDetect, DepthDarkening: GL fragment passes) against scipy.ndimage
on synthetic images of odd, non-square sizes and on the ray-cast CT head: the GL image equals the
float64 reference within TOLERANCE (float32 arithmetic on values in [0, 1]; the measured error is
about 1e-6), keeps its size, refuses bad values by processor and property, and holds its GL
textures constant over repeated evaluation."""

import numpy as np
import pytest
import scipy.ndimage as ndi

import vgraph
from vgraph.image import Image
from vgraph.leaks import repeated_evaluations

from helpers.paths import REPO

TOLERANCE = 1e-5
LUMINANCE = np.array([0.30, 0.59, 0.11])


def gaussian(channel, sigma):
    return ndi.gaussian_filter(np.asarray(channel, np.float64), sigma, mode="nearest", truncate=4.0)


def blurred(rgba, sigma):
    return np.stack([gaussian(rgba[..., c], sigma) for c in range(rgba.shape[-1])], axis=-1)


def sobel_magnitude(values):
    values = np.asarray(values, np.float64)
    return np.hypot(ndi.sobel(values, 0, mode="nearest"), ndi.sobel(values, 1, mode="nearest"))


def depth_darkened(rgba, depth_red, sigma, strength):
    depth = np.asarray(depth_red, np.float64)
    span = depth.max() - depth.min()
    normalised = (depth - depth.min()) / (span if span > 0 else 1.0)
    delta = gaussian(normalised, sigma) - normalised
    return np.concatenate([np.maximum(rgba[..., :3] + strength * np.minimum(delta, 0.0)[..., None], 0.0),
                           rgba[..., 3:]], axis=-1)


def run(processor_type, gl, **images_and_values):
    images = {k: Image.from_numpy(gl, v) for k, v in images_and_values.items() if isinstance(v, np.ndarray)}
    values = {k: v for k, v in images_and_values.items() if k not in images}
    return vgraph.registry.get(processor_type)(**values).process(**images).to_numpy()


@pytest.fixture
def noise():
    """Premultiplied RGBA noise, 37 rows by 53 columns (odd and not square: a swapped axis shows)."""
    rng = np.random.default_rng(35)
    rgba = rng.random((37, 53, 4)).astype(np.float32)
    rgba[..., :3] *= rgba[..., 3:]
    return rgba


@pytest.fixture(scope="module")
def head():
    """The shipped networks/depth_cues_head.json at 96 x 80 pixels: the ray-cast CT head over white
    (raycast_head.json's ray caster), its depth, and what the network's DepthDarkening made of them."""
    network = vgraph.load(REPO / "networks" / "depth_cues_head.json")
    ports = ("rc.image", "rc.depth", "darken.image", "contours.image")
    network.update(*ports, size=(96, 80))
    return tuple(network.output(port).to_numpy() for port in ports)


@pytest.mark.parametrize("sigma", [0.0, 0.6, 2.0, 7.5, 30.0])  # 30: the kernel is wider than the image
def test_image_blur_equals_scipy_gaussian_filter(gl, noise, sigma):
    result = run("ImageBlur", gl, image=noise, sigma=sigma)
    assert result.shape == noise.shape
    np.testing.assert_allclose(result, blurred(noise, sigma), atol=TOLERANCE)


def test_image_blur_of_the_ray_cast_head(gl, head, data_dir):
    image, *_ = head
    result = run("ImageBlur", gl, image=image, sigma=3.0)
    assert result.shape == image.shape == (80, 96, 4)
    np.testing.assert_allclose(result, blurred(image, 3.0), atol=TOLERANCE)
    assert np.abs(result - image).max() > 0.1  # the head's outline did blur


def test_a_blurred_transparent_background_stays_transparent(gl):
    square = np.zeros((31, 31, 4), np.float32)
    square[10:21, 10:21] = (0.8, 0.4, 0.2, 1.0)  # premultiplied, opaque
    result = run("ImageBlur", gl, image=square, sigma=2.0)
    covered = result[..., 3] > 1e-3
    # premultiplied stays premultiplied: un-premultiplying gives the square's own colour everywhere
    np.testing.assert_allclose(result[covered][:, :3] / result[covered][:, 3:], [[0.8, 0.4, 0.2]] * covered.sum(),
                               atol=1e-4)
    assert result[0, 0, 3] == 0.0


@pytest.mark.parametrize("channel", ["luminance", "alpha", "red"])
def test_edge_magnitude_equals_scipy_sobel(gl, noise, channel):
    values = {"luminance": noise[..., :3] @ LUMINANCE, "alpha": noise[..., 3], "red": noise[..., 0]}[channel]
    result = run("EdgeDetect", gl, image=noise, channel=channel, overlay=False, scale=0.5)
    assert result.shape == noise.shape
    np.testing.assert_allclose(result[..., :3], np.repeat(0.5 * sobel_magnitude(values)[..., None], 3, -1),
                               atol=TOLERANCE)
    assert (result[..., 3] == 1.0).all()


def test_a_unit_step_gives_an_edge_of_one_at_the_default_scale(gl):
    step = np.zeros((16, 16), np.float32)
    step[:, 8:] = 1.0
    result = run("EdgeDetect", gl, image=step, overlay=False)
    np.testing.assert_allclose(result[:, 7:9, 0], 1.0, atol=TOLERANCE)
    np.testing.assert_allclose(result[:, :6, 0], 0.0, atol=TOLERANCE)


def test_edges_over_the_ray_cast_head(gl, head, data_dir):
    image, *_ = head
    colour = np.array([0.0, 0.2, 1.0, 0.8])
    result = run("EdgeDetect", gl, image=image, scale=0.5, edge_color=tuple(colour))
    coverage = np.clip(0.5 * sobel_magnitude(image[..., :3] @ LUMINANCE), 0.0, 1.0)[..., None] * colour[3]
    expected = np.concatenate([colour[:3] * coverage, coverage], axis=-1) + (1.0 - coverage) * image
    assert result.shape == image.shape
    np.testing.assert_allclose(result, expected, atol=TOLERANCE)
    assert coverage.max() > 0.5  # the head has contours to draw


def test_contours_of_the_depth_over_the_colour_image(gl, head, data_dir):
    image, depth, darkened, shipped = head
    result = run("EdgeDetect", gl, image=image, edges_of=depth, channel="red", scale=20.0)
    coverage = np.clip(20.0 * sobel_magnitude(depth[..., 0]), 0.0, 1.0)[..., None]
    expected = np.concatenate([0.0 * image[..., :3], coverage], axis=-1) + (1.0 - coverage) * image
    np.testing.assert_allclose(result, expected, atol=TOLERANCE)
    assert (coverage[..., 0] == 1.0).any() and (coverage[..., 0] == 0.0).mean() > 0.5  # the outline, not all
    # the shipped network's picture: its contours (scale 3, dark brown) over the darkened image
    colour = np.array([0.1, 0.05, 0.0])
    coverage = np.clip(3.0 * sobel_magnitude(depth[..., 0]), 0.0, 1.0)[..., None]
    expected = np.concatenate([colour * coverage, coverage], axis=-1) + (1.0 - coverage) * darkened
    np.testing.assert_allclose(shipped, expected, atol=TOLERANCE)


def test_edges_of_an_image_of_another_size_are_refused(gl, noise):
    with pytest.raises(vgraph.VGraphError, match=r"edgeDetect: image \(53x37\) and edges_of \(20x10\) must have one size"):
        run("EdgeDetect", gl, image=noise, edges_of=np.ones((10, 20), np.float32))


def test_depth_darkening_equals_the_unsharp_masked_depth(gl, noise):
    depth = np.ones((37, 53, 4), np.float32)  # 1: no sample (the background is far)
    depth[8:30, 12:45, 0] = np.linspace(0.2, 0.6, 33, dtype=np.float32)
    result = run("DepthDarkening", gl, image=noise, depth=depth, sigma=3.0, strength=2.0)
    expected = depth_darkened(noise, depth[..., 0], 3.0, 2.0)
    assert result.shape == noise.shape
    np.testing.assert_allclose(result, expected, atol=TOLERANCE)
    assert (result[..., :3] < noise[..., :3] - 0.05).any()  # the halo behind the near square


def test_depth_darkening_of_the_ray_cast_head(gl, head, data_dir):
    image, depth, shipped, _ = head
    result = run("DepthDarkening", gl, image=image, depth=depth, sigma=4.0, strength=1.5)
    np.testing.assert_allclose(result, depth_darkened(image, depth[..., 0], 4.0, 1.5), atol=TOLERANCE)
    assert (result <= image + TOLERANCE).all() and (result[..., :3] < image[..., :3] - 0.05).any()
    # the shipped network's own settings (sigma 12, strength 1.5): the white background darkens
    # around the head's outline (the halo) and stays almost white far from it
    np.testing.assert_allclose(shipped, depth_darkened(image, depth[..., 0], 12.0, 1.5), atol=TOLERANCE)
    background = depth[..., 3] == 0
    assert (shipped[background][:, :3] < 0.8).any() and (shipped[0, 0, :3] > 0.99).all()


def test_one_depth_throughout_leaves_the_image_as_it_is(gl, noise):
    result = run("DepthDarkening", gl, image=noise, depth=np.full((37, 53), 0.5, np.float32))
    np.testing.assert_allclose(result, noise, atol=TOLERANCE)


@pytest.mark.parametrize("processor_type, name, value, reason", [
    ("ImageBlur", "sigma", -1.0, "greater than or equal to 0"),
    ("ImageBlur", "sigma", 65.0, "less than or equal to 64"),
    ("ImageBlur", "sigma", float("nan"), "finite number"),
    ("EdgeDetect", "scale", -0.5, "greater than or equal to 0"),
    ("EdgeDetect", "channel", "green", "luminance.*alpha.*red"),
    ("DepthDarkening", "sigma", -2.0, "greater than or equal to 0"),
    ("DepthDarkening", "strength", -1.0, "greater than or equal to 0"),
])
def test_bad_values_are_refused_naming_processor_and_property(processor_type, name, value, reason):
    network = vgraph.Network()
    network.add(processor_type, id="filter")
    with pytest.raises(vgraph.PropertyError, match=rf"^filter\.{name}: .*{reason}"):
        network.set(f"filter.{name}", value)


def test_depth_darkening_refuses_a_depth_image_of_another_size(gl, noise):
    with pytest.raises(vgraph.VGraphError, match=r"depthDarkening: image \(53x37\) and depth \(20x10\) must have one size"):
        run("DepthDarkening", gl, image=noise, depth=np.ones((10, 20), np.float32))


def test_depth_darkening_refuses_a_depth_that_is_not_a_number(gl, noise):
    depth = np.ones((37, 53), np.float32)
    depth[3, 4] = np.nan
    with pytest.raises(vgraph.VGraphError, match=r"depthDarkening\.depth: .*not finite"):
        run("DepthDarkening", gl, image=noise, depth=depth)


def test_the_filters_hold_their_textures_over_repeated_evaluation():
    """ImageSource -> ImageBlur -> EdgeDetect -> DepthDarkening (the blur as depth) -> Canvas."""
    network = vgraph.load(REPO / "networks" / "grayscale.json")
    network.remove("gray")
    for type_name, id in (("ImageBlur", "blur"), ("EdgeDetect", "edges"), ("DepthDarkening", "darken")):
        network.add(type_name, id=id)
    for source, target in (("source.image", "blur.image"), ("blur.image", "edges.image"),
                           ("edges.image", "darken.image"), ("blur.image", "darken.depth"),
                           ("darken.image", "canvas.image")):
        network.connect(source, target)
    samples = repeated_evaluations(network, 120, size=(32, 32), every=20)
    after_warm_up = [s.textures for s in samples if s.evaluation >= 40]
    assert max(after_warm_up) <= after_warm_up[0], samples
