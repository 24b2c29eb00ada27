"""GPU tricubic B-spline evaluation (vgraph.gl.tricubic, shaders/tricubic/) against exact cubic
polynomials and the CPU reference numerics.bspline.evaluate.

Errors are measured relative to the scale of each quantity: max |GPU - reference| over a point set
divided by max |reference| over the same set (value, gradient, Hessian separately). Tolerances
(docs/reports/accuracy.md, "Tricubic B-spline evaluation in GLSL"): measured on llvmpipe (float filter weights) at 2e-6 .. 1.4e-5;
set with margin, yet a wrong sign, axis or index gives errors of order 0.1 .. 1.
"""

import numpy as np
import pytest
from numpy.polynomial import Polynomial

from vgraph.errors import VGraphError
from vgraph.gl.tricubic import FETCHES, VARIANTS, evaluate_gl, variant_defines
from vgraph.implicit import sample
from vgraph.numerics.bspline import evaluate, prefilter
from vgraph.volume import Volume

TOLERANCE = {"direct": 2e-5, "fast": 5e-5}  # relative to scale, voxel-coordinate entry points
TEXTURE_SPACE_TOLERANCE = 5e-5  # + the float32 round trip u -> (u + 0.5) / n -> u
FAST_BOUND = 5e-5  # documented bound of the fast variant with float filter weights (n <= 64)
POINTS = 2500


@pytest.fixture(scope="module")
def ctx():
    from vgraph.gl_context import get_context
    return get_context()


def coefficients(data, spacing=(1.0, 1.0, 1.0)) -> Volume:
    return Volume(prefilter(data), spacing=spacing, is_spline_coefficients=True)


@pytest.fixture(scope="module")
def random_volume():
    """Prefiltered white noise on a grid with three different axis lengths (catches swapped axes)."""
    rng = np.random.default_rng(11)
    return coefficients(rng.standard_normal((21, 19, 17)))


@pytest.fixture(scope="module")
def smooth_volume():
    """A FunctionSelector volume: the torus sampled at 32^3 and prefiltered (world spacing 2/31)."""
    sampled = sample("torus", 32)
    return coefficients(sampled.data, sampled.spacing)


def random_points(volume: Volume, count=POINTS, margin=1.0, seed=0) -> np.ndarray:
    """Points (x, y, z) in [margin, n - 1 - margin], exactly representable in float32 so that the
    GPU and the reference evaluate the same points."""
    dims = np.array(volume.dims, dtype=np.float64)
    rng = np.random.default_rng(seed)
    points = rng.uniform(margin, dims - 1.0 - margin, size=(count, 3))
    return points.astype(np.float32).astype(np.float64)


def relative_errors(got, reference) -> dict[str, float]:
    errors = {}
    for name in ("value", "gradient", "hessian"):
        mine, ref = getattr(got, name), getattr(reference, name)
        if ref is not None:
            errors[name] = float(np.abs(mine - ref).max() / np.abs(ref).max())
    return errors


def assert_close(got, reference, tolerance):
    errors = relative_errors(got, reference)
    assert max(errors.values()) < tolerance, errors


# ------------------------------------------------------------------------- cubic polynomials

def cubic_polynomial_volume(shape_zyx, seed=3):
    """Coefficients whose spline is exactly P(x, y, z) = sum_m a_m(x) b_m(y) c_m(z) (cubics in
    each variable) wherever the stencil stays inside the grid, and P with exact derivatives.

    Per axis, sum_i q(i) B3(x - i) = q(x) + q''(x) / 6 for a cubic q, so coefficients
    q = a - a'' / 6 reproduce a. The factors live on [-1, 1] over the grid to keep values O(1)."""
    rng = np.random.default_rng(seed)
    nz, ny, nx = shape_zyx
    terms = [[Polynomial(rng.uniform(-1, 1, 4), domain=[0, n - 1], window=[-1, 1]) for n in (nx, ny, nz)]
             for _ in range(3)]
    grids = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")  # z, y, x
    coeffs = np.zeros(shape_zyx)
    for a, b, c in terms:
        coeffs += ((a - a.deriv(2) / 6)(grids[2]) * (b - b.deriv(2) / 6)(grids[1])
                   * (c - c.deriv(2) / 6)(grids[0]))

    def exact(points):
        x, y, z = points.T
        value, gradient, hessian = 0.0, np.zeros((len(points), 3)), np.zeros((len(points), 3, 3))
        for term in terms:
            factors = [[f.deriv(order)(u) if order else f(u) for order in range(3)]
                       for f, u in zip(term, (x, y, z))]
            value = value + factors[0][0] * factors[1][0] * factors[2][0]
            for i in range(3):
                for j in range(3):
                    orders = [0, 0, 0]
                    orders[i] += 1
                    orders[j] += 1
                    hessian[:, i, j] += np.prod([factors[k][orders[k]] for k in range(3)], axis=0)
                orders = [0, 0, 0]
                orders[i] = 1
                gradient[:, i] += np.prod([factors[k][orders[k]] for k in range(3)], axis=0)
        return value, gradient, hessian

    return coeffs.astype(np.float32), exact


@pytest.mark.parametrize("variant", VARIANTS)
def test_cubic_polynomials_are_reproduced_with_derivatives(ctx, variant):
    coeffs, exact = cubic_polynomial_volume((14, 13, 12))
    volume = Volume(coeffs, is_spline_coefficients=True)
    points = random_points(volume, 2000, margin=1.0, seed=4)  # stencil inside the grid
    got = evaluate_gl(ctx, volume, points, variant, derivatives=2)
    value, gradient, hessian = exact(points)
    errors = {"value": np.abs(got.value - value).max() / np.abs(value).max(),
              "gradient": np.abs(got.gradient - gradient).max() / np.abs(gradient).max(),
              "hessian": np.abs(got.hessian - hessian).max() / np.abs(hessian).max()}
    assert max(errors.values()) < TOLERANCE[variant], errors
    assert np.array_equal(got.hessian, np.swapaxes(got.hessian, -1, -2))


# ---------------------------------------------------------------------- against the CPU reference

@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("which", ["random_volume", "smooth_volume"])
@pytest.mark.parametrize("derivatives", [0, 1, 2])
def test_agrees_with_cpu_reference_inside_the_grid(ctx, request, variant, which, derivatives):
    volume = request.getfixturevalue(which)
    points = random_points(volume, seed=derivatives)
    reference = evaluate(volume.data, points, volume.spacing, derivatives)
    got = evaluate_gl(ctx, volume, points, variant, derivatives)
    assert (got.gradient is None) == (derivatives < 1) and (got.hessian is None) == (derivatives < 2)
    assert_close(got, reference, TOLERANCE[variant])


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("shape", [(21, 19, 17), (1, 9, 7)])
def test_boundary_is_mirrored_like_the_reference(ctx, variant, shape):
    """Points up to two voxels outside the grid (and an axis of length 1, which is constant):
    both variants mirror the coefficients as numerics.bspline does (sign of derivatives kept)."""
    data = np.random.default_rng(8).standard_normal(shape)
    volume = coefficients(data)
    dims = np.array(volume.dims, dtype=np.float64)
    rng = np.random.default_rng(9)
    points = rng.uniform(-2.0, dims + 1.0, size=(POINTS, 3)).astype(np.float32).astype(np.float64)
    reference = evaluate(volume.data, points, volume.spacing, 2)
    got = evaluate_gl(ctx, volume, points, variant, derivatives=2)
    if shape[0] == 1:  # constant along z: derivatives with respect to z vanish (up to the
        # float32 rounding of weights that sum to 0)
        assert np.abs(got.gradient[:, 2]).max() < 1e-6 * np.abs(got.gradient).max()
        assert np.abs(got.hessian[:, 2]).max() < 1e-6 * np.abs(got.hessian).max()
        reference = reference._replace(hessian=reference.hessian[:, :2, :2])
        got = got._replace(hessian=got.hessian[:, :2, :2])
    assert_close(got, reference, TOLERANCE[variant])


@pytest.mark.parametrize("variant", VARIANTS)
def test_texture_coordinate_entry_points_agree(ctx, random_volume, variant):
    """tricubic_jet(coeffs, p_texture, ...) as a ray caster calls it: the same results up to the
    float32 rounding of the texture coordinate."""
    points = random_points(random_volume, seed=12)
    reference = evaluate(random_volume.data, points, random_volume.spacing, 2)
    got = evaluate_gl(ctx, random_volume, points, variant, 2, texture_space=True)
    assert_close(got, reference, TEXTURE_SPACE_TOLERANCE)


# ---------------------------------------------------------------------------------- world units

@pytest.mark.parametrize("variant", VARIANTS)
def test_anisotropic_spacing_scales_derivatives(ctx, random_volume, variant):
    spacing = np.array([0.5, 2.0, 1.25])
    anisotropic = random_volume.with_data(random_volume.data, spacing=tuple(spacing))
    points = random_points(random_volume, seed=21)
    voxel = evaluate_gl(ctx, random_volume, points, variant, 2)
    world = evaluate_gl(ctx, anisotropic, points, variant, 2)
    np.testing.assert_allclose(world.value, voxel.value, rtol=0, atol=0)
    gradient_scale = np.abs(voxel.gradient).max()
    np.testing.assert_allclose(world.gradient * spacing, voxel.gradient, rtol=0,
                               atol=1e-6 * gradient_scale)
    hessian_scale = np.abs(voxel.hessian).max()
    np.testing.assert_allclose(world.hessian * np.outer(spacing, spacing), voxel.hessian, rtol=0,
                               atol=1e-6 * hessian_scale)
    reference = evaluate(anisotropic.data, points, anisotropic.spacing, 2)
    assert_close(world, reference, TOLERANCE[variant])


# ----------------------------------------------------------------------------- the fast variant

def test_fast_variant_error_is_within_its_documented_bound(ctx, random_volume, smooth_volume,
                                                           record_property):
    """The fast form's deviation from the reference (reported in the test's properties and on
    stdout with -s) stays below FAST_BOUND, and the direct form is at least as accurate."""
    worst = {}
    for name, volume in (("random", random_volume), ("torus", smooth_volume)):
        points = random_points(volume, seed=31)
        reference = evaluate(volume.data, points, volume.spacing, 2)
        fast = relative_errors(evaluate_gl(ctx, volume, points, "fast", 2), reference)
        direct = relative_errors(evaluate_gl(ctx, volume, points, "direct", 2), reference)
        for quantity, error in fast.items():
            worst[f"{name} {quantity}"] = error
            record_property(f"fast relative error, {name} {quantity}", error)
            assert direct[quantity] <= max(2.0 * error, 1e-6), (name, quantity, direct, fast)
    print("fast variant relative errors:", {k: f"{v:.1e}" for k, v in worst.items()})
    assert max(worst.values()) < FAST_BOUND, worst


def test_many_passes_give_the_same_results(ctx, random_volume, monkeypatch):
    """Point sets larger than one pass are split into passes (here 16 x 3 points per pass)."""
    import vgraph.gl.tricubic as tricubic
    points = random_points(random_volume, 500, seed=41)
    single = evaluate_gl(ctx, random_volume, points, "direct", 2)
    monkeypatch.setattr(tricubic, "PROBE_WIDTH", 16)
    monkeypatch.setattr(tricubic, "PROBE_MAX_ROWS", 3)
    split = evaluate_gl(ctx, random_volume, points, "direct", 2)
    for name in ("value", "gradient", "hessian"):
        assert np.array_equal(getattr(split, name), getattr(single, name)), name


def test_fetch_counts_and_defines():
    assert FETCHES == {"direct": (64, 64, 64), "fast": (8, 32, 92)}
    assert variant_defines("fast") == {"TRICUBIC_FAST": True}
    assert variant_defines("direct") == {"TRICUBIC_FAST": False}


# ---------------------------------------------------------------------------------- bad input

def test_non_finite_points_give_nan_and_shapes_follow_the_points(ctx, random_volume):
    points = np.array([[[3.0, 4.0, 5.0], [np.nan, 1.0, 1.0]], [[2.5, np.inf, 0.0], [6.0, 7.5, 8.25]]])
    got = evaluate_gl(ctx, random_volume, points, "fast", 2)
    reference = evaluate(random_volume.data, points, random_volume.spacing, 2)
    assert got.value.shape == (2, 2) and got.gradient.shape == (2, 2, 3)
    assert got.hessian.shape == (2, 2, 3, 3)
    assert np.array_equal(np.isnan(got.value), np.isnan(reference.value))
    assert np.isnan(got.hessian[0, 1]).all() and np.isnan(got.gradient[1, 0]).all()
    finite = ~np.isnan(reference.value)
    np.testing.assert_allclose(got.value[finite], reference.value[finite], atol=1e-4)
    assert evaluate_gl(ctx, random_volume, np.zeros((0, 3))).value.shape == (0,)


def test_refuses_bad_input(ctx, random_volume):
    samples = Volume(np.zeros((4, 4, 4), dtype=np.float32), source="ct.nrrd")
    with pytest.raises(VGraphError, match="CubicSplineProcessor"):
        evaluate_gl(ctx, samples, np.zeros((1, 3)))
    integers = Volume(np.zeros((4, 4, 4), dtype=np.uint8), is_spline_coefficients=True,
                      source="coeffs.raw")
    with pytest.raises(VGraphError, match=r"coeffs\.raw.*float data.*uint8"):
        evaluate_gl(ctx, integers, np.zeros((1, 3)))
    with pytest.raises(VGraphError, match="variant must be one of direct, fast, got 'cubic'"):
        evaluate_gl(ctx, random_volume, np.zeros((1, 3)), variant="cubic")
    with pytest.raises(VGraphError, match="derivatives must be 0, 1 or 2, got 3"):
        evaluate_gl(ctx, random_volume, np.zeros((1, 3)), derivatives=3)
    with pytest.raises(VGraphError, match=r"shape \(\.\.\., 3\).*\(4, 2\)"):
        evaluate_gl(ctx, random_volume, np.zeros((4, 2)))
