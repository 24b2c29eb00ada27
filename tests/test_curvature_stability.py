"""Stability of the curvature ray casters: vanishing gradients, umbilics, zero Gaussian curvature,
saddles, stiff fields, radii from one voxel to beyond the volume, quantised data, NaN/Inf voxels,
levels outside the data, grazing rays. Outputs stay finite; where curvature is undefined the pixel
is flagged (curvature alpha 0.5, rgb 0; image `undefined_color`). docs/explanations/curvature.md ("Stability")
describes each case and the numbers measured here."""

import warnings

import numpy as np
import pytest

from vgraph import registry
from vgraph.camera import Camera
from vgraph.gl.curvature import ZERO_CURVATURE
from vgraph.implicit import exact_curvature, make_function, sample
from vgraph.numerics.bspline import evaluate
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.curvature import TORUS_CAMERA, coefficients_of, curvature_network
from helpers.networks import rendering_network

SIZE = (64, 64)
OBLIQUE = Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(-0.3, -0.4, -1.0))
UNDEFINED = (1.0, 0.0, 1.0, 1.0)
OUTPUTS = ("image", "curvature", "position", "depth")


def volume_for(mode, samples):
    """What the mode needs, made as a network makes it (the CubicSplineProcessor for the spline)."""
    if not mode.startswith("tricubic"):
        return samples
    return registry.get("CubicSplineProcessor")(id="spline").process(samples)


def outputs(volume, camera=OBLIQUE, size=SIZE, processor="CurvatureRaycaster", **properties):
    """Every output of the processor; all finite, curvature alpha only 0, 0.5 or 1."""
    names = OUTPUTS if processor == "CurvatureRaycaster" else ("image", "depth")
    network = curvature_network(volume, camera, processor=processor, **properties)
    result = dict(zip(names, (network.evaluate(f"cr.{name}", size=size) for name in names)))
    for name, image in result.items():
        assert np.isfinite(image).all(), name
    if "curvature" in result:
        assert set(np.unique(result["curvature"][..., 3])) <= {0.0, 0.5, 1.0}
        np.testing.assert_array_equal(result["curvature"][..., 3] > 0, result["position"][..., 3] == 1)
    return result


def relative_errors(curvature, position, function, mask=None):
    """|k - exact| / max(|k1|, |k2|) at the hits (k1 and k2 together)."""
    hit = curvature[..., 3] == 1.0 if mask is None else mask
    exact = exact_curvature(function, position[hit, :3].astype(np.float64))
    scale = np.maximum(np.abs(exact.k1), np.abs(exact.k2))
    return np.concatenate([np.abs(curvature[hit, 0] - exact.k1) / scale,
                           np.abs(curvature[hit, 1] - exact.k2) / scale])


def inside_faces(position, spacing, voxels):
    """Hits at least ``voxels`` voxels inside every face of the [-1, 1]^3 box."""
    margin = 1.0 - voxels * spacing
    return (position[..., 3] == 1.0) & (np.abs(position[..., :3]).max(axis=-1) < margin)


# --- |grad f| -> 0 -------------------------------------------------------------------------------
@pytest.mark.parametrize("mode", ["central", "tricubic"])
def test_a_constant_volume_has_no_surface_and_only_undefined_samples(mode):
    """No crossing of any level: no hit, the background everywhere. Direct volume rendering with
    opacity at the constant value composites `undefined_color` at every sample: the RayCaster's
    dvr with that colour in its TF."""
    flat = Volume(np.full((20, 20, 20), 7.0, dtype=np.float32), spacing=(0.1,) * 3, origin=(-1,) * 3)
    volume = volume_for(mode, flat)
    surface = outputs(volume, derivatives=mode, iso_level=0.5)
    assert not surface["position"][..., 3].any()
    assert np.all(surface["image"] == [0.0, 0.0, 0.0, 1.0])
    fog = [(0.0, 0.2), (1.0, 0.2)]  # the constant is normalised intensity 0
    ours = outputs(volume, processor="CurvatureVolumeRaycaster", derivatives=mode,
                   undefined_color=UNDEFINED,
                   transfer_function=TransferFunction(points=[(x, 1, 1, 1, a) for x, a in fog]))
    theirs = rendering_network(flat, OBLIQUE, transfer_function=TransferFunction(
        points=[(x, *UNDEFINED[:3], a) for x, a in fog])).evaluate("rc.image", size=SIZE)
    assert theirs[..., 0].max() > 0.5
    np.testing.assert_allclose(ours["image"], theirs, atol=1e-5)


def test_a_vanishing_gradient_on_the_surface_is_flagged():
    """f = z^3: the level set f = 0 is the plane z = 0, where grad f = 0. The cubic spline
    reproduces z^3, so at the hit |grad f| ~ 1e-14: undefined, flagged (alpha 0.5, rgb 0) and
    shown in `undefined_color`. Central differences one voxel apart see a slope of h^2 there and
    give the plane's answer, k = 0 (defined)."""
    n = 32
    z = np.linspace(-1.0, 1.0, n)
    cube = np.broadcast_to((z ** 3)[:, None, None], (n, n, n)).astype(np.float32)
    samples = Volume(np.ascontiguousarray(cube), spacing=(2 / (n - 1),) * 3, origin=(-1.0,) * 3,
                     declared_range=(-1.0, 1.0))
    spline = outputs(coefficients_of(samples), derivatives="tricubic", undefined_color=UNDEFINED)
    hit = spline["position"][..., 3] == 1.0
    assert hit.sum() > 1000
    assert np.all(spline["curvature"][hit] == [0.0, 0.0, 0.0, 0.5])
    assert np.all(spline["image"][hit] == UNDEFINED)
    assert np.abs(spline["position"][hit, 2]).max() < 1e-3  # on the plane z = 0
    differences = outputs(samples, derivatives="central")
    hit = differences["curvature"][..., 3] == 1.0
    assert hit.sum() > 1000
    assert np.abs(differences["curvature"][hit, :3]).max() * samples.spacing[0] < 1e-5


# --- umbilics, K = 0, saddles ------------------------------------------------------------------
def test_umbilics_stay_defined_with_k1_equal_k2():
    """Sphere: 2F^2 - T^2 = 0 in exact arithmetic; rounding makes it slightly negative, and the
    clamp to 0 gives k1 == k2 exactly (measured at 358 of 492 hits) instead of NaN."""
    samples = sample("sphere", 64, "float32")
    result = outputs(coefficients_of(samples), derivatives="tricubic", curvature="shape_index",
                     shading="none")
    curvature = result["curvature"]
    hit = curvature[..., 3] == 1.0
    assert hit.sum() > 400 and np.all(curvature[..., 3] != 0.5)
    k1, k2 = curvature[hit, 0], curvature[hit, 1]
    assert np.all(k1 >= k2) and np.all(k1 - k2 < 2e-3 / 0.7)
    assert np.mean(k1 == k2) > 0.3
    # Shape index +1 (convex umbilic) everywhere: the top of the colour map, JET(1) = dark red.
    assert np.abs(result["image"][hit, :3] - [0.5, 0.0, 0.0]).max() < 2e-3


@pytest.mark.parametrize("mode", ["tricubic", "central"])
def test_cylinder_has_zero_gaussian_curvature_drawn_as_contour(mode):
    """k1 = 1/R, k2 = 0, K = 0. The measure reads |K| below the zero floor as 0, so the linear
    normalisation does not stretch rounding noise: the whole Gaussian image is the zero contour."""
    samples = sample("cylinder", 64, "float32")
    result = outputs(volume_for(mode, samples), derivatives=mode, curvature="gaussian",
                     shading="none")
    curvature, position = result["curvature"], result["position"]
    hit = curvature[..., 3] == 1.0
    radius = np.hypot(position[hit, 0], position[hit, 1])
    np.testing.assert_allclose(curvature[hit, 0], 1 / radius, rtol=3e-3)
    assert np.abs(curvature[hit, 1]).max() < 1e-5 and np.abs(curvature[hit, 2]).max() < 1e-5
    assert np.all(result["image"][hit, :3] == 0.0)


@pytest.mark.parametrize("mode, margin", [("central", 2), ("tricubic", 10)])
def test_plane_is_flat_away_from_the_volume_boundary(mode, margin):
    """A tilted plane crosses the box's faces. Inside, k1 = k2 = 0 to rounding (~1e-5 per voxel);
    near the faces the reconstruction's boundary rule bends the surface: one voxel for
    differences (clamp-to-edge), ~8 voxels for the spline (its mirror boundary rings, decaying
    by 0.27 per voxel). Measured max |k| h: central 5.6e-7 from one voxel in; tricubic 4.6e-3 at
    4 voxels, 3.3e-4 at 6, 2.4e-5 at 8, 1.7e-6 at 10."""
    samples = sample(make_function("plane", normal=(0.2, 0.3, 1.0), offset=0.1), 64, "float32")
    result = outputs(volume_for(mode, samples), derivatives=mode, curvature="k2")
    inner = inside_faces(result["position"], samples.spacing[0], margin)
    assert inner.sum() > 500
    assert np.abs(result["curvature"][inner, :2]).max() * samples.spacing[0] < ZERO_CURVATURE


def test_saddles_have_negative_gaussian_curvature():
    saddle = make_function("saddle")
    samples = sample(saddle, 64, "float32")
    result = outputs(coefficients_of(samples), derivatives="tricubic", curvature="gaussian")
    inner = inside_faces(result["position"], samples.spacing[0], 10)
    assert inner.sum() > 300
    k1, k2, gaussian = (result["curvature"][inner, c] for c in range(3))
    assert np.all(k1 > 0) and np.all(k2 < 0) and np.all(gaussian < 0)
    errors = relative_errors(result["curvature"], result["position"], saddle, inner)
    assert np.median(errors) < 1e-4 and errors.max() < 2e-3  # measured 1.1e-6, 1.8e-4


# --- stiff fields, radii, quantisation ---------------------------------------------------------
@pytest.mark.parametrize("sharpness", [1.0, 20.0, 100.0, 1000.0])
def test_stiff_shell_stays_finite_and_on_its_reconstructed_surface(sharpness):
    """f = tanh(s u): from s = 20 the transition is narrower than two voxels and at s = 1000 the
    samples are a step (+-1): the reconstruction is a voxelised sphere whose curvature is noise
    (median relative error: s = 1 7e-4, s = 20 0.09, s = 100 3.6, s = 1000 10), but every
    output stays finite and every hit lies on the reconstructed level set."""
    shell = make_function("stiff_shell", sharpness=sharpness)
    samples = sample(shell, 64, "float32")
    coefficients = coefficients_of(samples)
    result = outputs(coefficients, derivatives="tricubic", curvature="mean")
    hit = result["curvature"][..., 3] == 1.0
    assert 450 < hit.sum() < 560  # the outer sphere (radius 0.7) covers about 490 pixels
    world = result["position"][hit, :3].astype(np.float64)
    spline = evaluate(coefficients.data, coefficients.world_to_voxel(world), coefficients.spacing, 1)
    assert np.max(np.abs(spline.value) / np.linalg.norm(spline.gradient, axis=1)) < 1e-5
    if sharpness == 1.0:
        assert np.median(relative_errors(result["curvature"], result["position"], shell)) < 3e-3


def test_radii_from_one_voxel_to_beyond_the_volume():
    """Sphere radii of 1 to 28 voxels and a cap of a sphere of radius 100 voxels (larger than the
    volume): always finite and defined; the error falls with the radius (tricubic medians
    measured: 8.5e-2 at 1 voxel, 7.5e-3 at 3.2, 9.5e-4 at 6.3, 2.8e-4 at 12.6) and the cap
    (interior hits) is within 6e-4 of 1/R."""
    medians = []
    for resolution, radius in ((40, 0.05), (64, 0.1), (64, 0.2), (64, 0.4), (64, 0.9)):
        sphere = make_function("sphere", radius=radius)
        camera = Camera.looking_at_box((-radius,) * 3, (radius,) * 3, direction=(-0.3, -0.4, -1.0))
        result = outputs(coefficients_of(sample(sphere, resolution, "float32")), camera,
                         derivatives="tricubic")
        assert np.all(result["curvature"][..., 3] != 0.5)
        medians.append(np.median(relative_errors(result["curvature"], result["position"], sphere)))
    assert medians[0] < 0.15 and all(m < 2e-3 for m in medians[2:])
    assert medians[0] > medians[1] > medians[2] > medians[3]
    n, h = 64, 2.0 / 63
    big = 100 * h
    axis = np.linspace(-1.0, 1.0, n)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    data = (big - np.sqrt(x * x + y * y + (z + big - 0.3) ** 2)).astype(np.float32)
    m = float(np.abs(data).max())
    cap = Volume(data, spacing=(h,) * 3, origin=(-1.0,) * 3, declared_range=(-m, m))
    result = outputs(coefficients_of(cap), derivatives="tricubic")
    inner = inside_faces(result["position"], h, 10)
    assert inner.sum() > 400
    np.testing.assert_allclose(result["curvature"][inner, :2], 1 / big, rtol=1e-3)


def test_quantised_data_gives_noisier_but_finite_curvature():
    """The torus in float32, uint16 and uint8 (Cabral 2010 ch. 6): quantisation steps become
    curvature noise. Medians measured (tricubic / central / filtered): float32 2.8e-4 / 1.7e-3 /
    2.4e-3, uint16 5.2e-3 / 2.4e-3 / 2.7e-3, uint8 1.5 / 0.36 / 0.11: the interpolating spline
    passes through every quantised sample and shows the steps most, the smoothing filter least."""
    torus = make_function("torus")
    median = {}
    for data_type in ("float32", "uint16", "uint8"):
        samples = sample(torus, 64, data_type)
        for mode in ("tricubic", "filtered"):
            result = outputs(volume_for(mode, samples), TORUS_CAMERA, derivatives=mode)
            assert np.all(result["curvature"][..., 3] != 0.5)
            median[data_type, mode] = np.median(relative_errors(result["curvature"],
                                                                result["position"], torus))
    assert median["float32", "tricubic"] < median["uint16", "tricubic"] < median["uint8", "tricubic"]
    assert median["uint8", "filtered"] < median["uint8", "tricubic"]
    assert median["uint8", "tricubic"] < 5.0


# --- bad data, bad levels, grazing rays ----------------------------------------------------------
@pytest.mark.parametrize("mode", ["central", "tricubic"])
def test_nan_and_inf_voxels_give_finite_outputs(mode):
    """Non-finite voxels are uploaded clamped to the value range (NaN and -Inf to its low end,
    +Inf to its high end); the CubicSplineProcessor replaces them the same way before filtering.
    The surface gets dents there, but no output is ever NaN or Inf."""
    samples = sample("torus", 48, "float32")
    data = samples.data.copy()
    rng = np.random.default_rng(5)
    for value in (np.nan, np.inf, -np.inf):
        data.flat[rng.choice(data.size, data.size // 100, replace=False)] = value
    broken = samples.with_data(data, declared_range=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the prefilter's warning about replaced voxels
        volume = volume_for(mode, broken)
    surface = outputs(volume, TORUS_CAMERA, derivatives=mode)
    assert (surface["curvature"][..., 3] == 1.0).sum() > 1000
    outputs(volume, TORUS_CAMERA, processor="CurvatureVolumeRaycaster", derivatives=mode)


def test_levels_outside_the_data_give_no_surface():
    """uint8 data in [0, 100] of the declared [0, 255]: level 0.9 lies above every value, level 0
    at or below every value (everything counts as inside): no crossing, no hit, the background."""
    values = (sample("sphere", 32, "uint8").data.astype(np.float64) * 100 / 255).round()
    volume = Volume(values.astype(np.uint8), spacing=(2 / 31,) * 3, origin=(-1.0,) * 3,
                    declared_range=(0.0, 255.0))
    for level in (0.9, 0.0):
        result = outputs(volume, derivatives="central", iso_level=level)
        assert not result["position"][..., 3].any(), level
        assert np.all(result["image"] == [0.0, 0.0, 0.0, 1.0])
    assert outputs(volume, derivatives="central", iso_level=0.2)["position"][..., 3].any()


def test_grazing_rays_hit_a_surface_point_with_its_curvature():
    """Camera in the torus's plane: rays graze the top and bottom of the tube. Curvature is
    computed at a point on the surface whatever the ray's angle, so grazing hits (next to a miss)
    are as accurate as the others, and every hit is defined."""
    torus = make_function("torus")
    coefficients = coefficients_of(sample(torus, 64, "float32"))
    camera = Camera(position=(3.0, 0.4, 0.0), focus=(0.0, 0.4, 0.0), up=(0, 0, 1), near=1.0,
                    far=5.0, fov=20)
    result = outputs(coefficients, camera, (96, 64), derivatives="tricubic")
    hit = result["curvature"][..., 3] == 1.0
    padded = np.pad(hit, 1)
    edge = hit & ~(padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
    assert edge.sum() > 50 and np.all(result["curvature"][..., 3] != 0.5)
    errors = relative_errors(result["curvature"], result["position"], torus, edge)
    assert np.percentile(errors, 95) < 2e-2
    # A plane seen exactly edge-on: the rays in it never cross the level; no hit, all finite.
    plane = sample(make_function("plane"), 32, "float32")
    edge_on = Camera(position=(3.0, 0.0, 0.0), focus=(0.0, 0.0, 0.0), near=1.0, far=5.0)
    assert outputs(plane, edge_on, derivatives="central")["position"][..., 3].sum() < 64
