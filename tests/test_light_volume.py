"""Volumetric shadows: the light volume (vgraph.numerics.light_volume) against the analytic
attenuation of a uniform medium and a slab, against shadow rays (vgraph.numerics.reference_shadows)
for a sphere, and the RayCaster's light_volume inport against the CPU reference (rule 9)."""

import numpy as np
import pytest

from vgraph import ProcessorError, VGraphError
from vgraph.camera import Camera
from vgraph.implicit import sample
from vgraph.numerics.light_volume import (Extinction, extinction, index_light, light_volume, normalized_values,
                                          transmittance)
from vgraph.numerics.reference_raycast import Shading, render, volume_box
from vgraph.numerics.reference_shadows import shadow_rays, shadowed
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

SIZE = (56, 44)
# GL against the CPU reference sampling the same light volume (max |difference| per channel).
# Measured on llvmpipe: ~1.3e-6, as the unshadowed ray caster (tests/test_raycaster.py).
REFERENCE_TOLERANCE = 2e-5
# The light volume's sweep against shadow rays, per pixel of the sphere's image: measured max
# 0.0144, mean 0.0003 (rule 3's trapezoid and resamplings; resampling the optical depth at every
# slice, the first version, gave 0.043 and 0.0010).
SWEEP_MAX, SWEEP_MEAN = 0.025, 0.001
CODE_STEP = 1.0 / 65535  # the light volume's 16-bit codes
SPHERE_TF = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (0.45, 1, 1, 1, 0.0),
                                     (0.55, 0.9, 0.8, 0.6, 0.3), (1.0, 0.9, 0.8, 0.6, 0.3)])
LIGHT = (0.5, 1.0, 0.3)


def constant_tf(alpha):
    return TransferFunction(points=[(0.0, 1.0, 1.0, 1.0, alpha), (1.0, 1.0, 1.0, 1.0, alpha)])


def uniform_box(shape=(20, 30, 40), spacing=(1.0, 0.5, 2.0)):
    return Volume(np.ones(shape, np.float32), spacing=spacing, origin=(1.0, -2.0, 0.5), declared_range=(0.0, 1.0))


def distance_to_box(volume, light):
    """World distance from every voxel centre along ``light`` (unit, index axes) to the box's face."""
    z, y, x = np.indices(volume.data.shape)
    points = np.stack([x, y, z], axis=-1) * np.asarray(volume.spacing)
    top = (np.asarray(volume.dims) - 1) * np.asarray(volume.spacing)
    with np.errstate(divide="ignore", invalid="ignore"):
        ahead = np.where(light > 0, (top - points) / light, np.where(light < 0, -points / light, np.inf))
    return ahead.min(axis=-1)


@pytest.fixture(scope="module")
def sphere():
    return sample("sphere", 32, "float32")


def sphere_camera(volume):
    return Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))


# --- the light volume against the analytic attenuation --------------------------------------------
@pytest.mark.parametrize("light", [(0, 0, 1), (0, 0, -1), (1, 0, 0), (-1, 0, 0), (0, 2, 0), (0, -1, 0)])
def test_a_uniform_medium_attenuates_as_exp_of_minus_tau_d(light):
    volume, alpha = uniform_box(), 0.1
    tau = -np.log1p(-alpha) / min(volume.spacing)  # extinction per world unit (rule 1)
    np.testing.assert_allclose(extinction(volume, constant_tf(alpha)), tau, rtol=1e-6)
    transmittance = light_volume(volume, constant_tf(alpha), light).data / 65535.0
    expected = np.exp(-tau * distance_to_box(volume, index_light(volume, light)))
    np.testing.assert_allclose(transmittance, expected, atol=CODE_STEP)
    assert transmittance.min() < 0.1  # light crosses the whole box: deep shadow at its far side


def test_an_oblique_light_through_a_slab_attenuates_as_exp_of_minus_tau_d():
    """A slab of m voxels (z) in empty space, lit obliquely: below it, away from its edges,
    T = exp(-tau d) with d = m * spacing_z / |light_z|, the light's path through the slab's cells."""
    data = np.zeros((30, 40, 40), np.float32)
    data[18:23] = 1.0  # m = 5 slices
    volume = Volume(data, spacing=(1.0, 1.0, 0.8), declared_range=(0.0, 1.0))
    alpha = 0.2
    tf = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (1.0, 1, 1, 1, alpha)])
    light = np.array([0.3, -0.2, 1.0])
    tau = -np.log1p(-alpha) / 0.8
    unit = light / np.linalg.norm(light)
    d = 5 * 0.8 / unit[2]
    t = light_volume(volume, tf, light).data / 65535.0
    np.testing.assert_allclose(t[23:][:, 14:26, 8:20], 1.0, atol=CODE_STEP)  # above the slab: lit
    # away from the box's side faces (module docstring, rule 3)
    np.testing.assert_allclose(t[:18][:, 14:26, 8:20], np.exp(-tau * d), atol=2 * CODE_STEP)
    # chunks of 4 slices (7 sheared grids) give the same
    chunked = transmittance(normalized_values(volume), Extinction(volume, tf), volume.spacing,
                            index_light(volume, light), chunk=4)
    np.testing.assert_allclose(chunked[:18][:, 14:26, 8:20], np.exp(-tau * d), atol=1e-5)
    np.testing.assert_allclose(chunked[23:][:, 14:26, 8:20], 1.0, atol=1e-6)
    assert np.exp(-tau * d) < 0.5  # a real shadow


def test_shadow_rays_attenuate_a_uniform_medium_as_exp_of_minus_tau_d():
    volume, alpha = uniform_box((8, 9, 10)), float(np.float32(0.3))  # the LUT's float32 value
    light = (0.2, -0.4, 1.0)
    points = volume.voxel_to_world(np.indices(volume.data.shape)[::-1].reshape(3, -1).T)
    tau = -np.log1p(-alpha) / min(volume.spacing)
    expected = np.exp(-tau * distance_to_box(volume, index_light(volume, light))).ravel()
    np.testing.assert_allclose(shadow_rays(volume, constant_tf(alpha), light)(points), expected, rtol=1e-9)


def test_the_sweep_matches_shadow_rays_on_a_sphere(sphere):
    camera = sphere_camera(sphere)
    lit = render(sphere, camera, SPHERE_TF, SIZE, shadow=shadowed(light_volume(sphere, SPHERE_TF, LIGHT)))
    rays = render(sphere, camera, SPHERE_TF, SIZE, shadow=shadow_rays(sphere, SPHERE_TF, LIGHT))
    plain = render(sphere, camera, SPHERE_TF, SIZE)
    assert np.abs(plain - rays).max() > 0.5  # the shadow is in the picture
    error = np.abs(lit - rays)
    assert error.max() < SWEEP_MAX and error.mean() < SWEEP_MEAN


# --- the RayCaster's light_volume inport against the CPU reference --------------------------------
def shadowed_network(volume, camera, light, **properties):
    network = ray_caster_network(volume, camera, **properties)
    network.add(GivenVolume(id="light", volume=light))
    network.connect("light.volume", "rc.light_volume")
    return network


@pytest.mark.parametrize("shaded, strength", [(False, 1.0), (True, 1.0), (True, 0.6)])
def test_the_gl_image_matches_the_cpu_reference_on_a_sphere(sphere, shaded, strength):
    camera = sphere_camera(sphere)
    light = light_volume(sphere, SPHERE_TF, LIGHT)
    gl = shadowed_network(sphere, camera, light, transfer_function=SPHERE_TF, shadow_strength=strength,
                          shading="blinn_phong" if shaded else "none").evaluate("rc.image", size=SIZE)
    reference = render(sphere, camera, SPHERE_TF, SIZE, shading=Shading() if shaded else None,
                       shadow=shadowed(light), shadow_strength=strength)
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


def test_the_gl_image_matches_the_cpu_reference_on_a_slab():
    data = np.zeros((24, 20, 20), np.float32)
    data[8:16] = 1.0
    volume = Volume(data, spacing=(0.5, 0.5, 0.5), declared_range=(0.0, 1.0))
    tf = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (1.0, 0.9, 0.7, 0.5, 0.15)])
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-1.0, -0.2, -0.4))
    light = light_volume(volume, tf, (0.2, 0.1, 1.0))
    gl = shadowed_network(volume, camera, light, transfer_function=tf, shading="none").evaluate("rc.image", size=SIZE)
    reference = render(volume, camera, tf, SIZE, shadow=shadowed(light))
    assert np.abs(reference - render(volume, camera, tf, SIZE)).max() > 0.1
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


def test_a_light_volume_of_full_light_changes_no_pixel(sphere):
    camera = sphere_camera(sphere)
    full = Volume(np.full(sphere.data.shape, 65535, np.uint16), spacing=sphere.spacing, origin=sphere.origin,
                  declared_range=(0.0, 65535.0))
    plain = ray_caster_network(sphere, camera, transfer_function=SPHERE_TF).evaluate("rc.image", size=SIZE)
    lit = shadowed_network(sphere, camera, full, transfer_function=SPHERE_TF).evaluate("rc.image", size=SIZE)
    assert np.array_equal(plain, lit)


def test_the_light_volume_processor_follows_the_transfer_function_and_light(sphere):
    network = ray_caster_network(sphere, sphere_camera(sphere), transfer_function=SPHERE_TF)
    network.add("LightVolume", id="lv", transfer_function=SPHERE_TF, light_direction=LIGHT)
    network.connect("src.volume", "lv.volume")
    network.connect("lv.light_volume", "rc.light_volume")
    first = network.evaluate("lv.light_volume")
    np.testing.assert_array_equal(first.data, light_volume(sphere, SPHERE_TF, LIGHT).data)
    network.processors["lv"].light_direction = (-1.0, 0.0, 0.0)
    np.testing.assert_array_equal(network.evaluate("lv.light_volume").data,
                                  light_volume(sphere, SPHERE_TF, (-1.0, 0.0, 0.0)).data)
    network.processors["lv"].transfer_function = constant_tf(0.05)
    np.testing.assert_array_equal(network.evaluate("lv.light_volume").data,
                                  light_volume(sphere, constant_tf(0.05), (-1.0, 0.0, 0.0)).data)
    image = network.evaluate("rc.image", size=SIZE)
    assert image.shape == (SIZE[1], SIZE[0], 4)


def test_a_zero_light_direction_is_refused_by_name(sphere):
    network = ray_caster_network(sphere, sphere_camera(sphere))
    network.add("LightVolume", id="lv", light_direction=(0.0, 0.0, 0.0))
    network.connect("src.volume", "lv.volume")
    with pytest.raises(ProcessorError, match="lv.light_direction: must not be zero"):
        network.evaluate("lv.light_volume")


def test_a_turned_light_volume_is_refused_by_name(sphere):
    turned = Volume(np.ones(sphere.data.shape, np.float32), spacing=sphere.spacing, origin=sphere.origin,
                    direction=((0, -1, 0), (1, 0, 0), (0, 0, 1)))
    with pytest.raises(VGraphError, match="rc.light_volume"):
        shadowed_network(sphere, sphere_camera(sphere), turned).evaluate("rc.image", size=SIZE)


@pytest.mark.parametrize("compositing", ["dvr", "iso"])
def test_a_uniform_light_volume_scales_the_colour_in_dvr_and_iso(sphere, compositing):
    """T = 0.5 everywhere, strength 0.6: every colour is 1 - 0.6 * 0.5 = 0.7 of the unshadowed one
    (black background); mip draws as without."""
    camera = sphere_camera(sphere)
    half = Volume(np.full((4, 5, 6), 32768, np.uint16), spacing=(0.7, 0.5, 0.6), origin=(-1.0, -1.0, -1.0),
                  declared_range=(0.0, 65535.0))  # another grid: the mapping of texture coordinates
    settings = dict(transfer_function=SPHERE_TF, compositing=compositing, shadow_strength=0.6)
    plain = ray_caster_network(sphere, camera, **settings).evaluate("rc.image", size=SIZE)
    lit = shadowed_network(sphere, camera, half, **settings).evaluate("rc.image", size=SIZE)
    factor = 1.0 - 0.6 * (1.0 - 32768 / 65535)
    assert plain[..., :3].max() > 0.3
    np.testing.assert_allclose(lit[..., :3], plain[..., :3] * factor, atol=2e-6)
    np.testing.assert_array_equal(lit[..., 3], plain[..., 3])
    mip = dict(settings, compositing="mip")
    assert np.array_equal(ray_caster_network(sphere, camera, **mip).evaluate("rc.image", size=SIZE),
                          shadowed_network(sphere, camera, half, **mip).evaluate("rc.image", size=SIZE))


def test_a_light_volume_on_its_own_grid_is_sampled_where_the_samples_are(sphere):
    """A ramp on a coarser, shifted grid: the GL maps the volume's texture coordinates onto it as
    the CPU reference samples it at the samples' world points (clamped beyond its box)."""
    camera = sphere_camera(sphere)
    z, y, x = np.indices((13, 15, 12))
    ramp = Volume((65535 * (0.2 + 0.8 * (x / 11.0) * (z / 12.0))).astype(np.uint16), spacing=(0.13, 0.1, 0.11),
                  origin=(-0.9, -1.1, -0.95), declared_range=(0.0, 65535.0))
    gl = shadowed_network(sphere, camera, ramp, transfer_function=SPHERE_TF,
                          shading="none").evaluate("rc.image", size=SIZE)
    reference = render(sphere, camera, SPHERE_TF, SIZE, shadow=shadowed(ramp))
    assert np.abs(reference - render(sphere, camera, SPHERE_TF, SIZE)).max() > 0.2
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


def test_a_volume_drawn_brick_by_brick_refuses_a_light_volume_by_name(sphere, monkeypatch):
    import vgraph.processors.raycaster as raycaster
    monkeypatch.setattr(raycaster, "needs_bricks", lambda volume, gl: True)  # as for a volume too large
    light = light_volume(sphere, SPHERE_TF, LIGHT)
    with pytest.raises(ProcessorError, match="rc.light_volume: .* drawn brick by brick.*disconnect light_volume"):
        shadowed_network(sphere, sphere_camera(sphere), light).evaluate("rc.image", size=SIZE)
