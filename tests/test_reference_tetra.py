"""The exact CPU reference for tetrahedral meshes (vgraph.numerics.reference_tetra): closed forms
of a segment, quadrature of the emission-absorption integral, the thickness map of one
tetrahedron against the projected-tetrahedra classification (Shirley & Tuchman 1990), a
tetrahedralised volume against the reference ray caster, and the shared mesh in seconds."""

import time

import numpy as np
import pytest
from scipy import integrate
from scipy.spatial import ConvexHull

from helpers.paths import DATA
from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.mesh import TetMesh
from vgraph.numerics import reference_raycast
from vgraph.numerics.reference_tetra import (MAX_OPACITY, ray_segments, render,
                                             segment_integral)
from vgraph.tetrahedralize import volume_tetrahedra
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

CLEAR = (0.0, 0.0, 0.0, 0.0)


def constant_tf(rgb, alpha):
    return TransferFunction(points=[(0.0, *rgb, alpha), (1.0, *rgb, alpha)])


# --- one segment --------------------------------------------------------------------------------
@pytest.mark.parametrize("alpha", [0.0, 0.05, 0.5, 0.97, 1.0])
def test_constant_tf_has_the_closed_form(alpha):
    rgb = np.array([0.9, 0.4, 0.1])
    lengths = np.array([0.0, 1e-6, 0.1, 0.5, 1.0, 2.5, 10.0])
    L = 0.5
    result = segment_integral(0.2, 0.8, lengths, constant_tf(rgb, alpha), L)
    a = min(alpha, MAX_OPACITY)
    expected_alpha = 1.0 - (1.0 - a) ** (lengths / L)
    np.testing.assert_allclose(result[:, 3], expected_alpha, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(result[:, :3], rgb * expected_alpha[:, None], rtol=1e-12, atol=1e-15)


def test_constant_intensity_in_a_ramp_is_a_constant_segment():
    tf = TransferFunction(points=[(0.0, 0.0, 0.0, 1.0, 0.0), (1.0, 1.0, 0.5, 0.0, 0.8)])
    s, length, L = 0.3, 1.7, 0.4
    rgb, a = tf(s)[:3], tf(s)[3]
    expected_alpha = 1.0 - (1.0 - a) ** (length / L)
    np.testing.assert_allclose(segment_integral(s, s, length, tf, L),
                               [*(rgb * expected_alpha), expected_alpha], rtol=1e-12)


def reference_integral(s_front, s_back, length, tf, L):
    """Premultiplied RGBA of the emission-absorption ODE dTau/du = tau, dC/du = c tau exp(-Tau)
    solved with scipy (DOP853, restarted at every TF point the segment crosses), and its optical
    depth once more by scipy quad; the TF's opacities clamped at MAX_OPACITY as the model says."""
    points = np.asarray(tf.points, dtype=np.float64)
    points[:, 4] = np.minimum(points[:, 4], MAX_OPACITY)
    clamped = TransferFunction(points=[tuple(p) for p in points])
    inner = sorted(length * (p - s_front) / (s_back - s_front) for p in points[:, 0]
                   if s_back != s_front and 0.0 < (p - s_front) / (s_back - s_front) < 1.0)
    breaks = [0.0, *inner, length]

    def rgba(u):
        return clamped(s_front + (s_back - s_front) * u / length)

    def tau(u):
        return -np.log1p(-rgba(u)[3]) / L

    def rhs(u, y):
        value = rgba(u)
        extinction = -np.log1p(-value[3]) / L
        return [extinction, *(value[:3] * extinction * np.exp(-y[0]))]

    y = np.zeros(4)
    for u0, u1 in zip(breaks[:-1], breaks[1:]):
        if u1 > u0:
            y = integrate.solve_ivp(rhs, (u0, u1), y, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
    depth = integrate.quad(tau, 0.0, length, points=inner or None, limit=200, epsabs=1e-14,
                           epsrel=1e-13)[0]
    assert abs(depth - y[0]) < 1e-10
    return np.array([*y[1:], -np.expm1(-depth)])


RAMP = TransferFunction(points=[(0.0, 0.0, 0.2, 1.0, 0.0), (1.0, 1.0, 0.6, 0.0, 0.9)])
STEPS = TransferFunction(points=[(0.0, 0.1, 0.1, 0.8, 0.02), (0.3, 0.2, 0.9, 0.3, 0.4),
                                 (0.3, 0.9, 0.1, 0.1, 0.1), (0.7, 1.0, 1.0, 0.0, 0.7),
                                 (1.0, 0.3, 0.0, 0.5, 0.05)])
OPAQUE = TransferFunction(points=[(0.0, 1.0, 0.0, 0.0, 0.0), (0.6, 0.5, 0.5, 1.0, 1.0),
                                  (1.0, 0.0, 1.0, 0.0, 0.2)])


@pytest.mark.parametrize("tf, s_front, s_back", [
    (RAMP, 0.1, 0.9), (RAMP, 0.95, 0.05), (RAMP, -0.5, 1.5),   # linear ramp, both ways, clamped ends
    (STEPS, 0.05, 0.95), (STEPS, 0.9, 0.1),                     # several pieces and a step
    (OPAQUE, 0.0, 1.0), (OPAQUE, 0.59, 0.62),                   # opacity reaching 1 (log singularity)
])
@pytest.mark.parametrize("length", [0.02, 0.3, 1.0, 4.0])
def test_piecewise_linear_tf_agrees_with_the_ode(tf, s_front, s_back, length):
    L = 0.5
    result = segment_integral(s_front, s_back, length, tf, L)
    np.testing.assert_allclose(result, reference_integral(s_front, s_back, length, tf, L),
                               atol=1e-8, rtol=0)


def test_a_segment_cut_in_two_composites_to_the_whole():
    L = 0.25
    for s0, s2, l1, l2 in [(0.05, 0.95, 0.3, 0.7), (0.9, 0.0, 1.0, 0.1), (0.2, 0.2, 0.4, 0.5)]:
        s1 = s0 + (s2 - s0) * l1 / (l1 + l2)  # the intensity is linear along the whole segment
        whole = segment_integral(s0, s2, l1 + l2, STEPS, L)
        front = segment_integral(s0, s1, l1, STEPS, L)
        back = segment_integral(s1, s2, l2, STEPS, L)
        np.testing.assert_allclose(whole, front + (1.0 - front[3]) * back, atol=1e-12)


def test_segment_integral_refuses_bad_input():
    with pytest.raises(VGraphError, match="opacity_length"):
        segment_integral(0.0, 1.0, 1.0, RAMP, 0.0)
    with pytest.raises(VGraphError, match="lengths"):
        segment_integral(0.0, 1.0, -1.0, RAMP, 1.0)
    with pytest.raises(VGraphError, match="normalised"):
        segment_integral(0.0, 1.0, 1.0, TransferFunction(space="data", points=[(0, 1, 1, 1, 1)]), 1.0)


# --- one tetrahedron ----------------------------------------------------------------------------
TET_POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.2, 0.9, 0.1], [0.3, 0.25, 0.8]])


def orthographic(direction, box_min, box_max, aspect=1.0):
    return Camera.looking_at_box(box_min, box_max, direction=direction, projection="orthographic",
                                 aspect=aspect, up=(0.0, 0.0, 1.0) if abs(direction[2]) < 0.9
                                 else (0.0, 1.0, 0.0))


def projected_thickness(points, camera, size):
    """Thickness of an orthographic view of one tetrahedron at the pixel centres, from its
    projection (Shirley & Tuchman): the projected outline is a triangle with the fourth vertex
    inside (class 1) or a quadrilateral whose diagonals cross (class 2); the thickness is 0 on the
    outline, the chord through that inner vertex or crossing point at it, and linear in between -
    a tent, the minimum over the outline's edges of (distance to the edge) / (peak's distance)."""
    width, height = size
    right, up, forward = camera.basis()
    xy = np.stack([points @ right, points @ up], axis=1)
    z = points @ forward
    hull = ConvexHull(xy).vertices  # counter-clockwise
    if len(hull) == 3:
        inner = ({0, 1, 2, 3} - set(hull)).pop()
        a, b, c = xy[hull]
        lam = np.linalg.solve(np.array([[a[0], b[0], c[0]], [a[1], b[1], c[1]], [1, 1, 1]]),
                              [*xy[inner], 1.0])
        peak, peak_height = xy[inner], abs(z[inner] - lam @ z[hull])
    else:
        i, j = hull[0], hull[2]  # the diagonals of the quadrilateral: (h0, h2) and (h1, h3)
        k, m = hull[1], hull[3]
        s, t = np.linalg.solve(np.column_stack([xy[j] - xy[i], xy[k] - xy[m]]), xy[k] - xy[i])
        peak = xy[i] + s * (xy[j] - xy[i])
        peak_height = abs((z[i] + s * (z[j] - z[i])) - (z[k] + t * (z[m] - z[k])))
    origins, _ = camera.rays(width, height)
    q = np.stack([origins @ right, origins @ up], axis=-1)
    tent = np.full(q.shape[:2], np.inf)
    corners = xy[hull]
    for e in range(len(corners)):
        p0, p1 = corners[e], corners[(e + 1) % len(corners)]
        normal = np.array([-(p1 - p0)[1], (p1 - p0)[0]])  # inward for a counter-clockwise outline
        tent = np.minimum(tent, ((q - p0) @ normal) / ((peak - p0) @ normal))
    return peak_height * np.clip(tent, 0.0, None), len(hull)


@pytest.mark.parametrize("direction", [(0.0, 0.0, -1.0), (1.0, 0.2, 0.1), (-0.3, 1.0, -0.4),
                                       (0.5, -0.6, 0.7), (0.1, 0.3, 1.0), (-1.0, -0.7, -0.2)])
def test_single_tetrahedron_thickness_and_alpha(direction):
    mesh = TetMesh(TET_POINTS, [[0, 1, 2, 3]], [0.0, 1.0, 0.4, 0.7], reference_length=0.3)
    size = (40, 32)
    camera = orthographic(direction, *mesh.bounds, aspect=size[0] / size[1])
    resolved = camera.resolved(*mesh.bounds, size[0] / size[1])
    expected, _ = projected_thickness(mesh.points.astype(np.float64), resolved, size)
    assert (expected > 0).sum() > 100 and expected.max() > 0.2
    thickness = ray_segments(mesh, camera, size).thickness(size)
    np.testing.assert_allclose(thickness, expected, atol=1e-9)
    rgb, a = np.array([0.2, 0.7, 1.0]), 0.6
    image = render(mesh, camera, constant_tf(rgb, a), size, background=CLEAR)
    alpha = 1.0 - (1.0 - a) ** (expected / mesh.opacity_length)
    np.testing.assert_allclose(image[..., 3], alpha, atol=1e-6)
    np.testing.assert_allclose(image[..., :3], alpha[..., None] * rgb, atol=1e-6)


def test_both_classes_of_projection_are_covered():
    classes = set()
    for direction in [(0.0, 0.0, -1.0), (1.0, 0.2, 0.1), (-0.3, 1.0, -0.4), (0.5, -0.6, 0.7)]:
        camera = orthographic(direction, TET_POINTS.min(0), TET_POINTS.max(0)).resolved(
            TET_POINTS.min(0), TET_POINTS.max(0))
        classes.add(projected_thickness(TET_POINTS, camera, (8, 8))[1])
    assert classes == {3, 4}


def test_rays_that_miss_show_the_background_exactly():
    mesh = TetMesh(TET_POINTS, [[0, 1, 2, 3]], [0.0, 1.0, 0.4, 0.7])
    background = (0.25, 0.5, 0.75, 0.6)
    camera = orthographic((0.5, -0.6, 0.7), *mesh.bounds)
    image, depth = render(mesh, camera, constant_tf((1, 1, 1), 0.5), (24, 24),
                          background=background, return_depth=True)
    missed = depth[..., 2] == 0
    assert missed.sum() > 100
    np.testing.assert_array_equal(image[missed], np.broadcast_to(np.float32(background), image[missed].shape))
    np.testing.assert_array_equal(depth[missed][:, [0, 1, 3]], [[1.0, 0.0, 0.0]] * int(missed.sum()))


# --- a tetrahedralised volume against the reference ray caster ----------------------------------
def linear_volume(coefficients, dims=(7, 6, 5), spacing=(0.5, 0.5, 0.5), origin=(1.0, -1.0, 0.5)):
    nx, ny, nz = dims
    z, y, x = np.indices((nz, ny, nx)).astype(np.float64)
    a, b, c = coefficients
    data = (a * (origin[0] + x * spacing[0]) + b * (origin[1] + y * spacing[1])
            + c * (origin[2] + z * spacing[2]))
    return Volume(data, spacing=spacing, origin=origin, declared_range=(-4.0, 6.0))


def volume_mesh(volume):
    points, tets, voxels = volume_tetrahedra(volume.data, volume.spacing, volume.origin)
    return TetMesh(points, tets, volume.data.reshape(-1)[voxels], declared_range=volume.declared_range,
                   reference_length=min(volume.spacing))


VOLUME_TF = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.02), (0.45, 0.9, 0.6, 0.1, 0.2),
                                     (1.0, 1.0, 1.0, 0.3, 0.4)])


@pytest.mark.parametrize("coefficients", [(0.0, 0.0, 0.0), (1.0, -0.5, 0.8), (-0.3, 0.9, 0.2)])
def test_tetrahedralised_volume_matches_the_ray_caster(coefficients):
    volume = linear_volume(coefficients)
    mesh = volume_mesh(volume)
    lo, hi = mesh.bounds
    np.testing.assert_array_equal(np.stack([lo, hi]),
                                  np.stack(reference_raycast.volume_box(volume)))
    camera = Camera(position=(-2.0, -4.0, 6.0), focus=tuple((lo + hi) / 2), up=(0.0, 0.0, 1.0),
                    fit_to_data=True)
    size = (40, 36)
    exact = render(mesh, camera, VOLUME_TF, size, background=(0.1, 0.1, 0.1, 1.0))
    sampled = reference_raycast.render(volume, camera, VOLUME_TF, size, sampling_rate=512.0,
                                       early_termination=1.0, background=(0.1, 0.1, 0.1, 1.0))
    assert np.abs(exact - exact[0, 0]).max() > 0.1  # the mesh is in the picture
    np.testing.assert_allclose(exact, sampled, atol=1e-3)


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (1.0, 1.0, 0.0),
                                       (1.0, -1.0, 1.0), (0.0, 1.0, 1.0), (0.3, 0.2, -1.0)])
@pytest.mark.parametrize("pixels", [24, 37])
def test_shared_faces_are_watertight(direction, pixels):
    """The tetrahedra of a grid fill its box: every ray's total length in them is its chord of
    the box, also in views along the axes and diagonals where rays run in shared faces (counted
    once, not twice or never)."""
    mesh = volume_mesh(linear_volume((1.0, -0.5, 0.8)))
    lo, hi = mesh.bounds
    camera = Camera.looking_at_box(lo, hi, direction=direction, projection="orthographic",
                                   up=(0.0, 0.0, 1.0) if direction[2] == 0 else (0.0, 1.0, 0.0))
    size = (pixels, pixels)
    thickness = ray_segments(mesh, camera, size).thickness(size)
    resolved = camera.resolved(lo, hi)
    origins, directions = (a.reshape(-1, 3) for a in resolved.rays(*size))
    with np.errstate(divide="ignore"):
        slabs = np.stack([(lo - origins) / directions, (hi - origins) / directions])
    chord = np.maximum(np.nanmin(slabs.max(axis=0), axis=1) - np.nanmax(slabs.min(axis=0), axis=1), 0.0)
    assert (chord > 0).sum() > pixels * pixels / 8
    np.testing.assert_allclose(thickness, chord.reshape(pixels, pixels), atol=1e-9)


def test_depth_of_an_axis_aligned_view():
    volume = linear_volume((1.0, -0.5, 0.8))
    mesh = volume_mesh(volume)
    lo, hi = mesh.bounds
    centre = (lo + hi) / 2
    camera = Camera(projection="orthographic", position=(centre[0], centre[1], hi[2] + 5.0),
                    focus=tuple(centre), up=(0.0, 1.0, 0.0), near=1.0, far=20.0,
                    parallel_scale=2.0)
    image, depth = render(mesh, camera, VOLUME_TF, (30, 30), return_depth=True)
    inside = depth[..., 3] == 1.0
    assert inside.sum() > 100
    np.testing.assert_allclose(depth[..., 1][inside], 4.0, atol=1e-6)  # near plane 1 from the eye
    expected = camera.projection_matrix(1.0) @ [0.0, 0.0, -5.0, 1.0]
    np.testing.assert_allclose(depth[..., 0][inside], 0.5 + 0.5 * expected[2] / expected[3], atol=1e-6)
    assert depth[..., 2][inside].min() >= 4  # one tetrahedron or more per cell, 4 cells deep


# --- the shared mesh ----------------------------------------------------------------------------
POST = DATA / "tet_lox_post" / "post.vtk"


@pytest.mark.skipif(not POST.is_file(), reason=f"the shared mesh {POST} is not here")
def test_shared_mesh_renders_in_seconds():
    import meshio

    raw = meshio.read(POST)
    mesh = TetMesh(raw.points, raw.cells_dict["tetra"], raw.point_data["Pressure"])
    assert len(mesh.tets) == 8750
    tf = TransferFunction(points=[(0.0, 0.0, 0.0, 1.0, 0.02), (0.5, 0.0, 1.0, 0.0, 0.05),
                                  (1.0, 1.0, 0.0, 0.0, 0.3)])
    start = time.perf_counter()
    image, depth = render(mesh, Camera(fit_to_data=True).viewed_from("iso"), tf, (128, 128),
                          background=CLEAR, return_depth=True)
    elapsed = time.perf_counter() - start
    assert elapsed < 20.0, f"{elapsed:.1f} s"
    covered = image[..., 3] > 0.0
    assert 0.2 < covered.mean() < 0.9 and image[..., 3].max() > 0.3
    assert np.ptp(image[..., 1][covered]) > 0.1  # coloured, not flat
    np.testing.assert_array_equal(covered, depth[..., 3] == 1.0)


# --- input --------------------------------------------------------------------------------------
def test_data_space_tf_and_non_finite_scalars():
    """A TF in data units is resolved through the mesh's value range; NaN and -inf count as the
    range's low end, +inf as its high end (as volumes do)."""
    points = np.vstack([TET_POINTS, TET_POINTS + [2.0, 0.0, 0.0]])
    tets = [[0, 1, 2, 3], [4, 5, 6, 7]]
    camera = orthographic((0.3, 0.2, -1.0), points.min(0), points.max(0))
    data_tf = TransferFunction(space="data", points=[(10.0, 1.0, 0.0, 0.0, 0.1), (20.0, 0.0, 1.0, 0.0, 0.8)])
    normal_tf = TransferFunction(points=[(0.0, 1.0, 0.0, 0.0, 0.1), (1.0, 0.0, 1.0, 0.0, 0.8)])
    finite = TetMesh(points, tets, [10, 20, 15, 12, 10, 20, 10, 20], reference_length=0.4)
    odd = TetMesh(points, tets, [10, 20, 15, 12, np.nan, np.inf, -np.inf, 20], reference_length=0.4,
                  declared_range=(10.0, 20.0))
    np.testing.assert_allclose(render(finite, camera, data_tf, (32, 24)),
                               render(finite, camera, normal_tf, (32, 24)), atol=1e-7)
    np.testing.assert_allclose(render(odd, camera, data_tf, (32, 24)),
                               render(finite, camera, normal_tf, (32, 24)), atol=1e-7)


def test_bad_arguments_are_refused():
    mesh = TetMesh(TET_POINTS, [[0, 1, 2, 3]], [0.0, 1.0, 0.4, 0.7])
    camera = Camera(fit_to_data=True)
    with pytest.raises(VGraphError, match="mode"):
        render(mesh, camera, RAMP, (8, 8), mode="sampled")
    with pytest.raises(VGraphError, match="size"):
        render(mesh, camera, RAMP, (8, 0))
    with pytest.raises(VGraphError, match="background"):
        render(mesh, camera, RAMP, (8, 8), background=(0, 0, 0))


def test_camera_inside_the_mesh():
    """Tetrahedra reaching behind the eye are tested against every ray; the ray starts on the
    near plane inside the mesh."""
    volume = linear_volume((1.0, -0.5, 0.8))
    mesh = volume_mesh(volume)
    lo, hi = mesh.bounds
    centre = (lo + hi) / 2
    camera = Camera(position=tuple(centre), focus=tuple(hi), up=(0.0, 0.0, 1.0), near=0.01, far=20.0)
    thickness = ray_segments(mesh, camera, (16, 16)).thickness((16, 16))
    resolved = camera.resolved(lo, hi)
    origins, directions = (a.reshape(-1, 3) for a in resolved.rays(16, 16))
    exits = np.min(np.where(directions > 0, (hi - origins) / np.where(directions > 0, directions, 1),
                            np.where(directions < 0, (lo - origins) / np.where(directions < 0, directions, 1),
                                     np.inf)), axis=1)
    np.testing.assert_allclose(thickness, exits.reshape(16, 16), atol=1e-9)
