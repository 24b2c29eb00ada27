"""The iso-surface under a picked pixel, found on the tricubic B-spline surface (issue 36).

The GL's iso ray caster stops at the first sample past the level and refines it on the trilinear
field, so its depth is a point near the surface, not on the smooth surface the data describe. Here
the ray is walked again on the tricubic B-spline of the volume (vgraph.numerics.bspline, the
coefficients made once per volume and kept while it lives: vgraph.derived): the first change of
sign of ``f - level`` within ``SEARCH_VOXELS`` voxels of the GL's depth brackets the surface, and
a Newton iteration along the ray, ``t -= (f - level) / (grad f . d)``, kept inside the bracket
(a step that would leave it bisects instead), converges to it. The gradient and Hessian there give
the normal and the principal curvatures (Kindlmann et al. 2003: vgraph.numerics.curvature).

Units: everything in world units (patient space, the volume's affine: the spline is evaluated in
voxel indices and its derivatives are turned into world axes with the volume's direction).
Curvature signs follow vgraph.numerics.curvature: the inside has higher values, the outward normal
is -grad f / |grad f|, a sphere of radius r has k1 = k2 = +1/r.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph import derived
from vgraph.numerics.bspline import evaluate, prefilter
from vgraph.numerics.curvature import kindlmann

SEARCH_VOXELS = 2.0    # how far before and after the GL's depth the surface is looked for
SEARCH_STEPS = 16      # samples of f along that stretch (a quarter of a voxel apart)
NEWTON_STEPS = 30      # at most this many Newton (or bisection) steps
TOLERANCE = 1e-7       # stop when the bracket or the step is below this many voxels


@dataclass(frozen=True)
class SurfacePoint:
    """The picked point on the tricubic iso-surface, with its normal and curvatures."""
    point: tuple[float, float, float]      # world (patient) coordinates
    normal: tuple[float, float, float]     # outward unit normal (towards lower values)
    k1: float                              # principal curvatures, 1 / world unit, k1 >= k2
    k2: float
    mean: float                            # (k1 + k2) / 2
    gaussian: float                        # k1 k2
    shift: float                           # how far it lies from the GL's point, along the ray (world units)
    steps: int                             # Newton or bisection steps taken


def coefficients(volume) -> np.ndarray:
    """The cubic B-spline coefficients of ``volume`` (its data if it holds them already), made once."""
    if volume.is_spline_coefficients:
        return volume.data
    return derived.value(volume, "bspline coefficients", lambda: prefilter(volume.data))


def spline_value(volume, points_world) -> np.ndarray:
    """The tricubic B-spline of ``volume`` at world points (..., 3)."""
    return evaluate(coefficients(volume), volume.world_to_voxel(points_world)).value


def refine_on_surface(volume, level: float, origin, direction, t_guess: float) -> SurfacePoint | None:
    """The first crossing of ``level`` by the tricubic field along the ray ``origin + t direction``
    (unit direction, world units) near ``t_guess``; None when the field does not cross the level
    within SEARCH_VOXELS voxels of it (the GL's hit was not an iso-surface there)."""
    origin, direction = np.asarray(origin, float), np.asarray(direction, float)
    step = float(min(volume.spacing))
    coeffs = coefficients(volume)

    def f(t: float, derivatives: int = 0):
        voxel = volume.world_to_voxel(origin + t * direction)
        return evaluate(coeffs, voxel, derivatives=derivatives)

    bracket = _first_bracket(volume, coeffs, level, origin, direction, t_guess, step)
    if bracket is None:
        return None
    low, high, steps = *bracket, 0
    t = 0.5 * (low + high)
    while steps < NEWTON_STEPS and high - low > TOLERANCE * step:
        steps += 1
        sample = f(t, 1)
        residual = float(sample.value) - level
        if residual == 0.0:
            break
        if (residual < 0.0) == (float(f(low).value) - level < 0.0):
            low = t
        else:
            high = t
        slope = float(_world_gradient(volume, sample.gradient) @ direction)
        newton = t - residual / slope if slope != 0.0 else np.nan
        moved = abs(newton - t) if np.isfinite(newton) else np.inf
        t = newton if low < newton < high else 0.5 * (low + high)
        if moved < TOLERANCE * step:
            break
    return _surface_point(volume, coeffs, origin + t * direction, t - t_guess, steps)


def _first_bracket(volume, coeffs, level, origin, direction, t_guess, step):
    """(t_low, t_high) around the first sign change of f - level on the searched stretch."""
    ts = t_guess + step * np.linspace(-SEARCH_VOXELS, SEARCH_VOXELS, 2 * SEARCH_STEPS + 1)
    voxels = volume.world_to_voxel(origin + ts[:, None] * direction)
    above = evaluate(coeffs, voxels).value - level >= 0.0
    change = np.flatnonzero(above[1:] != above[:-1])
    if len(change) == 0:
        return None
    i = int(change[0])
    return float(ts[i]), float(ts[i + 1])


def _world_gradient(volume, gradient_index) -> np.ndarray:
    """A gradient in index units (per voxel along i, j, k) as one in world units (x, y, z)."""
    per_axis = np.asarray(gradient_index, float) / np.asarray(volume.spacing)
    return np.asarray(volume.direction, float) @ per_axis


def _world_hessian(volume, hessian_index) -> np.ndarray:
    scale = np.outer(volume.spacing, volume.spacing)
    rotation = np.asarray(volume.direction, float)
    return rotation @ (np.asarray(hessian_index, float) / scale) @ rotation.T


def _surface_point(volume, coeffs, point, shift, steps) -> SurfacePoint:
    sample = evaluate(coeffs, volume.world_to_voxel(point), derivatives=2)
    gradient = _world_gradient(volume, sample.gradient)
    hessian = _world_hessian(volume, sample.hessian)
    curvature = kindlmann(gradient, hessian)
    length = float(np.linalg.norm(gradient))
    normal = -gradient / length if length > 0 else np.zeros(3)
    return SurfacePoint(point=tuple(float(v) for v in point), normal=tuple(float(v) for v in normal),
                        k1=float(curvature.k1), k2=float(curvature.k2), mean=float(curvature.mean),
                        gaussian=float(curvature.gaussian), shift=float(shift), steps=steps)
