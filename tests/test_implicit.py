"""Tests of vgraph.implicit: exact derivatives against finite differences, exact curvature against
closed forms, sampling layout and value mapping, topology of the sampled solids, validation."""

import dataclasses
import math

import numpy as np
import pytest

from vgraph.errors import PropertyError
from vgraph.implicit import (FUNCTIONS, Cylinder, Ellipsoid, Genus2, Hyperboloid, ImplicitFunction,
                             MarschnerLobb, Plane, RoundedCube, Saddle, Sphere, StiffShell, Torus,
                             exact_curvature, level_to_value, make_function, sample, value_to_level)
from vgraph.implicit import sampling

REQUIRED = {"sphere", "torus", "ellipsoid", "rounded_cube", "saddle", "marschner_lobb", "genus2",
            "stiff_shell", "cylinder", "plane"}


# --- helpers ------------------------------------------------------------------------------------
def _torus_singular_distance(p, centre_x, big):
    rho = np.hypot(p[:, 0] - centre_x, p[:, 1])
    return np.minimum(rho, np.hypot(rho - big, p[:, 2]))


def _distance_to_singular_set(fn, p):
    """Distance of each point to where fn's form is not smooth (inf where it is smooth)."""
    if isinstance(fn, (Sphere, Ellipsoid, RoundedCube, StiffShell)):
        return np.linalg.norm(p, axis=1)
    if isinstance(fn, Cylinder):
        return np.hypot(p[:, 0], p[:, 1])
    if isinstance(fn, Torus):
        return _torus_singular_distance(p, 0.0, fn.major_radius)
    if isinstance(fn, Genus2):
        h = fn.separation / 2
        return np.minimum(_torus_singular_distance(p, h, fn.major_radius),
                          _torus_singular_distance(p, -h, fn.major_radius))
    return np.full(len(p), np.inf)


def _fd_gradient(fn, p, h=1e-4):
    out = np.empty((len(p), 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        out[:, i] = (-fn.value(p + 2 * e) + 8 * fn.value(p + e) - 8 * fn.value(p - e)
                     + fn.value(p - 2 * e)) / (12 * h)
    return out


def _fd_hessian(fn, p, h=1e-3):
    out = np.empty((len(p), 3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        out[:, :, j] = (-_fd_gradient(fn, p + 2 * e) + 8 * _fd_gradient(fn, p + e)
                        - 8 * _fd_gradient(fn, p - e) + _fd_gradient(fn, p - 2 * e)) / (12 * h)
    return out


def _euler_characteristic(solid):
    """Euler characteristic of the union of closed unit cubes at the True voxels."""
    s = np.pad(solid, 1)
    cubes = s.sum()
    counts = []
    for dims in ((0,), (1,), (2,), (0, 1), (0, 2), (1, 2), (0, 1, 2)):
        cell = s.copy()  # a cell of the dual lattice is present if any voxel touching it is
        for axis in dims:
            cell = cell[(slice(None),) * axis + (slice(1, None),)] | \
                cell[(slice(None),) * axis + (slice(None, -1),)]
        counts.append(cell.sum())
    faces = sum(counts[:3])
    edges = sum(counts[3:6])
    vertices = counts[6]
    return int(vertices - edges + faces - cubes)


# --- registry and derivatives -------------------------------------------------------------------
def test_registry_holds_the_required_functions_with_unit_boxes():
    assert REQUIRED <= set(FUNCTIONS)
    for name, cls in FUNCTIONS.items():
        fn = cls()
        assert fn.name == name
        assert fn.box == ((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(fn, next(iter(fn.parameters())), 0.5)


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_gradient_and_hessian_match_finite_differences(name):
    fn = FUNCTIONS[name]()
    rng = np.random.default_rng(7)
    p = rng.uniform(-0.95, 0.95, (400, 3))
    p = p[_distance_to_singular_set(fn, p) > 0.05][:60]
    v, g, h = fn.jet(p)
    np.testing.assert_array_equal(v, fn.value(p))
    np.testing.assert_array_equal(g, fn.gradient(p))
    np.testing.assert_array_equal(h, fn.hessian(p))
    g_scale, h_scale = max(1.0, np.abs(g).max()), max(1.0, np.abs(h).max())
    assert np.abs(g - _fd_gradient(fn, p)).max() < 1e-8 * g_scale
    assert np.abs(h - _fd_hessian(fn, p)).max() < 1e-5 * h_scale
    np.testing.assert_allclose(h, np.swapaxes(h, 1, 2), atol=1e-12 * h_scale)


def test_marschner_lobb_derivatives_are_exact_on_its_axis():
    fn = MarschnerLobb(alpha=0.25, f_m=6.3)  # non-integer f_M: the radial term curves at r = 0
    # on the axis and within r < 0.03, where the radial term switches to its series form
    p = np.array([[0.0, 0.0, -0.6], [0.0, 0.0, 0.0], [0.0, 0.0, 0.35], [0.01, 0.005, 0.2],
                  [-0.02, 0.01, -0.3]])
    h = fn.hessian(p)
    np.testing.assert_allclose(h, _fd_hessian(fn, p), atol=1e-5 * np.abs(h).max())
    np.testing.assert_array_equal(fn.gradient(p)[:3, :2], 0.0)
    assert abs(h[0, 0, 0]) > 1.0


def test_stiff_shell_at_sharpness_1000_stays_finite():
    fn = StiffShell(radius=0.6, thickness=0.2, sharpness=1000.0)
    rng = np.random.default_rng(3)
    special = [[0, 0, 0], [1e-80, 0, 0], [0.7, 0, 0], [0.5, 0, 0], [0.6, 0, 0], [1, 1, 1]]
    p = np.vstack([rng.uniform(-1, 1, (2000, 3)), special])
    v, g, h = fn.jet(p)
    assert np.isfinite(v).all() and np.isfinite(g).all() and np.isfinite(h).all()
    assert np.abs(v).max() <= 1.0
    # |grad u| = 1 on both surfaces, so |grad f| = sharpness there; the sign says which side is in
    np.testing.assert_allclose(g[-4], [-1000.0, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(g[-3], [1000.0, 0, 0], rtol=1e-12)
    curv = exact_curvature(fn, [[0.7, 0, 0], [0, 0.5, 0]])
    np.testing.assert_allclose(curv.k1, [1 / 0.7, -1 / 0.5], rtol=1e-9)
    np.testing.assert_allclose(curv.k2, [1 / 0.7, -1 / 0.5], rtol=1e-9)


# --- exact curvature against closed forms -------------------------------------------------------
def test_sphere_curvature_is_one_over_radius_on_every_level_set():
    p = np.array([[0.5, 0, 0], [0, 0.3, 0.4], [0.1, 0.2, 0.2]])
    curv = exact_curvature(Sphere(radius=0.5), p)
    expected = 1 / np.linalg.norm(p, axis=1)
    for k in (curv.k1, curv.k2, curv.H):
        np.testing.assert_allclose(k, expected, rtol=1e-12)
    np.testing.assert_allclose(curv.K, expected**2, rtol=1e-12)


def test_torus_curvature_at_equators_and_top():
    big, small = 0.55, 0.25
    p = [[big + small, 0, 0], [0, -(big - small), 0], [big, 0, small]]
    curv = exact_curvature(Torus(major_radius=big, minor_radius=small), p)
    np.testing.assert_allclose(curv.k1, [1 / small] * 3, rtol=1e-12)
    np.testing.assert_allclose(curv.k2, [1 / (big + small), -1 / (big - small), 0], atol=1e-12)
    assert curv.K[0] > 0 and curv.K[1] < 0


def test_cylinder_and_plane_have_zero_gaussian_curvature():
    curv = exact_curvature(Cylinder(radius=0.4), [[0.4, 0, 0.3], [0, -0.4, -0.7]])
    np.testing.assert_allclose(curv.k1, 2.5, rtol=1e-12)
    np.testing.assert_allclose(curv.K, 0.0, atol=1e-12)
    np.testing.assert_allclose(curv.H, 1.25, rtol=1e-12)
    plane = Plane(normal=(1.0, 2.0, -2.0), offset=0.3)
    assert plane.normal == pytest.approx((1 / 3, 2 / 3, -2 / 3))
    curv = exact_curvature(plane, [[0.1, 0.1, 0.1], [0.1, 0.0, 0.0]])
    assert np.all(curv.k1 == 0) and np.all(curv.k2 == 0)


def test_ellipsoid_gaussian_curvature_matches_closed_form():
    a, b, c = 0.8, 0.6, 0.4
    rng = np.random.default_rng(1)
    theta, phi = rng.uniform(0, np.pi, 50), rng.uniform(0, 2 * np.pi, 50)
    p = np.stack([a * np.sin(theta) * np.cos(phi), b * np.sin(theta) * np.sin(phi),
                  c * np.cos(theta)], axis=1)
    fn = Ellipsoid(a=a, b=b, c=c)
    np.testing.assert_allclose(fn.value(p), 0.0, atol=1e-12)
    expected = 1 / (a * b * c * ((p[:, 0] / a**2) ** 2 + (p[:, 1] / b**2) ** 2
                                 + (p[:, 2] / c**2) ** 2)) ** 2
    curv = exact_curvature(fn, p)
    np.testing.assert_allclose(curv.K, expected, rtol=1e-10)
    assert np.all(curv.k2 > 0)  # convex, curving towards the interior
    np.testing.assert_allclose(exact_curvature(fn, [[a, 0, 0]]).k1, a / c**2, rtol=1e-12)


def test_hyperboloid_and_saddle_have_negative_gaussian_curvature():
    a, b, c = 0.45, 0.35, 0.5
    rng = np.random.default_rng(2)
    t, s = rng.uniform(-1, 1, 40), rng.uniform(0, 2 * np.pi, 40)
    p = np.stack([a * np.cosh(t) * np.cos(s), b * np.cosh(t) * np.sin(s), c * np.sinh(t)], axis=1)
    fn = Hyperboloid(a=a, b=b, c=c)
    np.testing.assert_allclose(fn.value(p), 0.0, atol=1e-12)
    expected = -1 / (a * b * c * ((p[:, 0] / a**2) ** 2 + (p[:, 1] / b**2) ** 2
                                  + (p[:, 2] / c**2) ** 2)) ** 2
    np.testing.assert_allclose(exact_curvature(fn, p).K, expected, rtol=1e-10)

    radius = 0.75
    xy = rng.uniform(-0.9, 0.9, (40, 2))
    p = np.column_stack([xy, (xy[:, 0] ** 2 - xy[:, 1] ** 2) / (2 * radius)])
    curv = exact_curvature(Saddle(curvature_radius=radius), p)
    expected = -(1 / radius**2) / (1 + (xy**2).sum(axis=1) / radius**2) ** 2
    np.testing.assert_allclose(curv.K, expected, rtol=1e-10)
    at_origin = exact_curvature(Saddle(curvature_radius=radius), [[0, 0, 0]])
    assert at_origin.k1[0] == pytest.approx(1 / radius) and at_origin.k2[0] == pytest.approx(-1 / radius)
    assert at_origin.H[0] == pytest.approx(0.0, abs=1e-12)


def test_rounded_cube_levels_are_convex_with_closed_form_gaussian_curvature():
    n = 4
    fn = RoundedCube(half_width=0.65, exponent=n)
    rng = np.random.default_rng(4)
    d = rng.normal(size=(60, 3))
    for level_radius in (0.65, 0.3):  # two level sets: every level is a scaled rounded cube
        p = level_radius * d / (np.abs(d) ** n).sum(axis=1, keepdims=True) ** (1 / n)
        grad_f = n * p ** (n - 1)  # closed form for F = x^n + y^n + z^n (same level sets)
        hess_diag = n * (n - 1) * p ** (n - 2)
        adj = np.stack([hess_diag[:, 1] * hess_diag[:, 2], hess_diag[:, 0] * hess_diag[:, 2],
                        hess_diag[:, 0] * hess_diag[:, 1]], axis=1)
        expected = (grad_f**2 * adj).sum(axis=1) / (grad_f**2).sum(axis=1) ** 2
        curv = exact_curvature(fn, p)
        np.testing.assert_allclose(curv.K, expected, rtol=1e-9)
        assert np.all(curv.K >= 0) and np.all(curv.k2 >= -1e-12)
    face_centre = exact_curvature(fn, [[0.65, 0, 0]])
    assert face_centre.K[0] == pytest.approx(0.0, abs=1e-12)


def test_curvature_is_zero_not_nan_where_the_gradient_vanishes():
    curv = exact_curvature(Sphere(), [[0.0, 0.0, 0.0]])
    assert all(np.isfinite(k).all() and k[0] == 0 for k in (curv.k1, curv.k2, curv.K, curv.H))
    assert not curv.defined[0]


# --- sampling -----------------------------------------------------------------------------------
@pytest.mark.parametrize("data_type,dtype,full_scale", [
    ("uint8", np.uint8, 255), ("uint16", np.uint16, 65535), ("float32", np.float32, None)])
def test_sample_layout_and_value_mapping(data_type, dtype, full_scale):
    fn = Ellipsoid(a=0.8, b=0.6, c=0.4)  # three different axes catch any [z, y, x] mix-up
    vol = sample(fn, 17, data_type)
    assert vol.data.shape == (17, 17, 17) and vol.data.dtype == dtype
    assert vol.spacing == pytest.approx((0.125, 0.125, 0.125))
    assert vol.origin == (-1.0, -1.0, -1.0)
    axis = np.linspace(-1, 1, 17)
    zz, yy, xx = np.meshgrid(axis, axis, axis, indexing="ij")
    f = fn.value(np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1)).reshape(zz.shape)
    m = np.abs(f).max()
    assert vol.value_scale == pytest.approx(m, rel=1e-15)
    if full_scale is None:
        assert vol.value_range == pytest.approx((-m, m))
        np.testing.assert_array_equal(vol.data, f.astype(np.float32))
    else:
        assert vol.value_range == (0.0, float(full_scale))
        np.testing.assert_array_equal(vol.data, np.rint((f / (2 * m) + 0.5) * full_scale))
    np.testing.assert_allclose(vol.normalized(vol.data), value_to_level(f, m),
                               atol=0.51 / (full_scale or 1e6))


@pytest.mark.parametrize("data_type,tolerance", [
    ("float32", 1e-6), ("uint16", 1e-4), ("uint8", 0.6 * 2 * 1.04 / 255)])
def test_sampled_sphere_surface_sits_at_half_intensity(data_type, tolerance):
    radius = 0.7
    vol = sample(Sphere(radius=radius), 65, data_type)
    profile = vol.normalized(vol.data[32, 32, 32:])  # +x half of the axis through the centre
    x = vol.origin[0] + vol.spacing[0] * np.arange(32, 65)

    def crossing(level):
        i = np.nonzero(profile < level)[0][0]
        t = (profile[i - 1] - level) / (profile[i - 1] - profile[i])
        return x[i - 1] + t * (x[i] - x[i - 1])
    assert crossing(0.5) == pytest.approx(radius, abs=tolerance)
    # another normalised level is the level set f = (2L - 1) m, i.e. a sphere of radius r - f
    assert crossing(0.6) == pytest.approx(radius - vol.level_to_value(0.6), abs=tolerance)
    assert vol.level_to_value(0.6) == pytest.approx(float(level_to_value(0.6, vol.value_scale)))
    assert vol.value_to_level(vol.level_to_value(0.37)) == pytest.approx(0.37)


def test_sampling_in_small_slabs_gives_the_same_volume(monkeypatch):
    whole = sample("genus2", 20, "uint16")
    monkeypatch.setattr(sampling, "_SLAB_POINTS", 1000)  # 2 z-planes per slab, 10 slabs
    sliced = sample("genus2", 20, "uint16", progress=False)
    np.testing.assert_array_equal(whole.data, sliced.data)
    assert whole.value_scale == sliced.value_scale


def test_constant_zero_function_samples_at_half_intensity():
    @dataclasses.dataclass(frozen=True)
    class Zero(ImplicitFunction):
        name = "zero"

        def _field(self, x, y, z):
            return x * 0.0

    vol = sample(Zero(), 16, "uint8")
    assert vol.value_scale == 1.0
    assert np.all(vol.data == 128)


@pytest.mark.parametrize("name,euler", [("sphere", 1), ("torus", 0), ("genus2", -1),
                                        ("stiff_shell", 2), ("rounded_cube", 1)])
def test_sampled_solids_have_the_documented_topology(name, euler):
    vol = sample(name, 64, "float32")
    assert _euler_characteristic(vol.data > 0) == euler


def test_genus2_has_two_holes_joined_in_one_solid():
    fn = Genus2()
    h = fn.separation / 2
    assert np.all(fn.value([[h, 0, 0], [-h, 0, 0]]) < 0)  # the holes
    assert np.all(fn.value([[0, 0, 0], [h + fn.major_radius, 0, 0], [0, 0.3, 0]]) > 0)


# --- validation ---------------------------------------------------------------------------------
@pytest.mark.parametrize("call,message", [
    (lambda: Sphere(radius=2.0), "function 'sphere', parameter 'radius': must be in [0.05, 0.9], got 2.0"),
    (lambda: Sphere(radius="big"), "parameter 'radius': must be a number, got 'big'"),
    (lambda: Sphere(radius=True), "parameter 'radius': must be a number"),
    (lambda: Torus(major_radius=0.3, minor_radius=0.3), "parameter 'minor_radius': must be <= major_radius - 0.05"),
    (lambda: Torus(major_radius=0.7, minor_radius=0.3), "parameter 'major_radius': major_radius + minor_radius must be <= 0.9"),
    (lambda: StiffShell(sharpness=0.0), "parameter 'sharpness': must be in (0, 1000], got 0.0"),
    (lambda: StiffShell(sharpness=1001), "parameter 'sharpness': must be in (0, 1000], got 1001"),
    (lambda: StiffShell(sharpness=float("nan")), "parameter 'sharpness': must be in (0, 1000]"),
    (lambda: MarschnerLobb(alpha=1.0), "parameter 'alpha': must be in [0, 1), got 1.0"),
    (lambda: RoundedCube(exponent=3), "parameter 'exponent': must be an even integer in [2, 16], got 3"),
    (lambda: Plane(normal=(0, 0, 0)), "parameter 'normal': must be three finite numbers, not all 0"),
    (lambda: Genus2(separation=0.5), "parameter 'separation': must be in [major_radius + minor_radius + blend + 0.05, 2 (major_radius + minor_radius)) = [0.58, 1)"),
    (lambda: make_function("cube"), "function: unknown function 'cube'; known: sphere, torus"),
    (lambda: make_function("torus", R=0.5), "function 'torus', parameter 'R': unknown parameter"),
    (lambda: sample("sphere", 8), "resolution: must be an integer in [16, 512], got 8"),
    (lambda: sample("sphere", 1024), "resolution: must be an integer in [16, 512], got 1024"),
    (lambda: sample("sphere", 32, "int8"), "data_type: must be one of uint8, uint16, float32, got 'int8'"),
])
def test_bad_parameters_are_rejected_with_clear_messages(call, message):
    with pytest.raises(PropertyError) as err:
        call()
    assert message in str(err.value)


def test_make_function_builds_with_parameters_and_defaults():
    fn = make_function("torus", minor_radius=0.2)
    assert fn == Torus(major_radius=0.55, minor_radius=0.2)
    assert fn.parameters() == {"major_radius": 0.55, "minor_radius": 0.2}
    assert math.isclose(fn.value([[0.75, 0, 0]])[0], 0.0, abs_tol=1e-15)
