"""ColorBar: the bar shows the TF / colour map at the positions it claims, labels the right range,
leaves the rest of the image alone, and refuses bad settings naming the property."""

import numpy as np
import PIL.Image
import pytest

import vgraph
from vgraph.gl.curvature import colormap_table
from vgraph.transfer_function import TransferFunction
from vgraph.processors.color_bar import curvature_scale, format_ticks

from helpers.paths import REPO

GREY = 0.2
TF = TransferFunction(points=[(0.0, 0.0, 0.0, 1.0, 0.0), (0.5, 0.0, 1.0, 0.0, 0.5),
                              (1.0, 1.0, 0.0, 0.0, 1.0)])


@pytest.fixture
def grey_png(tmp_path):
    """A uniform opaque dark grey 240 x 180 picture (8 bit: GREY * 255 = 51 is exact)."""
    path = tmp_path / "grey.png"
    PIL.Image.fromarray(np.full((180, 240, 4), [51, 51, 51, 255], np.uint8)).save(path)
    return path


def bar_network(picture, **properties):
    net = vgraph.Network()
    net.add("ImageSource", id="source", path=str(picture))
    net.add("ColorBar", id="bar", **properties)
    net.connect("source.image", "bar.image")
    return net


def bar_pixels(net):
    """The output, the input and the bar's rectangle (x, y, w, h)."""
    out = net.evaluate("bar.image")
    return out, net.evaluate("source.image"), net["bar"].last_layout.bar


def test_vertical_bar_shows_the_transfer_function_bottom_to_top(grey_png):
    net = bar_network(grey_png, transfer_function=TF, title="Density", units="g/cm3")
    out, original, (x, y, w, h) = bar_pixels(net)
    assert 60 < h <= 90  # half the height, less the room the end labels need
    column = out[y:y + h, x + w // 2]
    expected = TF(np.linspace(1.0, 0.0, h))  # top row: the high end
    np.testing.assert_allclose(column[:, :3], expected[:, :3], atol=1e-6)
    assert np.all(column[:, 3] == 1.0)  # without show_opacity the bar is opaque
    assert x + w > 240 / 2 and y < 180 / 2  # top right


def test_the_image_outside_the_bar_and_its_labels_is_untouched(grey_png):
    net = bar_network(grey_png, transfer_function=TF, title="Density")
    out, original, (x, y, w, h) = bar_pixels(net)
    changed = np.argwhere(np.any(out != original, axis=-1))
    assert changed.size
    top, left = changed.min(axis=0)
    bottom, right = changed.max(axis=0)
    assert left > 240 / 2 and bottom < 180 * 0.75  # only the top-right corner changed
    keep = np.ones(out.shape[:2], bool)
    keep[top:bottom + 1, left:right + 1] = False
    assert np.array_equal(out[keep], original[keep])  # bit for bit


def test_labels_and_title_are_drawn_in_the_text_colour(grey_png):
    net = bar_network(grey_png, transfer_function=TF, title="Density", text_color=[1.0, 1.0, 0.0])
    out, _, (x, y, w, h) = bar_pixels(net)
    labels = out[y:y + h, x + w + 2:]
    yellowish = lambda pixels: (pixels[..., 0] > 0.6) & (pixels[..., 2] < 0.15)  # on grey 0.2
    assert yellowish(labels).sum() > 50
    assert yellowish(out[:y]).sum() > 30  # the title above the bar
    texts = [text for *_, text in net["bar"].last_layout.texts]
    assert texts == ["0.00", "0.25", "0.50", "0.75", "1.00", "Density"]


def test_horizontal_colour_map_with_the_value_range_property(grey_png):
    net = bar_network(grey_png, colormap="viridis", value_range=[-40.0, 1000.0],
                      orientation="horizontal", corner="bottom_left", tick_count=3)
    out, original, (x, y, w, h) = bar_pixels(net)
    row = out[y + h // 2, x:x + w]
    table = colormap_table("viridis").astype(np.float64)
    t = np.linspace(0.0, 1.0, w)
    expected = np.stack([np.interp(t, np.linspace(0, 1, 256), table[:, c]) for c in range(3)], -1)
    np.testing.assert_allclose(row[:, :3], expected, atol=1e-6)
    assert x < 240 / 2 and y > 180 / 2
    assert [text for *_, text in net["bar"].last_layout.texts] == ["-40", "480", "1000"]


def test_a_connected_volume_gives_the_labels_its_value_range(grey_png):
    net = bar_network(grey_png)
    net.add("FunctionSelector", id="function", function="sphere", resolution=16)
    net.connect("function.volume", "bar.volume")
    net.update("bar.image")
    low, high = net["function"].outputs["volume"].value_range
    texts = [text for *_, text in net["bar"].last_layout.texts]
    assert texts[0] == format_ticks([low, high])[0] and texts[-1] == format_ticks([low, high])[1]


def test_a_transfer_function_in_data_units_is_placed_on_the_value_range(grey_png):
    tf = TransferFunction(space="data", points=[(100.0, 0.0, 0.0, 1.0, 1.0), (300.0, 1.0, 0.0, 0.0, 1.0)])
    net = bar_network(grey_png, transfer_function=tf, value_range=[0.0, 400.0])
    out, _, (x, y, w, h) = bar_pixels(net)
    values = np.linspace(400.0, 0.0, h)  # top row: the high end
    red = np.clip((values - 100.0) / 200.0, 0.0, 1.0)
    np.testing.assert_allclose(out[y:y + h, x + w // 2, 0], red, atol=1e-6)
    np.testing.assert_allclose(out[y:y + h, x + w // 2, 2], 1.0 - red, atol=1e-6)


def test_a_percentile_transfer_function_needs_the_volume(grey_png):
    tf = TransferFunction(space="percentile", points=[(5.0, 0.0, 0.0, 0.0, 0.0), (95.0, 1.0, 1.0, 1.0, 1.0)])
    net = bar_network(grey_png, transfer_function=tf)
    with pytest.raises(vgraph.ProcessorError, match=r"bar\.transfer_function: its positions are "
                                                     r"percentile values: connect the volume"):
        net.update("bar.image")
    net.add("FunctionSelector", id="function", function="sphere", resolution=16)
    net.connect("function.volume", "bar.volume")
    out, _, (x, y, w, h) = bar_pixels(net)
    volume = net["function"].outputs["volume"]
    expected = tf.for_volume(volume)(np.linspace(1.0, 0.0, h))
    np.testing.assert_allclose(out[y:y + h, x + w // 2, :3], expected[:, :3], atol=1e-6)


def test_show_opacity_puts_the_alpha_over_a_checkerboard(grey_png):
    net = bar_network(grey_png, transfer_function=TF, show_opacity=True, thickness=0.1)
    out, _, (x, y, w, h) = bar_pixels(net)
    tf = TF(np.linspace(1.0, 0.0, h))
    for col in (x, x + w - 1):  # the two columns lie on different checker cells
        pixels = out[y:y + h, col, :3]
        for grey in (0.8, 0.55):
            blended = tf[:, 3:] * tf[:, :3] + (1 - tf[:, 3:]) * grey
            matches = np.all(np.abs(pixels - blended) < 1e-6, axis=1)
            assert matches.sum() > h / 4
    assert np.all(out[y:y + h, x:x + w, 3] == 1.0)


def test_curvature_scale_of_the_torus_matches_its_analytic_range():
    """Gaussian curvature of a torus with R = 0.55, r = 0.25 runs from -1/(r (R - r)) = -13.3
    (inner equator) to 1/(r (R + r)) = 5 (outer equator); the bar's ends say so and show the ends
    of the colour map."""
    net = vgraph.load(REPO / "networks" / "curvature_torus.json")
    net.add("ColorBar", id="bar", colormap="jet", units="1/mm")
    net.connect("curvature.image", "bar.image")
    net.connect("curvature.curvature", "bar.curvature")
    net.connect("spline.volume", "bar.volume")
    net.link("curvature.curvature", "bar.measure")
    out = net.evaluate("bar.image", size=(160, 128))
    layout = net["bar"].last_layout
    texts = [text for *_, text in layout.texts]
    assert texts[-1] == "Gaussian curvature (1/mm)"
    assert float(texts[0]) == pytest.approx(-13.33, rel=0.03)
    assert float(texts[-2]) == pytest.approx(5.0, rel=0.02)
    assert float(texts[2]) == 0.0  # linear normalisation: zero in the middle
    x, y, w, h = layout.bar
    jet = colormap_table("jet")
    np.testing.assert_allclose(out[y + h - 1, x + w // 2, :3], jet[0, :3], atol=1e-6)
    np.testing.assert_allclose(out[y, x + w // 2, :3], jet[-1, :3], atol=1e-6)


def test_curvature_scales_follow_the_normalisation_shader():
    k = np.array([-2.0, 0.5, 4.0])
    linear = curvature_scale(k, "mean", "linear", 1.0)
    assert (linear.t_low, linear.t_high) == (0.0, 1.0)
    np.testing.assert_allclose(linear.value(np.array([0.0, 0.25, 0.5, 0.75, 1.0])), [-2, -1, 0, 2, 4])
    exponential = curvature_scale(k, "mean", "exponential", 0.5)
    assert exponential.t_low == pytest.approx(0.5 * np.exp(-1.0))
    assert exponential.t_high == pytest.approx(1 - 0.5 * np.exp(-2.0))
    np.testing.assert_allclose(exponential.value(np.array([exponential.t_low, 0.5, exponential.t_high])),
                               [-2, 0, 4])
    positive = curvature_scale(np.array([1.0, 3.0]), "k1", "linear", 1.0)
    assert (positive.t_low, positive.t_high) == (0.5, 1.0)  # only the upper half of the map is used
    shape = curvature_scale(np.array([-0.5, 1.0]), "shape_index", "linear", 1.0)
    assert (shape.t_low, shape.t_high) == (0.25, 1.0)


@pytest.mark.parametrize("values, texts", [
    ([0.0, 0.25, 0.5, 0.75, 1.0], ["0.00", "0.25", "0.50", "0.75", "1.00"]),
    ([0.0, 1023.75, 2047.5, 3071.25, 4095.0], ["0", "1024", "2048", "3071", "4095"]),
    ([-1e-17, 0.5], ["0.000", "0.500"]),               # no "-0.000"
    ([-13.37, -6.68, 0.0, 2.5, 5.01], ["-13.4", "-6.7", "0.0", "2.5", "5.0"]),
    ([1000.0, 1000.5, 1001.0], ["1000.0", "1000.5", "1001.0"]),  # neighbours stay apart
    ([0.0, 2.5e6, 5e6], ["0.00e+00", "2.50e+06", "5.00e+06"]),
    ([0.0, 0.0], ["0", "0"]),
])
def test_tick_labels(values, texts):
    assert format_ticks(values) == texts


def test_bad_settings_name_the_property(grey_png):
    with pytest.raises(vgraph.PropertyError, match=r"^bar\.corner: invalid value 'middle'"):
        bar_network(grey_png, corner="middle")
    with pytest.raises(vgraph.PropertyError, match=r"^bar\.tick_count"):
        bar_network(grey_png, tick_count=1)
    net = bar_network(grey_png, value_range=[1.0, 1.0])
    with pytest.raises(vgraph.ProcessorError, match=r"bar\.value_range: the low end must be below"):
        net.update("bar.image")


def test_a_curvature_image_needs_a_colour_map(grey_png):
    net = bar_network(grey_png)
    net.add("ImageSource", id="curvature", path=str(grey_png))
    net.connect("curvature.image", "bar.curvature")
    with pytest.raises(vgraph.ProcessorError, match=r"bar\.colormap: a curvature image is connected"):
        net.update("bar.image")


def test_a_tiny_image_still_gets_a_bar(tmp_path):
    path = tmp_path / "tiny.png"
    PIL.Image.fromarray(np.zeros((12, 10, 4), np.uint8)).save(path)
    net = bar_network(path, title="A long title that cannot fit")
    out = net.evaluate("bar.image")
    assert out.shape == (12, 10, 4) and np.isfinite(out).all()
