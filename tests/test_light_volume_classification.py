"""The light volume under the ray casters' gradient classification (rule 5 of
vgraph.numerics.light_volume): a 2D TF or gradient opacity that makes a region transparent lets the
light through it, exactly as a light volume of the same voxels' opacities under a 1D TF does; off,
nothing changes."""

import numpy as np
import pytest

from vgraph.gl.raycasting.gradient_classification import largest_magnitude
from vgraph.gradient_opacity import GradientOpacity
from vgraph.network import Network
from vgraph.numerics.light_volume import light_volume
from vgraph.numerics.reference_classification import GradientClassification, largest_gradient_magnitude
from vgraph.numerics.reference_raycast import VolumeSampler
from vgraph.numerics.voxel_gradients import gradient_fractions
from vgraph.testing import GivenVolume
from vgraph.transfer_function import TransferFunction
from vgraph.transfer_function_2d import Rectangle, TransferFunction2D
from vgraph.volume import Volume

CODE_STEP = 1.0 / 65535
TF = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (0.05, 1, 1, 1, 0.4), (1.0, 1, 1, 1, 0.4)])
RAMP = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 1.0)])  # alpha = value
# Opaque (0.4) where the gradient fraction is below 0.3: the homogeneous block, not the striped one.
HOMOGENEOUS_2D = GradientClassification(transfer_function_2d=TransferFunction2D(
    primitives=[Rectangle(value=(0.05, 1.0), gradient=(0.0, 0.3), color=(1.0, 1.0, 1.0, 0.4))]))
HOMOGENEOUS_CURVE = GradientClassification(
    gradient_opacity=GradientOpacity(points=[(0.0, 1.0), (0.3, 1.0), (0.35, 0.0), (1.0, 0.0)]))
# Columns under each block, off its edges (and off the side the oblique light leaves the box by).
LEFT, RIGHT = np.s_[:, 4:28, 3:16], np.s_[:, 4:28, 24:37]


@pytest.fixture(scope="module")
def blocks():
    """Slab z 10..19 in empty space: x < 20 homogeneous (0.5, gradient fraction 0 inside), x >= 20
    stripes 0.2, 0.2, 0.8, 0.8 along x (|central difference| 0.3 everywhere inside: fraction 0.6)."""
    data = np.zeros((30, 40, 40), np.float32)
    data[10:20, :, :20] = 0.5
    data[10:20, :, 20:] = np.tile([0.2, 0.2, 0.8, 0.8], 5)
    return Volume(data, spacing=(1.0, 1.0, 1.0), declared_range=(0.0, 1.0))


def opacity_field(volume, classification):
    """The alpha of every voxel by the CPU reference ray caster's classification, as a volume."""
    sampler = VolumeSampler(volume)
    points = volume.voxel_to_world(np.indices(volume.data.shape)[::-1].reshape(3, -1).T)
    lut = TF.for_volume(volume).lut().astype(np.float64)
    alpha = classification.classifier(sampler, lut)(points, sampler(points))[:, 3]
    return Volume(alpha.reshape(volume.data.shape).astype(np.float32), spacing=volume.spacing,
                  declared_range=(0.0, 1.0))


def test_gradient_fractions_are_the_ray_casters(blocks):
    sampler = VolumeSampler(blocks)
    points = blocks.voxel_to_world(np.indices(blocks.data.shape)[::-1].reshape(3, -1).T)
    expected = np.linalg.norm(sampler.voxel_gradient(points), axis=1) / largest_gradient_magnitude(sampler)
    np.testing.assert_allclose(gradient_fractions(blocks).ravel(), expected, atol=1e-6)
    assert largest_magnitude(blocks) == pytest.approx(0.5)  # the GL's G_max: the striped block's faces
    assert gradient_fractions(blocks)[12:18][RIGHT] == pytest.approx(0.6, abs=1e-4)
    assert np.all(gradient_fractions(Volume(np.ones((4, 5, 6), np.float32))) == 0.0)  # constant: 0


@pytest.mark.parametrize("classification", [HOMOGENEOUS_2D, HOMOGENEOUS_CURVE], ids=["2d_tf", "gradient_opacity"])
def test_a_region_transparent_by_its_gradient_lets_the_light_through(blocks, classification):
    light = (0.0, 0.4, 1.0)  # from above, oblique along the stripes
    plain = light_volume(blocks, TF, light).data / 65535.0
    classified = light_volume(blocks, TF, light, classification).data / 65535.0
    assert plain[:10][RIGHT].max() < 0.05 and plain[:10][LEFT].max() < 0.05  # the 1D TF: both shade
    np.testing.assert_array_equal(classified[:10][RIGHT], 1.0)  # the stripes are transparent
    assert classified[:10][LEFT].max() < 0.05  # the homogeneous block still shades
    np.testing.assert_array_equal(classified[20:], 1.0)  # above the slab: full light


@pytest.mark.parametrize("classification", [HOMOGENEOUS_2D, HOMOGENEOUS_CURVE], ids=["2d_tf", "gradient_opacity"])
@pytest.mark.parametrize("light", [(0.0, 0.0, 1.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)])
def test_it_equals_the_light_volume_of_the_same_opacities_under_a_1d_tf(blocks, classification, light):
    """Along an axis the sweep samples the voxels themselves, so classifying by gradient is the same
    as classifying the reference's voxel opacities with alpha = value."""
    expected = light_volume(opacity_field(blocks, classification), RAMP, light).data.astype(np.int64)
    got = light_volume(blocks, TF, light, classification).data.astype(np.int64)
    assert np.abs(got - expected).max() <= 1
    assert got.min() < 0.5 * 65535  # a real shadow


def test_off_is_the_1d_tf_bit_for_bit(blocks):
    light = (0.3, -0.2, 1.0)
    plain = light_volume(blocks, TF, light).data
    np.testing.assert_array_equal(light_volume(blocks, TF, light, GradientClassification()).data, plain)
    network = Network()
    network.add(GivenVolume(id="src", volume=blocks))
    network.add("LightVolume", id="lv", transfer_function=TF, light_direction=light)
    network.connect("src.volume", "lv.volume")
    np.testing.assert_array_equal(network.evaluate("lv.light_volume").data, plain)


def test_the_light_volume_follows_the_ray_casters_classification_through_links(blocks):
    network = Network()
    network.add(GivenVolume(id="src", volume=blocks))
    network.add("RayCaster", id="rc", transfer_function=TF, light="direction", light_direction=(0.0, 0.4, 1.0))
    network.add("LightVolume", id="lv")
    for name in ("transfer_function", "light_direction", "gradient_opacity", "transfer_function_2d"):
        network.link(f"rc.{name}", f"lv.{name}")
    network.connect("src.volume", "lv.volume")
    rc = network.processors["rc"]
    rc.transfer_function_2d = HOMOGENEOUS_2D.transfer_function_2d
    np.testing.assert_array_equal(network.evaluate("lv.light_volume").data,
                                  light_volume(blocks, TF, (0.0, 0.4, 1.0), HOMOGENEOUS_2D).data)
    rc.transfer_function_2d, rc.gradient_opacity = None, HOMOGENEOUS_CURVE.gradient_opacity
    np.testing.assert_array_equal(network.evaluate("lv.light_volume").data,
                                  light_volume(blocks, TF, (0.0, 0.4, 1.0), HOMOGENEOUS_CURVE).data)
