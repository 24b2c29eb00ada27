"""MIP with empty-space skipping (shaders/raycasting/compositing_mip.glsl: the ray's largest block
first, then only blocks that can still change the result) against the plain march: the same
image and the same depth sample, bit for bit, on a smooth volume whose maxima lie inside (torus),
CT data (bonsai), noise, plateaus with exact ties and values outside the value range (clamped),
plateaus far from zero; perspective, orthographic and a camera inside; and far fewer samples
evaluated on the torus."""

import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.implicit import sample
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import rendering_network
from helpers.paths import DATA

SIZE = (64, 48)
RAMP = TransferFunction(points=[(0.0, 0.0, 0.0, 0.2, 0.0), (0.4, 0.2, 0.5, 0.9, 0.3),
                                (1.0, 1.0, 0.9, 0.6, 1.0)])


def noise(shape=(37, 29, 41), seed=5):
    return Volume(np.random.default_rng(seed).random(shape).astype(np.float32), spacing=(1.0, 0.9, 1.2))


def plateaus():
    """Four values only (many exact ties along every ray, 1.0 among them) and a declared range
    that leaves some voxels above 1 and below 0 (clamped before the maximum is taken)."""
    data = np.random.default_rng(7).integers(0, 4, (30, 26, 34)).astype(np.uint8)
    data[:, :, 20:] = 1  # a slab of one value: ties everywhere and maxima equal to block maxima
    return Volume(data, declared_range=(0.5, 2.5))


def far_from_zero():
    """Plateaus around 1000 with a range of 1: intensities carry float32 rounding of the offset
    (6e-5), which the block maxima, computed in float64, do not."""
    steps = np.random.default_rng(8).integers(0, 4, (30, 26, 34))
    return Volume((1000.0 + steps / 3.0).astype(np.float32))


def spike_in_a_margin():
    """A constant volume with one bright voxel at x = 15, the last of block 1 and in the margin of
    block 2: rays through block 2 see only the constant under a block maximum of 1, so the block
    with the ray's largest maximum yields the constant, and the first sample holding it lies in
    the blocks in front, whose maximum equals it (the tie rule before the depth sample)."""
    data = np.full((24, 24, 24), 0.5, dtype=np.float32)
    data[12, 12, 15] = 1.0
    return Volume(data, declared_range=(0.0, 1.0))


VOLUMES = {"torus": lambda: sample("torus", 64, "float32"), "noise": noise, "plateaus": plateaus,
           "far_from_zero": far_from_zero, "spike_in_a_margin": spike_in_a_margin}


def cameras(volume):
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    inside = Camera(position=tuple(centre + 0.3 * (hi - lo) * np.array([0.2, -0.3, 0.4])),
                    focus=tuple(centre + (hi - lo) * np.array([0.5, 0.2, -0.3])),
                    near=0.01 * float(np.max(hi - lo)), far=10.0 * float(np.max(hi - lo)), fov=70)
    return {"perspective": Camera.looking_at_box(lo, hi, direction=(-0.5, -0.3, -1.0)),
            "orthographic": Camera.looking_at_box(lo, hi, direction=(0.3, -0.6, -1.0),
                                                  projection="orthographic"),
            "inside": inside}


def with_and_without_skipping(volume, camera, size=SIZE, **properties):
    """(image, depth) with empty-space skipping, then without."""
    network = rendering_network(volume, camera, compositing="mip", transfer_function=RAMP, **properties)
    outputs = []
    for skipping in (True, False):
        network.set("rc.empty_space_skipping", skipping)
        outputs.append((network.evaluate("rc.image", size=size), network.evaluate("rc.depth", size=size)))
    assert network["rc"].passes[-1][1].get("SKIP_EMPTY_SPACE") is not True  # the second one did not skip
    return outputs


def assert_same_picture(skipped, plain):
    (image, depth), (plain_image, plain_depth) = skipped, plain
    np.testing.assert_array_equal(image, plain_image)
    # depth: window depth, distance, (b = samples evaluated, differs), has a depth sample
    np.testing.assert_array_equal(depth[..., [0, 1, 3]], plain_depth[..., [0, 1, 3]])


@pytest.mark.parametrize("camera_name", ["perspective", "orthographic", "inside"])
@pytest.mark.parametrize("volume_name", list(VOLUMES))
def test_skipping_changes_neither_image_nor_depth(volume_name, camera_name):
    volume = VOLUMES[volume_name]()
    skipped, plain = with_and_without_skipping(volume, cameras(volume)[camera_name])
    assert np.ptp(plain[0][..., 0]) > 0.1  # something varied is in the picture
    assert_same_picture(skipped, plain)
    assert skipped[1][..., 2].sum() <= plain[1][..., 2].sum()


@pytest.mark.parametrize("rate", [0.5, 2.3])
def test_other_sampling_rates_and_nearest_interpolation(rate):
    volume = sample("torus", 48, "float32")
    for interpolation in ("trilinear", "nearest"):
        skipped, plain = with_and_without_skipping(volume, cameras(volume)["perspective"],
                                                   sampling_rate=rate, interpolation=interpolation)
        assert_same_picture(skipped, plain)


def test_the_torus_takes_far_fewer_samples():
    """The torus's maxima lie inside: skipping blocks front to back against the running maximum
    kept 70 % of the samples here (the maximum rises slowly along a ray); starting with the ray's
    largest block keeps 35 %."""
    volume = sample("torus", 128, "float32")
    camera = cameras(volume)["perspective"]
    skipped, plain = with_and_without_skipping(volume, camera)
    covered = plain[1][..., 3] > 0
    ratio = skipped[1][..., 2][covered].sum() / plain[1][..., 2][covered].sum()
    assert ratio < 0.45, ratio


@pytest.fixture(scope="module")
def bonsai():
    path = DATA / "ct_bonsai" / "bonsai.nii.gz"
    if not path.exists():
        pytest.skip(f"shared data not found at {path}")
    return read_volume(path)


@pytest.mark.parametrize("camera_name", ["perspective", "orthographic", "inside"])
def test_bonsai(bonsai, camera_name):
    skipped, plain = with_and_without_skipping(bonsai, cameras(bonsai)[camera_name], size=(96, 96))
    assert_same_picture(skipped, plain)
    assert skipped[1][..., 2].sum() < 0.8 * plain[1][..., 2].sum()


# --- the BrickedRayCaster's MIP (shaders/bricks/composite_mip.glsl), brick by brick -------------
@pytest.mark.parametrize("volume_name", list(VOLUMES))
def test_bricked_skipping_changes_neither_image_nor_depth(volume_name):
    from vgraph.testing import ray_caster_network
    volume = VOLUMES[volume_name]()
    for camera_name in ("perspective", "inside"):
        network = ray_caster_network(volume, cameras(volume)[camera_name], "BrickedRayCaster",
                                     compositing="mip", transfer_function=RAMP, brick_size=16, lod_bias=-16.0)
        outputs = []
        for skipping in (True, False):
            network.set("rc.empty_space_skipping", skipping)
            outputs.append((network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)))
        assert np.ptp(outputs[1][0][..., 0]) > 0.1
        np.testing.assert_array_equal(outputs[0][0], outputs[1][0])
        np.testing.assert_array_equal(outputs[0][1], outputs[1][1])
