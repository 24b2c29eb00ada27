"""Measuring by picking on a torus and between two planes at a known angle (issue 36), the
tolerances docs/reports/accuracy.md ("Measuring on a torus and between two planes") states, at
voxel 1 (bench/picking_shapes.py builds the volumes and says what is measured; the bench
bench_picking_accuracy.py --shape torus|planes prints the table at several voxel sizes)."""

import math

import numpy as np
import pytest

import picking_shapes
from picking_shapes import ANGLE, APEX, planes_errors, planes_volume, torus_errors

VOXEL = 1.0


@pytest.fixture(scope="module")
def torus():
    return torus_errors(VOXEL)


@pytest.fixture(scope="module")
def planes():
    return planes_errors(VOXEL)


def test_tricubic_picks_lie_on_the_torus_within_a_hundredth_of_a_voxel(torus):
    assert torus["tricubic"]["surface"] < 0.01
    assert torus["linear"]["surface"] < 0.1
    assert torus["nearest"]["surface"] < 1.0
    # the refinement gains at least five times on the GL's trilinear depth
    assert torus["tricubic"]["surface"] < torus["linear"]["surface"] / 5


def test_rulers_across_the_tube_on_oblique_rays_measure_its_chords(torus):
    assert torus["tricubic"]["chords"] < 0.02
    assert torus["linear"]["chords"] < 0.15
    assert torus["nearest"]["chords"] < 1.0


def test_the_tube_and_outer_diameters_measured_at_their_extreme_points(torus):
    """Where the rays run along the gradient the field is linear along them: linear and tricubic
    are exact to float rounding; nearest stops half a voxel early on each side, or a quarter."""
    for method in ("linear", "tricubic"):
        assert abs(torus[method]["tube"]) < 1e-3 and abs(torus[method]["outer"]) < 1e-3
    assert torus["nearest"]["tube"] == pytest.approx(0.75, abs=1e-3)
    assert torus["nearest"]["outer"] == pytest.approx(1.0, abs=1e-3)


def test_picks_on_the_planes_lie_on_them(planes):
    assert planes["linear"]["plane"] < 1e-4     # trilinear interpolation reproduces a plane
    assert planes["tricubic"]["plane"] < 0.02
    assert planes["nearest"]["plane"] < 0.5


def test_the_ridge_is_blunted_as_linear_interpolation_of_a_kink_predicts(planes):
    """The trilinear field lowers the ridge by 2 a (1 - a) h cot(angle / 2), a = where the ridge
    falls between two grid columns: the vertex picked lies that far below it; tricubic less."""
    volume = planes_volume(VOXEL)
    a = ((APEX[0] - volume.origin[0]) / VOXEL) % 1.0
    predicted = 2 * a * (1 - a) / math.tan(math.radians(ANGLE) / 2)
    assert planes["linear"]["vertex"] == pytest.approx(predicted, abs=1e-3)
    assert planes["tricubic"]["vertex"] < planes["linear"]["vertex"]
    assert planes["nearest"]["vertex"] < 1.0


def test_the_angle_markup_on_three_picks_measures_the_planes_angle_within_the_stated_error(planes):
    assert abs(planes["tricubic"]["angle"]) < 4.5
    assert abs(planes["linear"]["angle"]) < 7.0
    assert abs(planes["nearest"]["angle"]) < 10.0
    # every method's error is the blunted vertex's: it opens the angle
    assert all(planes[m]["angle"] > 0 for m in picking_shapes.METHODS)


def test_an_angle_markup_through_exact_points_measures_the_angle():
    """The reference: the markup's own angle through the exact ridge and plane points."""
    from vgraph.markups import Markup
    half = math.radians(ANGLE) / 2
    first = np.add(APEX, (5 * math.sin(half), 0, -5 * math.cos(half)))
    last = np.add(APEX, (-3 * math.sin(half), 0, -3 * math.cos(half)))
    markup = Markup(name="a", kind="angle", points=(tuple(first), APEX, tuple(last)))
    assert markup.angle == pytest.approx(ANGLE, abs=1e-9)
