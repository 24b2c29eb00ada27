"""ImageSource, Grayscale, ImageWriter and Canvas: pixels against the formulas."""

import numpy as np
import PIL.Image
import pytest

import vgraph
from vgraph import Network, ProcessorError

from helpers.paths import REPO

WHEEL = REPO / "networks" / "data" / "color_wheel.png"


def reference_gray(rgba: np.ndarray, saturation: float) -> np.ndarray:
    luminance = 0.30 * rgba[..., 0] + 0.59 * rgba[..., 1] + 0.11 * rgba[..., 2]
    out = rgba.copy()
    out[..., :3] = luminance[..., None] * (1 - saturation) + rgba[..., :3] * saturation
    return out


def gray_network(path=WHEEL, saturation=0.0):
    network = Network()
    network.add("ImageSource", id="source", path=str(path))
    network.add("Grayscale", id="gray", saturation=saturation)
    network.add("Canvas", id="canvas")
    network.connect("source.image", "gray.image")
    network.connect("gray.image", "canvas.image")
    return network


@pytest.mark.parametrize("saturation", [0.0, 0.3, 1.0])
def test_grayscale_pixels_equal_the_formula(saturation):
    original = np.asarray(PIL.Image.open(WHEEL).convert("RGBA")).astype(np.float32) / 255
    result = gray_network(saturation=saturation).evaluate("canvas", size=original.shape[1::-1])  # not resampled
    assert result.shape == original.shape
    np.testing.assert_allclose(result, reference_gray(original, saturation), atol=2e-6)


def test_image_source_keeps_row_order_and_16_bit(tmp_path):
    ramp = (np.arange(6 * 4, dtype=np.uint16).reshape(6, 4) * 2500)
    PIL.Image.fromarray(ramp).save(tmp_path / "ramp16.png")
    network = gray_network(tmp_path / "ramp16.png", saturation=1.0)
    pixels = network.evaluate("source.image")
    np.testing.assert_allclose(pixels[..., 0], ramp / 65535.0, atol=1e-6)


@pytest.mark.parametrize("content, message", [(None, "file not found"), (b"garbage", "not a readable PNG")])
def test_image_source_errors_name_file_and_property(tmp_path, content, message):
    path = tmp_path / "broken.png"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ProcessorError, match=rf"'source' \(ImageSource\): .*broken.png: {message}.*source.path"):
        gray_network(path).update()


def test_image_writer_writes_8_bit_png_atomically(tmp_path):
    network = gray_network(saturation=0.0)
    network.add("ImageWriter", id="writer", path=str(tmp_path / "gray.png"))
    network.connect("gray.image", "writer.image")
    network.update("writer")
    written = np.asarray(PIL.Image.open(tmp_path / "gray.png"))
    expected = np.round(np.clip(network.output("gray.image").to_numpy(), 0, 1) * 255)
    assert written.dtype == np.uint8 and written.shape[2] == 4
    np.testing.assert_array_equal(written, expected)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gray.png"]


def test_image_writer_refuses_other_suffixes(tmp_path):
    network = gray_network()
    network.add("ImageWriter", id="writer", path=str(tmp_path / "gray.jpg"))
    network.connect("gray.image", "writer.image")
    with pytest.raises(ProcessorError, match="writer.path: .* must end in .png"):
        network.update("writer")


def test_images_stay_on_the_gpu_between_processors():
    network = gray_network()
    network.update()
    assert isinstance(network.output("gray.image"), vgraph.image.Image)


# --- ImageGamma, ImageThreshold, Background, ImageMix, TextOverlay (issue 35) ------------------------
# Each GL pass against the same formula in float64 numpy on premultiplied RGBA noise of an odd,
# non-square size (a swapped axis or a flipped row shows): float32 arithmetic on values in [0, 1],
# so the GL image lies within TOLERANCE of the reference.
TOLERANCE = 1e-5
LUMINANCE = np.array([0.30, 0.59, 0.11])


@pytest.fixture
def noise():
    """Premultiplied RGBA noise, 37 rows by 53 columns, with some fully transparent pixels."""
    rng = np.random.default_rng(35)
    rgba = rng.random((37, 53, 4)).astype(np.float32)
    rgba[::5, ::7, 3] = 0.0
    rgba[..., :3] *= rgba[..., 3:]
    return rgba


def run(processor_type, gl, **images_and_values):
    """The processor alone, on numpy images uploaded; its output read back."""
    from vgraph.image import Image
    images = {k: Image.from_numpy(gl, v) for k, v in images_and_values.items() if isinstance(v, np.ndarray)}
    values = {k: v for k, v in images_and_values.items() if k not in images}
    return vgraph.registry.get(processor_type)(**values).process(**images).to_numpy()


def straight(rgba):
    alpha = rgba[..., 3:].astype(np.float64)
    return np.where(alpha > 0, rgba[..., :3] / np.where(alpha > 0, alpha, 1.0), rgba[..., :3])


def gamma_reference(rgba, gamma, tone_mapping, exposure):
    x = exposure * np.maximum(straight(rgba), 0.0)
    mapped = {"none": x, "reinhard": x / (1 + x), "exposure": 1 - np.exp(-x)}[tone_mapping] ** (1 / gamma)
    alpha = rgba[..., 3:].astype(np.float64)
    return np.concatenate([np.where(alpha > 0, mapped * alpha, mapped), alpha], axis=-1)


@pytest.mark.parametrize("gamma, tone_mapping, exposure", [
    (1.0, "none", 1.0), (2.2, "none", 1.0), (0.5, "none", 3.0),
    (1.0, "reinhard", 4.0), (2.2, "reinhard", 1.0), (1.0, "exposure", 2.0), (1.8, "exposure", 0.5)])
def test_image_gamma_equals_the_formula(gl, noise, gamma, tone_mapping, exposure):
    result = run("ImageGamma", gl, image=noise, gamma=gamma, tone_mapping=tone_mapping, exposure=exposure)
    assert result.shape == noise.shape
    np.testing.assert_allclose(result, gamma_reference(noise, gamma, tone_mapping, exposure), atol=TOLERANCE)
    np.testing.assert_array_equal(result[..., 3], noise[..., 3])  # alpha passes through bit for bit


def test_image_gamma_one_leaves_the_image_as_it_is(gl, noise):
    np.testing.assert_allclose(run("ImageGamma", gl, image=noise), noise, atol=TOLERANCE)


@pytest.mark.parametrize("channel, threshold", [("luminance", 0.3), ("red", 0.25), ("green", 0.5),
                                                ("blue", 0.1), ("alpha", 0.6)])
def test_image_threshold_equals_the_formula(gl, noise, channel, threshold):
    above, below = (1.0, 0.5, 0.0, 0.8), (0.0, 0.0, 1.0, 1.0)
    result = run("ImageThreshold", gl, image=noise, channel=channel, threshold=threshold, above=above, below=below)
    value = {"luminance": noise[..., :3] @ LUMINANCE, "red": noise[..., 0], "green": noise[..., 1],
             "blue": noise[..., 2], "alpha": noise[..., 3]}[channel]
    premultiplied = {True: (0.8, 0.4, 0.0, 0.8), False: below}
    expected = np.where((value >= threshold)[..., None], premultiplied[True], premultiplied[False])
    np.testing.assert_allclose(result, expected, atol=TOLERANCE)
    assert 0.05 < (value >= threshold).mean() < 0.95  # both sides present: a swapped test would show


def background_reference(pattern, height, width, first, second, cell):
    first, second = (np.array(c[:3] + (1.0,)) * c[3] for c in (first, second))  # premultiplied
    rows, cols = np.indices((height, width))
    if pattern == "solid":
        t = np.zeros((height, width))
    elif pattern == "gradient":
        t = (rows + 0.5) / height
    else:
        t = ((cols // cell + rows // cell) % 2).astype(float)
    return (1 - t[..., None]) * first + t[..., None] * second


@pytest.mark.parametrize("pattern", ["solid", "gradient", "checkerboard"])
def test_background_under_an_image_equals_over_of_the_pattern(gl, noise, pattern):
    first, second = (0.9, 0.8, 0.7, 1.0), (0.1, 0.2, 0.3, 0.5)
    result = run("Background", gl, image=noise, pattern=pattern, first=first, second=second, cell=5)
    back = background_reference(pattern, 37, 53, first, second, 5)
    expected = noise + (1 - noise[..., 3:]) * back
    assert result.shape == noise.shape
    np.testing.assert_allclose(result, expected, atol=TOLERANCE)


def test_background_alone_has_the_requested_size():
    network = Network()
    network.add("Background", id="back", pattern="checkerboard", cell=4,
                first=(1.0, 1.0, 1.0, 1.0), second=(0.0, 0.0, 0.0, 1.0))
    network.add("Canvas", id="canvas")
    network.connect("back.image", "canvas.image")
    result = network.evaluate("canvas", size=(30, 18))
    assert result.shape == (18, 30, 4)
    np.testing.assert_allclose(result, background_reference("checkerboard", 18, 30, (1.0, 1.0, 1.0, 1.0),
                                                            (0.0, 0.0, 0.0, 1.0), 4), atol=TOLERANCE)
    assert (result[0, 0, :3] == 1.0).all() and (result[0, 4, :3] == 0.0).all()  # white at the top left


@pytest.fixture
def other_noise():
    rng = np.random.default_rng(36)
    rgba = rng.random((37, 53, 4)).astype(np.float32)
    rgba[..., :3] *= rgba[..., 3:]
    return rgba


@pytest.mark.parametrize("mode, factor", [("mix", 0.0), ("mix", 0.3), ("mix", 1.0), ("add", 0.7),
                                          ("multiply", 1.0), ("multiply", 0.4)])
def test_image_mix_equals_the_formula(gl, noise, other_noise, mode, factor):
    a, b, f = noise.astype(np.float64), other_noise.astype(np.float64), factor
    expected = {"mix": (1 - f) * a + f * b, "add": a + f * b, "multiply": a * ((1 - f) + f * b)}[mode]
    result = run("ImageMix", gl, a=noise, b=other_noise, mode=mode, factor=factor)
    np.testing.assert_allclose(result, expected, atol=TOLERANCE)


def test_image_mix_nearer_keeps_the_pixel_of_smaller_depth(gl, noise, other_noise):
    rng = np.random.default_rng(7)
    depth_a, depth_b = rng.random((37, 53)).astype(np.float32), rng.random((37, 53)).astype(np.float32)
    depth_b[:5] = depth_a[:5]  # a tie keeps a
    result = run("ImageMix", gl, a=noise, b=other_noise, depth_a=depth_a, depth_b=depth_b, mode="nearer")
    np.testing.assert_array_equal(result, np.where((depth_b < depth_a)[..., None], other_noise, noise))


def test_image_mix_refuses_images_of_another_size(gl, noise):
    with pytest.raises(vgraph.VGraphError, match=r"^imageMix: a \(53x37\) and b \(20x10\) must have one size"):
        run("ImageMix", gl, a=noise, b=np.ones((10, 20), np.float32))


def test_image_mix_nearer_without_depths_is_refused_by_name(gl, noise):
    with pytest.raises(vgraph.VGraphError, match=r"^imageMix: mode 'nearer' needs both depth images; connect depth_b"):
        run("ImageMix", gl, a=noise, b=noise, depth_a=noise[..., 0], mode="nearer")


@pytest.mark.parametrize("processor_type, name, value, reason", [
    ("ImageGamma", "gamma", 0.0, "greater than or equal to 0.05"),
    ("ImageGamma", "tone_mapping", "filmic", "none.*reinhard.*exposure"),
    ("ImageGamma", "exposure", float("nan"), "finite number"),
    ("ImageThreshold", "channel", "hue", "luminance.*red.*green.*blue.*alpha"),
    ("ImageThreshold", "above", (1.0, 2.0, 0.0), "less than or equal to 1"),
    ("Background", "pattern", "stripes", "solid.*gradient.*checkerboard"),
    ("Background", "cell", 0, "greater than or equal to 1"),
    ("ImageMix", "factor", 1.5, "less than or equal to 1"),
    ("ImageMix", "mode", "screen", "mix.*add.*multiply.*nearer"),
    ("TextOverlay", "caption_position", "middle", "top_left.*bottom_right"),
    ("TextOverlay", "font_size", 0.0, "greater than or equal to 0.01"),
    ("TextOverlay", "scale_bar_length", -1.0, "greater than or equal to 0"),
])
def test_bad_values_are_refused_naming_processor_and_property(processor_type, name, value, reason):
    network = Network()
    network.add(processor_type, id="filter")
    with pytest.raises(vgraph.PropertyError, match=rf"^filter\.{name}: .*{reason}"):
        network.set(f"filter.{name}", value)


def orthographic(**changes):
    from vgraph.camera import Camera
    return Camera(**{"projection": "orthographic", "position": (0.0, 0.0, 100.0), "focus": (0.0, 0.0, 0.0),
                     "parallel_scale": 50.0, **changes})


def text_overlay(gl, image, volume=None, **values):
    """The TextOverlay's output and its layout."""
    from vgraph.image import Image
    overlay = vgraph.registry.get("TextOverlay")(**values)
    result = overlay.process(image=Image.from_numpy(gl, image), volume=volume).to_numpy()
    return result, overlay.last_layout


def coverage_of(gl, shape, **values):
    """What the overlay covers: its white ink over opaque black is the coverage in each channel."""
    black = np.zeros(shape, np.float32)
    black[..., 3] = 1.0
    result, layout = text_overlay(gl, black, text_color=(1.0, 1.0, 1.0, 1.0), **values)
    return result[..., 0], layout


@pytest.mark.parametrize("position", ["top_left", "top_center", "bottom_right"])
def test_a_caption_is_pillows_text_composited_over_the_image(gl, noise, position):
    import PIL.ImageDraw
    import PIL.ImageFont
    text = "CT head\n0.5 mm"
    shape = (90, 160, 4)
    coverage, layout = coverage_of(gl, shape, text=text, caption_position=position, font_size=0.15)
    # the reference: Pillow's default font at 0.15 x 90 pixels, anchored 3 % of 90 from the corner
    mask = PIL.Image.new("L", (160, 90))
    x = {"left": 3, "center": 80, "right": 157}[position.split("_")[1]]
    anchor = {"left": "l", "center": "m", "right": "r"}[position.split("_")[1]] + ("a" if position.startswith("top") else "d")
    PIL.ImageDraw.Draw(mask).multiline_text((x, 3 if position.startswith("top") else 87), text, fill=255,
                                            font=PIL.ImageFont.load_default(size=14), anchor=anchor,
                                            align=position.split("_")[1])
    np.testing.assert_allclose(coverage, np.asarray(mask) / 255.0, atol=TOLERANCE)
    left, top, right, bottom = layout.caption
    assert (coverage[top:bottom, left:right] > 0.5).any() and coverage[:top].max() == coverage[bottom:].max() == 0
    # coloured ink over the noise: "over" with that coverage, every other pixel the input's, bit for bit
    image = np.resize(noise, shape).astype(np.float32)
    ink = np.array([1.0, 0.5, 0.0, 0.8])
    result, _ = text_overlay(gl, image, text=text, caption_position=position, font_size=0.15, text_color=tuple(ink))
    front = np.concatenate([ink[:3] * ink[3], ink[3:]])[None, None, :] * coverage[..., None]
    np.testing.assert_allclose(result, front + (1 - front[..., 3:]) * image, atol=TOLERANCE)
    np.testing.assert_array_equal(result[coverage == 0], image[coverage == 0])


def bar_pixels(coverage, layout):
    """The bar's covered length in pixels, measured along its middle row."""
    left, top, right, bottom = layout.bar
    row = coverage[(top + bottom) // 2]
    return int(np.count_nonzero(row == 1.0)), np.flatnonzero(row == 1.0)


@pytest.mark.parametrize("length, scale, height", [(30.0, 50.0, 240), (7.5, 20.0, 111), (1.0, 2.5, 200)])
def test_the_scale_bar_spans_its_length_of_an_orthographic_view(gl, length, scale, height):
    coverage, layout = coverage_of(gl, (height, 400, 4), scale_bar=True, scale_bar_length=length, units="mm",
                                   camera=orthographic(parallel_scale=scale))
    pixels, columns = bar_pixels(coverage, layout)
    assert pixels == round(length * height / (2 * scale))  # the view is 2 parallel_scale high
    assert columns[-1] == 400 - 1 - max(2, round(0.03 * min(height, 400)))  # bottom right, at the margin
    assert layout.bar_label == f"{length:g} mm" and layout.bar_world_length == length


def test_an_automatic_scale_bar_is_one_two_or_five_times_a_power_of_ten(gl):
    coverage, layout = coverage_of(gl, (240, 400, 4), scale_bar=True, camera=orthographic(parallel_scale=50.0))
    world_per_pixel = 100.0 / 240
    assert layout.bar_world_length == 20.0  # a quarter of the width is 41.7 world units: 20, not 50
    assert bar_pixels(coverage, layout)[0] == round(20.0 / world_per_pixel)


def test_the_scale_bar_of_a_camera_that_fits_the_data_matches_the_rendered_box(gl):
    """The volume's box, 100 world units wide, seen from the front by an orthographic camera that
    fits the data: the entry points cover as many columns as a 100-unit scale bar is long."""
    from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
    from vgraph.volume import Volume
    volume = Volume(np.zeros((11, 31, 51), np.float32), spacing=(2.0, 2.0, 2.0))  # box 100 x 60 x 20
    camera = DEFAULT_CAMERA.model_copy(update={"projection": "orthographic", "position": (0.0, 0.0, 5.0),
                                               "focus": (0.0, 0.0, 0.0), "up": (0.0, 1.0, 0.0)})
    entry_exit = vgraph.registry.get("EntryExitPoints")(camera=camera)
    entry_exit.render_size = (160, 120)
    entry = entry_exit.process(volume=volume)["entry"]
    box_columns = int(np.count_nonzero(entry.to_numpy()[60, :, 3] > 0))
    coverage, layout = coverage_of(gl, (120, 160, 4), scale_bar=True, scale_bar_length=100.0, camera=camera,
                                   volume=volume)
    assert abs(bar_pixels(coverage, layout)[0] - box_columns) <= 1
    assert bar_pixels(coverage, layout)[0] == round(100.0 * 120 / (2 * entry_exit.view_camera.parallel_scale))


def test_a_scale_bar_under_perspective_is_refused_by_name(gl, noise):
    with pytest.raises(vgraph.PropertyError, match=r"^textOverlay\.camera: a scale bar in world units is exact only "
                                                   r"for an orthographic camera"):
        text_overlay(gl, noise, scale_bar=True, camera=orthographic(projection="perspective"))


def test_a_scale_bar_of_a_fitting_camera_without_the_volume_is_refused(gl, noise):
    from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
    camera = DEFAULT_CAMERA.model_copy(update={"projection": "orthographic"})
    with pytest.raises(vgraph.VGraphError, match=r"^textOverlay\.camera: it fits the data .*connect the rendered "
                                                 r"volume to textOverlay\.volume"):
        text_overlay(gl, noise, scale_bar=True, camera=camera)


def test_a_scale_bar_longer_than_the_image_is_refused_naming_its_length(gl, noise):
    with pytest.raises(vgraph.PropertyError, match=r"^textOverlay\.scale_bar_length: a bar of 500 world units is "
                                                   r"500 pixels long .* between 1 and 49 pixels"):
        text_overlay(gl, noise, scale_bar=True, scale_bar_length=500.0, camera=orthographic(parallel_scale=18.5))


def test_the_image_processors_hold_their_textures_over_repeated_evaluation():
    """Background -> ImageGamma -> ImageThreshold -> ImageMix (with the background) -> TextOverlay -> Canvas."""
    from vgraph.leaks import repeated_evaluations
    network = Network()
    for type_name, id in (("Background", "back"), ("ImageGamma", "gamma"), ("ImageThreshold", "threshold"),
                          ("ImageMix", "mix"), ("TextOverlay", "text"), ("Canvas", "canvas")):
        network.add(type_name, id=id)
    network.set("text.text", "caption")
    for source, target in (("back.image", "gamma.image"), ("gamma.image", "threshold.image"),
                           ("threshold.image", "mix.a"), ("back.image", "mix.b"), ("mix.image", "text.image"),
                           ("text.image", "canvas.image")):
        network.connect(source, target)
    samples = repeated_evaluations(network, 120, size=(32, 32), every=20)
    after_warm_up = [s.textures for s in samples if s.evaluation >= 40]
    assert max(after_warm_up) <= after_warm_up[0], samples


@pytest.mark.parametrize("type_name, values, reason", [
    ("TextOverlay", {"text": "caption"}, "TextOverlay 'overlay' places its caption and scale bar in the whole image"),
    ("Background", {"pattern": "gradient"}, "Background 'overlay': its gradient runs over the whole image "
                                            "(a solid background can be tiled)"),
    ("Background", {"pattern": "solid"}, None),
])
def test_overlays_placed_in_the_whole_image_are_not_rendered_tile_by_tile(type_name, values, reason):
    """vgraph run --cluster renders tiles of the picture: a caption or a gradient in each tile would be
    a wrong picture, so such a network is refused by name (a solid background tiles fine)."""
    from vgraph.distributed.tiles import untileable
    network = vgraph.load(REPO / "networks" / "raycast_sphere.json")
    network.add(type_name, id="overlay", **values)
    canvas = next(p.id for p in network.processors.values() if p.type_name == "Canvas")
    (upstream,) = network.inputs_of(canvas, "image")
    network.disconnect(upstream)
    network.connect(f"{upstream.source}.{upstream.outport}", "overlay.image")
    network.connect("overlay.image", f"{canvas}.image")
    assert untileable(network, canvas) == ([reason] if reason else [])
