"""The CPU reference ray caster: its optical model (sample positions and counts, trilinear
reconstruction, LUT classification, opacity correction, compositing, early termination, MIP,
shading) on small synthetic volumes with answers known in closed form."""

import numpy as np
import pytest
from scipy import ndimage

from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.numerics.reference_raycast import (Shading, VolumeSampler, lookup, render,
                                               volume_box)
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

# An opaque TF whose colour is the intensity: MIP and first-hit images read the data directly.
IDENTITY = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 1.0), (1.0, 1.0, 1.0, 1.0, 1.0)])
SPACING = (0.8, 0.8, 0.4)  # the z spacing is the smallest, so steps land on slices


def constant_tf(rgb, alpha):
    return TransferFunction(points=[(0.0, *rgb, alpha), (1.0, *rgb, alpha)])


def aligned_volume(seed=0, shape=(9, 6, 10)):
    data = np.random.default_rng(seed).random(shape)
    return Volume(data, spacing=SPACING, origin=(1.0, -2.0, 3.0))


def aligned_camera(volume):
    """Orthographic, looking down -z, one pixel per voxel column with pixel centres on voxel
    centres: image (row, col) shows voxel column (x = col, y = ny - 1 - row)."""
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    nx, ny, _ = volume.dims
    return Camera(projection="orthographic", position=(centre[0], centre[1], hi[2] + 5.0),
                  focus=tuple(centre), up=(0.0, 1.0, 0.0), near=1.0, far=50.0,
                  parallel_scale=ny * volume.spacing[1] / 2)


def smooth_sphere(shape, spacing, centre, radius, width=1.0):
    z, y, x = np.indices(shape).astype(float)
    r = np.sqrt(((x * spacing[0] - centre[0]) ** 2 + (y * spacing[1] - centre[1]) ** 2
                 + (z * spacing[2] - centre[2]) ** 2))
    return 1.0 / (1.0 + np.exp((r - radius) / width))


@pytest.mark.parametrize("rate", [1.0, 2.0])
def test_mip_equals_the_maximum_over_z(rate):
    volume = aligned_volume()
    nx, ny, _ = volume.dims
    image = render(volume, aligned_camera(volume), IDENTITY, (nx, ny), mode="mip",
                   sampling_rate=rate)
    expected = volume.normalized(volume.data).max(axis=0)[::-1, :]  # row 0 = largest y
    for channel in range(3):
        np.testing.assert_allclose(image[..., channel], expected, atol=1e-6)
    np.testing.assert_allclose(image[..., 3], 1.0)


def test_opaque_tf_stops_each_ray_after_its_first_sample():
    volume = aligned_volume(seed=1)
    nx, ny, _ = volume.dims
    image, samples = render(volume, aligned_camera(volume), IDENTITY, (nx, ny),
                            return_samples=True)
    assert samples.dtype == np.int32 and np.all(samples == 1)
    front_slice = volume.normalized(volume.data[-1])[::-1, :]  # the entry face, z = max
    np.testing.assert_allclose(image[..., 0], front_slice, atol=1e-6)


@pytest.mark.parametrize("rate", [1.0, 2.0, 3.0])
def test_transparent_tf_samples_the_whole_ray_from_face_to_face(rate):
    volume = aligned_volume()
    nx, ny, nz = volume.dims
    background = (0.1, 0.2, 0.3, 0.4)
    image, samples = render(volume, aligned_camera(volume), constant_tf((1, 1, 1), 0.0), (nx, ny),
                            sampling_rate=rate, background=background, return_samples=True)
    assert np.all(samples == (nz - 1) * rate + 1)  # both end faces included
    np.testing.assert_allclose(image, np.broadcast_to(background, image.shape), atol=1e-7)


def test_perspective_rays_start_at_the_box_and_stop_at_the_far_plane():
    volume = Volume(np.zeros((17, 8, 8)), spacing=(1.0, 1.0, 0.5))  # z extent 8 world units
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    camera = Camera(position=(centre[0], centre[1], hi[2] + 10.0), focus=tuple(centre), near=1.0,
                    far=100.0, fov=40.0)
    transparent = constant_tf((1, 1, 1), 0.0)
    for rate in (1.0, 2.5):
        _, samples = render(volume, camera, transparent, (5, 5), sampling_rate=rate,
                            return_samples=True)
        assert samples[2, 2] == np.floor(8.0 / (0.5 / rate) + 1e-3) + 1  # the central ray: z axis
        assert np.all(samples[[0, 0, -1, -1], [0, -1, 0, -1]] < samples[2, 2])  # oblique rays: shorter
    # The far plane halfway through the box cuts the rays there.
    clipped = camera.model_copy(update={"far": 14.0})
    _, samples = render(volume, clipped, transparent, (5, 5), return_samples=True, early_termination=1.0)
    assert samples[2, 2] == np.floor(4.0 / 0.5 + 1e-3) + 1


@pytest.mark.parametrize("threshold, expected_samples", [(0.99, 7), (0.9, 4), (0.5, 1)])
def test_early_termination_at_the_accumulated_opacity(threshold, expected_samples):
    volume = aligned_volume(shape=(12, 3, 4))
    image, samples = render(volume, aligned_camera(volume), constant_tf((1, 1, 1), 0.5), (4, 3),
                            early_termination=threshold, return_samples=True)
    # A after k samples is 1 - 0.5^k; the ray stops once it reaches the threshold.
    assert np.all(samples == expected_samples)
    np.testing.assert_allclose(image[..., 0], 1 - 0.5 ** expected_samples, atol=1e-6)


@pytest.mark.parametrize("rate", [1.0, 2.0, 0.5])
def test_compositing_and_opacity_correction_match_the_closed_form(rate):
    volume = aligned_volume(shape=(9, 4, 5))
    nz = volume.dims[2]
    colour, alpha, bg = np.array([0.2, 0.6, 1.0]), 0.1, np.array([0.1, 0.2, 0.3, 0.5])
    image = render(volume, aligned_camera(volume), constant_tf(colour, alpha), (5, 4),
                   sampling_rate=rate, early_termination=1.0, background=bg)
    n = int(np.floor((nz - 1) * rate + 1e-3)) + 1
    corrected = 1 - (1 - alpha) ** (1 / rate)
    coverage = 1 - (1 - corrected) ** n
    expected = np.r_[colour * coverage + (1 - coverage) * bg[:3], coverage + (1 - coverage) * bg[3]]
    np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape).astype(np.float32),
                               rtol=1e-5)


def test_sampling_rate_keeps_the_mean_brightness():
    data = smooth_sphere((32, 32, 32), (1, 1, 1), (15.5, 15.5, 15.5), 9.0, width=3.0)
    volume = Volume(data)
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-1.0, -0.4, -0.7))
    tf = TransferFunction.ramp(0.05, 1.0, color=(1.0, 0.8, 0.6), opacity=0.15)
    means = [render(volume, camera, tf, (48, 48), sampling_rate=rate)[..., :3].mean()
             for rate in (1.0, 2.0, 4.0)]
    assert means[0] > 0.05  # the test is not about an empty picture
    np.testing.assert_allclose(means[1:], means[0], rtol=0.02)
    # Without the correction, four times the samples of the same alpha would be far brighter.
    uncorrected = TransferFunction.ramp(0.05, 1.0, color=(1.0, 0.8, 0.6), opacity=1 - 0.85 ** 0.25)
    dimmer = render(volume, camera, uncorrected, (48, 48), sampling_rate=1.0)[..., :3].mean()
    assert dimmer < 0.7 * means[0]


def iou(a, b):
    return np.logical_and(a, b).sum() / np.logical_or(a, b).sum()


@pytest.mark.parametrize("mode", ["mip", "dvr"])
@pytest.mark.parametrize("direction", [(-1.0, 0.0, 0.0), (-1.0, -0.3, -0.5)])
def test_anisotropic_spacing_renders_the_same_silhouette(mode, direction):
    centre, radius = (23.5, 23.5, 23.0), 14.0
    iso = Volume(smooth_sphere((48, 48, 48), (1, 1, 1), centre, radius), declared_range=(0, 1))
    aniso = Volume(smooth_sphere((24, 48, 48), (1, 1, 2), centre, radius), spacing=(1, 1, 2),
                   declared_range=(0, 1))
    camera = Camera.looking_at_box(*volume_box(iso), direction=direction, up=(0, 0, 1),
                                   projection="orthographic" if mode == "mip" else "perspective")
    tf = TransferFunction.ramp(0.4, 0.6, opacity=0.5)
    images = [render(v, camera, tf, (64, 64), mode=mode, background=(0, 0, 0, 0)) for v in (iso, aniso)]
    masks = [image[..., 3] > 0.25 for image in images]  # MIP: max intensity above 0.5
    assert iou(*masks) > 0.97
    # Round, not squashed along z (which is the image's vertical when looking along -x).
    rows, cols = np.flatnonzero(masks[1].any(axis=1)), np.flatnonzero(masks[1].any(axis=0))
    if direction == (-1.0, 0.0, 0.0):
        assert abs((rows[-1] - rows[0]) - (cols[-1] - cols[0])) <= 1


def test_camera_inside_the_volume_sees_it_all_around():
    data = smooth_sphere((24, 24, 24), (1, 1, 1), (11.5, 11.5, 11.5), 8.0, width=2.0)
    volume = Volume(data)
    camera = Camera(position=(11.5, 11.0, 12.0), focus=(11.5, 11.0, 0.0), fov=90.0, near=0.1, far=100.0)
    image, samples = render(volume, camera, TransferFunction.ramp(0.1, 1.0, opacity=0.2), (16, 16),
                            return_samples=True)
    assert np.all(samples > 0)
    assert np.all(image[..., 0] > 0.05)


def test_rays_that_miss_the_box_show_the_background_exactly():
    volume = aligned_volume()
    background = (0.25, 0.5, 0.75, 1.0)
    away = Camera(position=(0, 0, -10.0), focus=(0, 0, -20.0))
    image, samples = render(volume, away, IDENTITY, (8, 8), background=background, return_samples=True)
    assert np.all(samples == 0)
    np.testing.assert_array_equal(image, np.broadcast_to(np.float32(background), image.shape))
    framed = Camera.looking_at_box(*volume_box(volume), direction=(0.3, -1.0, 0.2))
    image, samples = render(volume, framed, IDENTITY, (32, 32), mode="mip", background=background,
                            return_samples=True)
    assert 0 < np.count_nonzero(samples) < samples.size
    np.testing.assert_array_equal(image[samples == 0], np.broadcast_to(np.float32(background),
                                                                       image[samples == 0].shape))


def test_trilinear_sampling_matches_scipy_with_clamp_to_edge():
    data = np.random.default_rng(3).random((5, 6, 7)).astype(np.float32)
    data[2, 3, 4] = np.nan
    volume = Volume(data, spacing=(0.5, 1.5, 2.0), origin=(-1.0, 2.0, 0.5))
    points = np.random.default_rng(4).uniform(-3, 12, size=(500, 3))
    clean = np.nan_to_num(data.astype(np.float64), nan=volume.value_range[0])
    voxel = (points - volume.origin) / volume.spacing
    expected = ndimage.map_coordinates(clean, voxel[:, ::-1].T, order=1, mode="nearest")
    np.testing.assert_allclose(VolumeSampler(volume)(points), volume.normalized(expected), atol=1e-12)


def test_lut_lookup_interpolates_linearly_between_entries():
    tf = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 1, 0.5, 0, 0.2), (0.31, 0, 1, 1, 1.0),
                                  (1.0, 1, 1, 1, 1)])
    lut = tf.lut().astype(np.float64)
    v = np.random.default_rng(5).uniform(-0.2, 1.2, 1000)
    positions = np.linspace(0, 1, len(lut))
    expected = np.stack([np.interp(v, positions, lut[:, c]) for c in range(4)], axis=1)
    np.testing.assert_allclose(lookup(lut, v), expected, atol=1e-12)
    np.testing.assert_allclose(lookup(lut, v), tf(v), atol=2e-3)  # LUT resolution


def test_shading_lights_surfaces_facing_the_headlight():
    data = smooth_sphere((32, 32, 32), (1, 1, 1), (15.5, 15.5, 15.5), 10.0, width=1.5)
    volume = Volume(data, declared_range=(0, 1))
    camera = Camera.looking_at_box(*volume_box(volume), direction=(0, 0, -1), projection="orthographic")
    colour = np.array([0.8, 0.5, 0.2])
    tf = TransferFunction(points=[(0.3, *colour, 0.0), (0.6, *colour, 1.0)])
    shading = Shading(ambient=0.2, diffuse=0.6, specular=0.3, shininess=10.0)
    image = render(volume, camera, tf, (33, 33), shading=shading, background=(0, 0, 0, 0))
    # The central ray meets the surface head-on: full diffuse and specular in every sample.
    centre = image[16, 16]
    np.testing.assert_allclose(centre[:3] / centre[3], np.clip(0.8 * colour + 0.3, 0, 1), atol=1e-3)
    # Towards the rim the surface turns away and gets darker.
    row = image[16, :, 0] / np.maximum(image[16, :, 3], 1e-9)
    rim = np.flatnonzero(image[16, :, 3] > 0.5)[0]
    assert row[rim] < 0.7 * row[16]
    # Two-sided lighting: the same surface with the opposite polarity (inside darker) looks the same.
    inverted = Volume(1.0 - data, declared_range=(0, 1))
    mirrored = TransferFunction(points=[(0.4, *colour, 1.0), (0.7, *colour, 0.0)])
    np.testing.assert_allclose(render(inverted, camera, mirrored, (33, 33), shading=shading,
                                      background=(0, 0, 0, 0)), image, atol=1e-4)
    # A constant volume has no gradient: shading leaves it unchanged.
    flat = Volume(np.full((8, 8, 8), 0.5), declared_range=(0, 1))
    flat_camera = Camera.looking_at_box(*volume_box(flat))
    plain = render(flat, flat_camera, tf, (8, 8))
    np.testing.assert_allclose(render(flat, flat_camera, tf, (8, 8), shading=shading), plain)


@pytest.mark.parametrize("kwargs, message", [
    ({"mode": "xray"}, "mode"),
    ({"sampling_rate": 0.0}, "sampling_rate"),
    ({"early_termination": 0.0}, "early_termination"),
    ({"early_termination": 1.5}, "early_termination"),
    ({"background": (0, 0, 0)}, "background"),
    ({"size": (0, 4)}, "size"),
    ({"size": (2.5, 4)}, "size"),
])
def test_bad_arguments_are_rejected_by_name(kwargs, message):
    volume = aligned_volume()
    arguments = {"size": (4, 4), **kwargs}
    with pytest.raises(VGraphError, match=message):
        render(volume, aligned_camera(volume), IDENTITY, **arguments)


def test_spline_coefficients_are_refused():
    volume = Volume(np.zeros((4, 4, 4)), is_spline_coefficients=True, source="coeffs.nrrd")
    with pytest.raises(VGraphError, match="coeffs.nrrd.*B-spline"):
        render(volume, Camera(), IDENTITY, (4, 4))
