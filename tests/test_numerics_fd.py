"""Trilinear sampling and finite differences against scipy and exact low-order polynomials."""

import itertools

import numpy as np
import pytest
from scipy import ndimage

from vgraph.numerics.finite_differences import (
    gradient_at,
    grid_gradient,
    grid_hessian,
    hessian_at,
    trilinear,
)

SPACING = np.array([0.5, 2.0, 1.5])


def grid_coordinates(shape):
    """x, y, z voxel coordinates of every voxel of a [z, y, x] volume."""
    z, y, x = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij")
    return x, y, z


def voxel_centres(shape):
    x, y, z = grid_coordinates(shape)
    return np.stack([x, y, z], axis=-1)


@pytest.mark.parametrize("boundary, scipy_mode", [("clamp", "nearest"), ("mirror", "mirror")])
def test_trilinear_matches_scipy_order_one(boundary, scipy_mode):
    rng = np.random.default_rng(0)
    data = rng.random((5, 7, 6)) * 10
    upper = np.array([6, 7, 5]) - 1.0
    points = np.concatenate([rng.uniform(-0.7, upper + 0.7, size=(2000, 3)),
                             rng.uniform(-2 * upper, 3 * upper, size=(300, 3))])
    reference = ndimage.map_coordinates(data, points[:, ::-1].T, order=1, mode=scipy_mode)
    assert np.allclose(trilinear(data, points, boundary), reference, atol=1e-12)


def test_trilinear_hits_voxel_values_and_handles_integer_data_and_thin_axes():
    data = np.random.default_rng(1).integers(0, 255, size=(3, 1, 4)).astype(np.uint8)
    assert np.array_equal(trilinear(data, voxel_centres(data.shape)), data.astype(np.float64))
    between = trilinear(data, [[0.5, 0.0, 0.0], [0.5, 3.0, 0.0]])  # y is a one-voxel axis
    assert between[0] == pytest.approx((float(data[0, 0, 0]) + float(data[0, 0, 1])) / 2)
    assert between[1] == between[0]  # clamped onto the single y layer


def test_linear_fields_are_exact_for_every_scheme_in_world_units():
    shape = (9, 10, 11)
    x, y, z = grid_coordinates(shape)
    slope_voxel = np.array([2.0, -3.0, 0.5])  # per voxel along x, y, z
    data = slope_voxel[0] * x + slope_voxel[1] * y + slope_voxel[2] * z + 7
    points = np.random.default_rng(2).uniform(2.0, 6.0, size=(100, 3))  # all neighbours inside
    for scheme in ("forward", "backward", "central", "filtered"):
        gradient = gradient_at(data, points, spacing=SPACING, scheme=scheme)
        assert np.allclose(gradient, slope_voxel / SPACING, atol=1e-12), scheme
    assert np.allclose(hessian_at(data, points, spacing=SPACING), 0.0, atol=1e-12)
    assert np.allclose(grid_gradient(data, SPACING)[1:-1, 1:-1, 1:-1], slope_voxel / SPACING)


def test_central_differences_are_exact_for_quadratics_on_the_grid():
    shape = (7, 8, 9)
    x, y, z = grid_coordinates(shape)
    data = 0.5 * x**2 - 2 * x * y + 3 * y * z + z**2 - y
    inner = (slice(1, -1),) * 3
    gradient = grid_gradient(data, SPACING, "central")[inner]
    expected = np.stack([x - 2 * y, -2 * x + 3 * z - 1, 3 * y + 2 * z], axis=-1)[inner] / SPACING
    assert np.allclose(gradient, expected)
    hessian = grid_hessian(data, SPACING)[inner]
    exact = np.array([[1.0, -2.0, 0.0], [-2.0, 0.0, 3.0], [0.0, 3.0, 2.0]]) / np.outer(SPACING, SPACING)
    assert np.allclose(hessian, exact)
    forward = grid_gradient(data, SPACING, "forward")[inner]
    assert np.allclose(forward[..., 0], (x - 2 * y + 0.5)[inner] / SPACING[0])  # f(x+1) - f(x)
    backward = grid_gradient(data, SPACING, "backward")[inner]
    assert np.allclose(backward[..., 2], (3 * y + 2 * z - 1)[inner] / SPACING[2])


def test_clamp_to_edge_semantics_at_the_border():
    data = np.zeros((1, 1, 4))
    data[0, 0] = [0.0, 1.0, 3.0, 6.0]
    forward = grid_gradient(data, scheme="forward")[0, 0, :, 0]
    central = grid_gradient(data, scheme="central")[0, 0, :, 0]
    assert forward.tolist() == [1.0, 2.0, 3.0, 0.0]  # the neighbour past the end is the end voxel
    assert central.tolist() == [0.5, 1.5, 2.5, 1.5]  # half the inner one-sided difference at edges
    mirrored = grid_gradient(data, scheme="central", boundary="mirror")[0, 0, :, 0]
    assert mirrored.tolist() == [0.0, 1.5, 2.5, 0.0]  # even extension: no slope at the ends
    assert np.all(grid_gradient(data)[..., 1:] == 0.0)  # the one-voxel axes have no slope


@pytest.mark.parametrize("boundary", ["clamp", "mirror"])
def test_point_and_grid_versions_agree_on_every_voxel_centre(boundary):
    data = np.random.default_rng(3).random((4, 5, 6))
    centres = voxel_centres(data.shape)
    for scheme in ("forward", "backward", "central"):
        assert np.allclose(gradient_at(data, centres, SPACING, scheme, boundary),
                           grid_gradient(data, SPACING, scheme, boundary), atol=1e-12), scheme
    assert np.allclose(hessian_at(data, centres, SPACING, boundary),
                       grid_hessian(data, SPACING, boundary), atol=1e-12)


def test_filtered_gradient_blends_the_centre_with_its_eight_diagonal_neighbours():
    rng = np.random.default_rng(4)
    data = rng.random((8, 8, 8))
    central = grid_gradient(data, SPACING, "central")
    for k, j, i in [(3, 4, 2), (4, 4, 4), (5, 2, 3)]:
        neighbours = [central[k + dz, j + dy, i + dx]
                      for dx, dy, dz in itertools.product((-1, 1), repeat=3)]
        expected = 0.25 * central[k, j, i] + 0.75 * np.mean(neighbours, axis=0)
        got = gradient_at(data, [i, j, k], SPACING, scheme="filtered")
        assert np.allclose(got, expected, atol=1e-12)
    # it smooths: on white noise it varies less than the plain central difference
    points = rng.uniform(2, 5, size=(400, 3))
    assert gradient_at(data, points, scheme="filtered").std() < 0.6 * gradient_at(data, points).std()


def test_step_and_hessian_mixed_terms_on_a_bilinear_field():
    shape = (9, 9, 9)
    x, y, z = grid_coordinates(shape)
    data = x * y - 2 * y * z + 0.5 * x * z  # trilinear interpolation reproduces it exactly
    points = np.random.default_rng(5).uniform(2.5, 5.5, size=(50, 3))
    hessian = hessian_at(data, points, SPACING, step=2.0)
    exact = np.array([[0.0, 1.0, 0.5], [1.0, 0.0, -2.0], [0.5, -2.0, 0.0]]) / np.outer(SPACING, SPACING)
    assert np.allclose(hessian, exact)
    px, py, pz = points.T
    gradient = gradient_at(data, points, SPACING, "central", step=2.0)
    assert np.allclose(gradient, np.stack([py + 0.5 * pz, px - 2 * pz, -2 * py + 0.5 * px], -1) / SPACING)


def test_nonfinite_points_give_nan_and_bad_arguments_raise():
    data = np.ones((3, 3, 3))
    points = np.array([[1.0, 1.0, 1.0], [np.nan, 0.0, 0.0]])
    assert np.isnan(trilinear(data, points)[1]) and trilinear(data, points)[0] == 1.0
    assert np.isnan(gradient_at(data, points)[1]).all() and np.all(gradient_at(data, points)[0] == 0)
    assert np.isnan(hessian_at(data, points)[1]).all()
    with pytest.raises(ValueError, match="scheme"):
        gradient_at(data, points, scheme="sideways")
    with pytest.raises(ValueError, match="boundary"):
        trilinear(data, points, boundary="wrap")
    with pytest.raises(ValueError, match="spacing"):
        grid_gradient(data, spacing=(1, -1, 1))
    with pytest.raises(ValueError, match="step"):
        hessian_at(data, points, step=0)
    with pytest.raises(ValueError, match=r"3D \[z, y, x\]"):
        grid_hessian(np.ones((3, 3)))
