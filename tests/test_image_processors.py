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
