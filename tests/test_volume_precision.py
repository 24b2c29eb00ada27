"""The 16-bit copy of a volume (Volume.at_precision, the ray casters' volume_precision): codes within
half a step of the stored values, clamped and non-finite values as the full-precision texture
holds them, one texture per precision, and GL images that match the CPU reference run on the
copy to the usual tolerance and the reference on the original within the quantisation error."""

import numpy as np
import pytest

from vgraph import VGraphError
from vgraph.gl_context import get_context
from vgraph.implicit import sample
from vgraph.numerics.reference_raycast import Shading, render
from vgraph.volume import SIXTEEN_BIT_CODES, SixteenBitCopy, Volume

from helpers.networks import rendering_network
from helpers.raycaster import COLOURED, IDENTITY, REFERENCE_TOLERANCE, SIZE, oblique_camera

HALF_STEP = 0.5 / SIXTEEN_BIT_CODES  # 7.6e-6: the largest quantisation error, normalised


@pytest.fixture(scope="module")
def torus():
    return sample("torus", 32, "float32")


def render_gl(volume, camera, output="image", **properties):
    return rendering_network(volume, camera, **properties).evaluate(f"rc.{output}", size=SIZE)


# --- the copy -----------------------------------------------------------------------------------
def test_codes_are_within_half_a_step_of_the_values():
    data = np.random.default_rng(3).normal(100.0, 30.0, (11, 9, 13))
    volume = Volume(data)  # float64
    copy = volume.at_precision("16bit")
    assert isinstance(copy, SixteenBitCopy) and copy.data.dtype == np.uint16
    assert copy.value_range == volume.value_range and copy.dims == volume.dims
    error = copy.normalized(copy.data) - volume.normalized(volume.data)
    assert np.abs(error).max() <= HALF_STEP * (1 + 1e-9)
    assert np.abs(error).max() > 0.5 * HALF_STEP  # it is quantised
    assert copy.data.min() == 0 and copy.data.max() == SIXTEEN_BIT_CODES  # the range's ends are exact


def test_a_range_wider_than_float64_differences():
    """hi - lo overflows for float64 data near +-1.8e308: the codes come from the scaled form."""
    data = np.array([-1.5e308, -0.5e308, 0.0, 1.5e308] * 6, dtype=np.float64).reshape(2, 3, 4)
    copy = Volume(data).at_precision("16bit")
    np.testing.assert_array_equal(copy.data[0, 0], [0, 21845, 32768, 65535])


def test_the_copy_is_made_once_and_full_precision_is_the_volume_itself(torus):
    assert torus.at_precision("16bit") is torus.at_precision("16bit")
    assert torus.at_precision("full") is torus
    copy = torus.at_precision("16bit")
    assert copy.at_precision("16bit") is copy and copy.at_precision("full") is copy
    with pytest.raises(VGraphError, match="16bit"):
        torus.at_precision("half")


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_8_and_16_bit_volumes_are_their_own_copy(dtype):
    volume = Volume(np.arange(60, dtype=dtype).reshape(3, 4, 5))
    assert volume.at_precision("16bit") is volume


def test_values_outside_the_range_and_non_finite_ones_clamp_as_in_the_full_texture():
    data = np.linspace(-1.0, 3.0, 60, dtype=np.float32).reshape(3, 4, 5)
    data[0, 0, :3] = np.nan, np.inf, -np.inf
    copy = Volume(data, declared_range=(0.0, 2.0)).at_precision("16bit")
    normalised = copy.normalized(copy.data)
    assert normalised[0, 0, 0] == 0.0 and normalised[0, 0, 1] == 1.0 and normalised[0, 0, 2] == 0.0
    assert normalised.min() == 0.0 and normalised.max() == 1.0
    inside = (data >= 0.0) & (data <= 2.0)
    np.testing.assert_allclose(normalised[inside], data[inside] / 2.0, atol=HALF_STEP * (1 + 1e-6))


def test_percentiles_and_histogram_are_the_codes_in_data_values():
    volume = Volume(np.random.default_rng(4).random((16, 16, 16)) * 50.0 - 10.0)
    copy = volume.at_precision("16bit")
    lo, hi = volume.value_range
    np.testing.assert_allclose(copy.percentiles([0, 25, 50, 99, 100]),
                               volume.percentiles([0, 25, 50, 99, 100]), atol=(hi - lo) * 2 * HALF_STEP)
    assert copy.histogram(64)[0].sum() == volume.data.size
    with pytest.raises(VGraphError, match="original"):
        copy.with_data(volume.data)


def test_one_texture_per_precision(torus):
    ctx = get_context()
    full, sixteen = torus.texture(ctx), torus.at_precision("16bit").texture(ctx)
    assert full.dtype == "f4" and sixteen.dtype == "nu2"
    assert torus.texture(ctx) is full and torus.at_precision("16bit").texture(ctx) is sixteen
    assert torus.at_precision("16bit").texture_scale_offset() == (1.0, 0.0)


# --- GL images ------------------------------------------------------------------------------------
@pytest.mark.parametrize("mode, shaded", [("dvr", False), ("dvr", True), ("mip", False)])
def test_16bit_images_match_the_reference_on_the_copy(torus, mode, shaded):
    camera = oblique_camera(torus)
    shading = dict(shading="blinn_phong") if shaded else {}
    gl = render_gl(torus, camera, compositing=mode, transfer_function=COLOURED, volume_precision="16bit",
                   **shading)
    reference = render(torus.at_precision("16bit"), camera, COLOURED, SIZE, mode=mode,
                       shading=Shading() if shaded else None)
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


def test_16bit_mip_is_within_the_quantisation_error_of_the_full_reference(torus):
    """With the identity TF a MIP pixel is the maximum intensity itself: the quantisation moves it
    by at most half a step, on top of the GL's usual difference from the reference."""
    camera = oblique_camera(torus)
    gl = render_gl(torus, camera, compositing="mip", transfer_function=IDENTITY, volume_precision="16bit")
    full = render_gl(torus, camera, compositing="mip", transfer_function=IDENTITY)
    reference = render(torus, camera, IDENTITY, SIZE, mode="mip")
    np.testing.assert_allclose(gl, reference, atol=HALF_STEP + REFERENCE_TOLERANCE)
    assert np.abs(gl - full).max() > 1e-6  # the 16-bit texture was sampled


def test_the_default_samples_the_stored_values(torus):
    network = rendering_network(torus, oblique_camera(torus))
    assert network["rc"].volume_precision == "full"
    network.evaluate("rc.image", size=SIZE)
    np.testing.assert_array_equal(
        network.evaluate("rc.image", size=SIZE),
        render_gl(torus, oblique_camera(torus), volume_precision="full"))


@pytest.mark.parametrize("mode", ["mip", "iso", "dvr"])
def test_skipping_uses_the_copy_block_ranges(torus, mode):
    """Block ranges come from the copy's codes, so skipping still changes no pixel."""
    network = rendering_network(torus, oblique_camera(torus), compositing=mode, transfer_function=COLOURED,
                                volume_precision="16bit")
    images = []
    for skipping in (True, False):
        network.set("rc.empty_space_skipping", skipping)
        images.append((network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)))
    np.testing.assert_array_equal(images[0][0], images[1][0])
    np.testing.assert_array_equal(images[0][1][..., [0, 1, 3]], images[1][1][..., [0, 1, 3]])
