"""The Image port type: numpy round trips with row 0 at the top, dtype scaling, channel expansion."""

import numpy as np
import pytest

from vgraph.errors import VGraphError
from vgraph.gl_context import get_context
from vgraph.image import Image


@pytest.fixture(scope="module")
def ctx():
    return get_context()


def test_float_round_trip_keeps_values_and_row_order(ctx):
    height, width = 5, 7
    rows = np.linspace(0.0, 1.0, height, dtype=np.float32)  # row 0 (top) = 0, bottom row = 1
    array = np.zeros((height, width, 4), np.float32)
    array[..., 0] = rows[:, None]
    array[..., 1] = np.arange(width)[None, :] * 10.0  # outside [0, 1]: float is kept as is
    array[..., 2] = -2.5
    array[..., 3] = 1.0
    image = Image.from_numpy(ctx, array)
    assert image.size == (width, height)
    back = image.to_numpy()
    assert back.dtype == np.float32 and back.shape == (height, width, 4)
    assert np.array_equal(back, array)
    image.release()


def test_row_zero_is_the_top_in_gl_terms(ctx):
    # GL's texel row 0 is the bottom: the raw texture bytes start with the array's LAST row.
    array = np.zeros((3, 2, 4), np.float32)
    array[0] = (1, 0, 0, 1)  # top row red
    array[2] = (0, 0, 1, 1)  # bottom row blue
    image = Image.from_numpy(ctx, array)
    gl_rows = np.frombuffer(image.texture.read(), np.float32).reshape(3, 2, 4)
    assert np.array_equal(gl_rows[0], array[2]) and np.array_equal(gl_rows[2], array[0])
    image.release()


@pytest.mark.parametrize("dtype, full_scale", [(np.uint8, 255), (np.uint16, 65535)])
def test_unsigned_integers_are_normalised(ctx, dtype, full_scale):
    array = np.array([[[0, full_scale, full_scale // 5, full_scale]]], dtype=dtype)
    back = Image.from_numpy(ctx, array).to_numpy()
    assert np.allclose(back[0, 0], [0.0, 1.0, (full_scale // 5) / full_scale, 1.0], atol=1e-7)
    assert back[0, 0, 1] == 1.0


def test_other_numeric_types_keep_their_values(ctx):
    array = np.array([[-3, 1000]], dtype=np.int16)
    assert np.array_equal(Image.from_numpy(ctx, array).to_numpy()[0, :, 0], [-3.0, 1000.0])
    mask = np.array([[True, False]])
    assert np.array_equal(Image.from_numpy(ctx, mask).to_numpy()[0, :, 0], [1.0, 0.0])


def test_grey_and_rgb_gain_channels(ctx):
    grey = np.array([[0.25, 0.5]], np.float64)
    assert np.array_equal(Image.from_numpy(ctx, grey).to_numpy()[0],
                          [[0.25, 0.25, 0.25, 1.0], [0.5, 0.5, 0.5, 1.0]])
    assert np.array_equal(Image.from_numpy(ctx, grey[..., None]).to_numpy()[0, 1], [0.5, 0.5, 0.5, 1])
    rgb = np.array([[[10, 20, 30]]], np.uint8)
    assert np.allclose(Image.from_numpy(ctx, rgb).to_numpy()[0, 0], [10 / 255, 20 / 255, 30 / 255, 1])


def test_empty_image_is_transparent_black_and_renderable(ctx):
    image = Image.empty(ctx, (3, 2))
    assert image.size == (3, 2) and np.array_equal(image.to_numpy(), np.zeros((2, 3, 4)))
    assert image.framebuffer is image.framebuffer  # created once
    image.framebuffer.clear(0.0, 0.5, 1.0, 1.0)
    assert np.array_equal(image.to_numpy()[1, 2], [0.0, 0.5, 1.0, 1.0])
    image.release()
    with pytest.raises(VGraphError, match="released"):
        image.to_numpy()


@pytest.mark.parametrize("array, message", [
    (np.zeros((2, 2, 2)), "H x W x 1/3/4"), (np.zeros(4), "H x W x 1/3/4"),
    (np.zeros((2, 2), complex), "numeric"), (np.zeros((0, 3)), "outside 1..")])
def test_bad_arrays_are_rejected(ctx, array, message):
    with pytest.raises(VGraphError, match=message):
        Image.from_numpy(ctx, array)


def test_bad_sizes_are_rejected(ctx):
    with pytest.raises(VGraphError, match="outside 1.."):
        Image.empty(ctx, (0, 4))
    with pytest.raises(VGraphError, match="width, height"):
        Image.empty(ctx, 5)


def test_releasing_the_bound_image_leaves_no_gl_error(ctx):
    """moderngl re-binds the framebuffer it last bound after making the next one: if that one was
    released, GL_INVALID_OPERATION stayed pending and was blamed on whatever came next."""
    ctx.error  # start clean
    image = Image.empty(ctx, (3, 2))
    image.framebuffer.use()
    image.release()
    Image.empty(ctx, (3, 2)).release()
    assert ctx.error == "GL_NO_ERROR"
