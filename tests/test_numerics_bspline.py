"""Cubic B-spline prefilter and tricubic evaluation against scipy.ndimage and exact polynomials."""

from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import polynomial as P
from scipy import ndimage

from vgraph.numerics.bspline import (
    bspline_kernel,
    bspline_weights,
    causal_start_weights,
    evaluate,
    mirror_index,
    prefilter,
)

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def scipy_coefficients(data):
    return ndimage.spline_filter(np.asarray(data), order=3, mode="mirror", output=np.float64)


def assert_float32_agreement(ours, reference):
    """ours is the float32 rounding of the float64 reference, up to float64 noise."""
    reference = np.asarray(reference, dtype=np.float64)
    assert ours.dtype == np.float32 and ours.shape == reference.shape
    half_ulp = 0.5 * np.spacing(np.abs(reference).astype(np.float32)).astype(np.float64)
    noise = 1e-12 * max(1.0, float(np.abs(reference).max()))
    excess = np.abs(ours.astype(np.float64) - reference) - (half_ulp + noise)
    assert excess.max() <= 0, f"worst excess over float32 rounding: {excess.max():.3g}"


# --- prefilter ---------------------------------------------------------------------------------

SHAPES = [(1, 1, 1), (1, 1, 5), (2, 2, 2), (1, 2, 3), (2, 3, 1), (5, 1, 7), (3, 40, 37),
          (17, 16, 33), (40, 3, 2), (37, 36, 35), (6, 50, 4)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("dtype", [np.float32, np.uint8, np.int16, np.float64])
def test_prefilter_matches_scipy_on_random_data(shape, dtype):
    rng = np.random.default_rng(sum(shape))
    data = (rng.random(shape) * 200 - (50 if dtype in (np.int16, np.float32) else 0)).astype(dtype)
    assert_float32_agreement(prefilter(data), scipy_coefficients(data))


def test_prefilter_long_axis_uses_the_truncated_start_sum_without_loss():
    data = np.random.default_rng(5).normal(size=(3, 2, 300)).astype(np.float32)
    assert len(causal_start_weights(300)) < 300
    assert_float32_agreement(prefilter(data), scipy_coefficients(data))


def test_prefilter_is_exact_on_constants_and_linear_ramps():
    assert np.all(prefilter(np.full((4, 5, 6), 7.0)) == np.float32(7.0))
    # a linear ramp is its own coefficient sequence in the interior (B-splines reproduce lines)
    ramp = np.broadcast_to(np.arange(80.0), (3, 4, 80))
    coefficients = prefilter(ramp)
    assert np.allclose(coefficients[:, :, 20:60], ramp[:, :, 20:60], atol=1e-4)


def test_prefilter_threads_and_memory_layout_do_not_change_the_result():
    data = np.random.default_rng(7).random((20, 30, 40)).astype(np.float32)
    single = prefilter(data, workers=1)
    assert np.array_equal(prefilter(data, workers=2), single)
    fortran = np.asfortranarray(data)
    assert np.array_equal(prefilter(fortran), single)
    transposed = data.transpose(2, 1, 0)  # a non-contiguous view of another volume
    assert_float32_agreement(prefilter(transposed), scipy_coefficients(transposed))


@pytest.mark.parametrize("shape", [(1, 1, 5), (1, 4, 1), (6, 5, 4)])
def test_prefilter_leaves_its_input_alone(shape):
    data = np.random.default_rng(8).random(shape)
    before = data.copy()
    prefilter(data)
    assert np.array_equal(data, before)


def test_prefilter_reports_progress_up_to_one():
    seen = []
    prefilter(np.zeros((4, 4, 4)), progress=seen.append)
    assert seen == sorted(seen) and seen[-1] == 1.0 and len(seen) >= 3


@pytest.mark.parametrize("bad", [np.zeros((4, 4)), np.zeros((0, 3, 3)), np.array([[["a"]]])])
def test_prefilter_rejects_bad_volumes(bad):
    with pytest.raises(ValueError, match="prefilter"):
        prefilter(bad)


def _raw(folder, name, dtype, shape):
    path = DATA / folder / name
    if not path.is_file():
        pytest.skip(f"data set {path} not found (shared/data is not part of the repository)")
    return np.fromfile(path, dtype=dtype).reshape(shape)


def _engine():
    path = DATA / "ct_engine" / "engine.nii.gz"
    if not path.is_file():
        pytest.skip(f"data set {path} not found (shared/data is not part of the repository)")
    nibabel = pytest.importorskip("nibabel")
    xyz = np.asanyarray(nibabel.load(str(path)).dataobj)  # nibabel arrays are [x, y, z]
    return xyz.transpose(2, 1, 0)  # -> [z, y, x]


REAL_DATA = {
    "mri_head_tiny": lambda: _raw("mri_head_tiny", "HeadMRVolume.raw", np.uint8, (42, 62, 48)),
    "sim_neghip": lambda: _raw("sim_neghip", "neghip_66x66x66_uint8.raw", np.uint8, (66, 66, 66)),
    "sim_hydrogen": lambda: _raw("sim_hydrogen", "hydrogen_64x64x64_float32.raw", "<f4", (64, 64, 64)),
    "ct_engine": _engine,
}


@pytest.mark.parametrize("name", sorted(REAL_DATA))
def test_prefilter_matches_scipy_on_real_data(name):
    data = REAL_DATA[name]()
    assert data.ndim == 3 and np.ptp(data) > 0  # a real, non-constant volume was loaded
    assert_float32_agreement(prefilter(data), scipy_coefficients(data))


@pytest.mark.parametrize("function", ["sphere", "torus", "marschner_lobb", "genus2"])
@pytest.mark.parametrize("data_type", ["float32", "uint8"])
def test_prefilter_matches_scipy_on_implicit_function_volumes(function, data_type):
    from vgraph.implicit import FUNCTIONS, sample
    if function not in FUNCTIONS:
        pytest.skip(f"no implicit function {function!r} registered")
    volume = sample(function, 33, data_type, progress=False)
    assert_float32_agreement(prefilter(volume.data), scipy_coefficients(volume.data))


# --- kernels -----------------------------------------------------------------------------------

def test_kernel_formulas_and_weights_agree():
    x = np.linspace(-2.5, 2.5, 1001)
    assert np.allclose(bspline_kernel(x)[np.abs(x) >= 2], 0.0)
    assert bspline_kernel(0.0) == pytest.approx(2 / 3) and bspline_kernel(1.0) == pytest.approx(1 / 6)
    h = 1e-6  # B3' and B3'' are the derivatives of B3 and B3'
    for order in (1, 2):
        numeric = (bspline_kernel(x + h, order - 1) - bspline_kernel(x - h, order - 1)) / (2 * h)
        assert np.allclose(bspline_kernel(x, order), numeric, atol=1e-5)
    t = np.random.default_rng(0).random(200)
    for order in range(3):
        expected = np.stack([bspline_kernel(t - m, order) for m in (-1, 0, 1, 2)], axis=-1)
        assert np.allclose(bspline_weights(t, order), expected, atol=1e-15)
        assert np.allclose(bspline_weights(t, order).sum(-1), 1.0 if order == 0 else 0.0)


def test_mirror_index_folds_like_whole_sample_mirroring():
    assert mirror_index(np.arange(-4, 9), 4).tolist() == [2, 3, 2, 1, 0, 1, 2, 3, 2, 1, 0, 1, 2]
    assert mirror_index(np.array([-3, 0, 5]), 1).tolist() == [0, 0, 0]


# --- evaluation --------------------------------------------------------------------------------

def _tensor_cubic(rng, centre):
    """A random polynomial of degree <= 3 in each variable, in coordinates centred at `centre`."""
    a = rng.normal(size=(4, 4, 4)) / (1.0 + np.add.outer(np.add.outer(np.arange(4), np.arange(4)),
                                                       np.arange(4)))
    def derivative(orders):
        coef = a
        for axis, order in enumerate(orders):
            coef = P.polyder(coef, order, axis=axis) if order else coef
        return lambda x, y, z: P.polyval3d(x - centre, y - centre, z - centre, coef)
    return derivative


def _exact_spline_coefficients(derivative, n):
    """c = (1 - Dxx/6)(1 - Dyy/6)(1 - Dzz/6) p on the grid: the B-spline then IS p (tensor cubic)."""
    z, y, x = np.meshgrid(*[np.arange(n, dtype=np.float64)] * 3, indexing="ij")
    total = np.zeros_like(x)
    for ox in (0, 2):
        for oy in (0, 2):
            for oz in (0, 2):
                factor = (-1 / 6) ** ((ox + oy + oz) // 2)
                total += factor * derivative((ox, oy, oz))(x, y, z)
    return total


def _analytic(derivative, points, spacing):
    x, y, z = points.T
    value = derivative((0, 0, 0))(x, y, z)
    gradient = np.stack([derivative(tuple(int(i == a) for i in range(3)))(x, y, z) / spacing[a]
                         for a in range(3)], axis=-1)
    hessian = np.empty((len(points), 3, 3))
    for a in range(3):
        for b in range(3):
            orders = [0, 0, 0]
            orders[a] += 1
            orders[b] += 1
            hessian[:, a, b] = derivative(tuple(orders))(x, y, z) / (spacing[a] * spacing[b])
    return value, gradient, hessian


def test_tricubic_reproduces_cubic_polynomials_exactly():
    rng = np.random.default_rng(11)
    n = 10
    derivative = _tensor_cubic(rng, centre=4.5)
    coefficients = _exact_spline_coefficients(derivative, n)
    points = rng.uniform(1.0, n - 2.0 - 1e-9, size=(400, 3))  # all 64 coefficients inside the grid
    spacing = np.array([0.5, 2.0, 1.25])
    sample = evaluate(coefficients, points, spacing=spacing, derivatives=2)
    value, gradient, hessian = _analytic(derivative, points, spacing)
    scale = np.abs(value).max()
    assert np.allclose(sample.value, value, rtol=0, atol=1e-12 * scale)
    assert np.allclose(sample.gradient, gradient, rtol=0, atol=1e-11 * scale)
    assert np.allclose(sample.hessian, hessian, rtol=0, atol=1e-10 * scale)


def test_prefilter_then_evaluate_reproduces_cubic_polynomials_away_from_the_boundary():
    rng = np.random.default_rng(12)
    n = 64
    derivative = _tensor_cubic(rng, centre=32.0)
    scaled = lambda orders: (lambda x, y, z: derivative(orders)(  # noqa: E731 - values of order 1
        32 + (x - 32) / 16, 32 + (y - 32) / 16, 32 + (z - 32) / 16) / 16.0 ** sum(orders))
    z, y, x = np.meshgrid(*[np.arange(n, dtype=np.float64)] * 3, indexing="ij")
    coefficients = prefilter(scaled((0, 0, 0))(x, y, z))
    # 27 voxels from the boundary the mirror's influence is z^27 ~ 4e-16; float32 rounding remains
    points = rng.uniform(27.0, 36.0, size=(300, 3))
    sample = evaluate(coefficients, points, derivatives=2)
    value, gradient, hessian = _analytic(scaled, points, np.ones(3))
    assert np.abs(sample.value - value).max() < 5e-8  # values are O(1) here
    assert np.abs(sample.gradient - gradient).max() < 1e-7
    assert np.abs(sample.hessian - hessian).max() < 2e-7
    # with float64 coefficients only the (negligible) boundary influence is left
    exact = evaluate(scipy_coefficients(scaled((0, 0, 0))(x, y, z)), points, derivatives=2)
    assert np.abs(exact.value - value).max() < 1e-12
    assert np.abs(exact.hessian - hessian).max() < 1e-12


def test_values_agree_with_scipy_map_coordinates_including_the_boundary():
    rng = np.random.default_rng(13)
    data = rng.random((9, 12, 7)) * 100
    nz, ny, nx = data.shape
    upper = np.array([nx, ny, nz]) - 1.0
    points = np.concatenate([
        rng.uniform(-0.5, upper + 0.5, size=(3000, 3)),  # near and just outside the boundary
        rng.uniform(-2 * upper, 3 * upper, size=(500, 3)),  # far outside: repeated mirroring
        np.array([[0, 0, 0], upper, [0, upper[1], 0.5]]),  # exact corners and edges
    ])
    at = points[:, ::-1].T  # map_coordinates wants (z, y, x)
    coefficients64 = scipy_coefficients(data)
    ours64 = evaluate(coefficients64, points).value
    reference = ndimage.map_coordinates(coefficients64, at, order=3, mode="mirror", prefilter=False)
    assert np.abs(ours64 - reference).max() < 1e-11
    # the whole pipeline, with our float32 coefficients, against scipy's own prefiltering
    ours = evaluate(prefilter(data), points).value
    reference = ndimage.map_coordinates(data, at, order=3, mode="mirror")
    assert np.abs(ours - reference).max() < 1e-5 * np.abs(data).max()


def test_spline_interpolates_the_samples():
    data = np.random.default_rng(14).random((5, 6, 7)).astype(np.float32)
    k, j, i = np.meshgrid(*[np.arange(n) for n in data.shape], indexing="ij")
    centres = np.stack([i, j, k], axis=-1).astype(np.float64)
    assert np.allclose(evaluate(prefilter(data), centres).value, data, atol=2e-6)


def test_derivatives_are_the_derivatives_of_the_value():
    rng = np.random.default_rng(15)
    coefficients = rng.random((8, 9, 10))
    points = rng.uniform(-1.5, 9.5, size=(200, 3))  # inside, near and outside the grid
    points += 0.25 * (np.abs(points - np.round(points)) < 1e-3)  # keep off the knots
    h = 1e-5
    sample = evaluate(coefficients, points, derivatives=2)
    for a in range(3):
        step = np.zeros(3)
        step[a] = h
        plus, minus = evaluate(coefficients, points + step, derivatives=1), \
            evaluate(coefficients, points - step, derivatives=1)
        assert np.allclose(sample.gradient[:, a], (plus.value - minus.value) / (2 * h), atol=1e-7)
        assert np.allclose(sample.hessian[:, :, a], (plus.gradient - minus.gradient) / (2 * h),
                           atol=1e-6)
    assert np.allclose(sample.hessian, np.swapaxes(sample.hessian, 1, 2))


def test_mirror_boundary_makes_the_spline_even_about_the_end_samples():
    coefficients = np.random.default_rng(16).random((6, 7, 8))
    inside = np.array([[0.3, 2.0, 1.0], [6.6, 5.2, 4.1]])
    mirrored = inside.copy()
    mirrored[0, 0] = -0.3  # reflect x about voxel 0
    mirrored[1, 0] = 2 * 7 - 6.6  # reflect x about voxel nx - 1 = 7
    a = evaluate(coefficients, inside, derivatives=1)
    b = evaluate(coefficients, mirrored, derivatives=1)
    assert np.allclose(a.value, b.value, atol=1e-14)
    assert np.allclose(a.gradient[:, 0], -b.gradient[:, 0], atol=1e-13)  # slope flips sign
    assert np.allclose(a.gradient[:, 1:], b.gradient[:, 1:], atol=1e-13)


def test_anisotropic_spacing_scales_derivatives_to_world_units():
    rng = np.random.default_rng(17)
    coefficients = rng.random((7, 7, 7))
    points = rng.uniform(0, 6, size=(50, 3))
    spacing = np.array([0.5, 2.0, 3.0])
    unit = evaluate(coefficients, points, derivatives=2)
    world = evaluate(coefficients, points, spacing=tuple(spacing), derivatives=2)
    assert np.array_equal(world.value, unit.value)
    assert np.allclose(world.gradient, unit.gradient / spacing)
    assert np.allclose(world.hessian, unit.hessian / np.outer(spacing, spacing))


def test_evaluate_shapes_nonfinite_points_and_errors():
    coefficients = np.ones((4, 4, 4), dtype=np.float32)
    sample = evaluate(coefficients, np.full((2, 5, 3), 1.5), derivatives=2)
    assert sample.value.shape == (2, 5) and sample.gradient.shape == (2, 5, 3)
    assert sample.hessian.shape == (2, 5, 3, 3)
    assert np.allclose(sample.value, 1.0) and np.allclose(sample.gradient, 0.0)
    only_value = evaluate(coefficients, [1.0, 2.0, 3.0])
    assert only_value.gradient is None and only_value.hessian is None
    assert only_value.value.shape == () and float(only_value.value) == pytest.approx(1.0)
    bad = evaluate(coefficients, [[np.nan, 1, 1], [1, 1, 1], [np.inf, 0, 0]], derivatives=1)
    assert np.isnan(bad.value[[0, 2]]).all() and bad.value[1] == pytest.approx(1.0)
    assert np.isnan(bad.gradient[0]).all() and np.isfinite(bad.gradient[1]).all()
    with pytest.raises(ValueError, match="derivatives"):
        evaluate(coefficients, [[1, 1, 1]], derivatives=3)
    with pytest.raises(ValueError, match=r"points must have shape \(\.\.\., 3\)"):
        evaluate(coefficients, [[1, 1]])
    with pytest.raises(ValueError, match="spacing"):
        evaluate(coefficients, [[1, 1, 1]], spacing=(1, 0, 1))
