"""Trilinear sampling and finite-difference derivatives: the CPU reference of the GPU's cheaper modes.

Conventions
- Volumes are [z, y, x] arrays; points are voxel-index coordinates (x, y, z) (voxel (i, j, k) =
  data[k, j, i] at point (i, j, k)); spacing is (x, y, z) in world units. Gradients are
  (d/dx, d/dy, d/dz) per world unit, Hessians (x, y, z) x (x, y, z) per world unit squared: the
  true derivatives of f (no sign flip; shading code that wants normals towards the viewer for
  bright-inside data negates them itself).
- Boundary, default "clamp": clamp-to-edge exactly as a GL texture with CLAMP_TO_EDGE and linear
  filtering samples it (coordinates clamped to [0, n-1], i.e. the outer voxel centres), so these
  numbers are what the shaders compute. A neighbour beyond the edge is the edge voxel itself: the
  one-sided difference across the edge is 0 and the central difference at an edge voxel is half the
  inner one-sided difference. "mirror" folds coordinates like scipy's mode='mirror' (whole-sample
  symmetric), matching the B-spline code in :mod:`vgraph.numerics.bspline`.
- Schemes, with h = one voxel along the axis (``step`` voxels if given) and s its world length:
    forward   (f(p + h) - f(p)) / s          backward  (f(p) - f(p - h)) / s
    central   (f(p + h) - f(p - h)) / (2 s)
    filtered  1/4 central(p) + 3/4 * mean of central(p + d) over the 8 diagonal neighbours
              d in {-h, +h}^3: a smoothed central difference (the idea of Voreen's
              calcGradientFiltered, Cabral 2010 fig. 6.1(c) "weighting the values of neighbouring voxels")
  At arbitrary points f is the trilinear interpolant, so on voxel centres the point versions equal
  the grid versions. Hessian: second central differences, mixed terms from the four diagonal samples.
- Everything is computed in float64. Non-finite points give NaN.
"""

from __future__ import annotations

import itertools

import numpy as np

SCHEMES = ("forward", "backward", "central", "filtered")
BOUNDARIES = ("clamp", "mirror")


# ----------------------------------------------------------------------------------------------
# Sampling
# ----------------------------------------------------------------------------------------------

def trilinear(data, points_xyz, boundary: str = "clamp") -> np.ndarray:
    """Trilinearly interpolated values at points (..., 3) (voxel coordinates x, y, z), float64."""
    volume = _volume(data, "trilinear")
    points, bad = _points(points_xyz, "trilinear")
    _check_boundary(boundary, "trilinear")
    flat = points.reshape(-1, 3)
    result = np.zeros(flat.shape[0])
    corners = [_axis_corners(flat[:, axis], volume.shape[2 - axis], boundary) for axis in range(3)]
    (x0, x1, tx), (y0, y1, ty), (z0, z1, tz) = corners
    for (zi, wz), (yi, wy), (xi, wx) in itertools.product(((z0, 1 - tz), (z1, tz)),
                                                          ((y0, 1 - ty), (y1, ty)),
                                                          ((x0, 1 - tx), (x1, tx))):
        result += wz * wy * wx * volume[zi, yi, xi]
    return _nan_where(result.reshape(points.shape[:-1]), bad)


def _nan_where(values: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """Set the results of non-finite points to NaN (bad has the points' leading shape)."""
    values[bad] = np.nan
    return values


def _axis_corners(coordinate: np.ndarray, n: int, boundary: str):
    """Lower/upper voxel index and fraction along one axis after applying the boundary rule."""
    if boundary == "mirror":
        coordinate = _fold_mirror(coordinate, n)
    coordinate = np.clip(coordinate, 0.0, n - 1.0)
    lower = np.minimum(np.floor(coordinate), max(n - 2, 0)).astype(np.int64)
    fraction = coordinate - lower
    upper = np.minimum(lower + 1, n - 1)
    return lower, upper, fraction


def _fold_mirror(coordinate: np.ndarray, n: int) -> np.ndarray:
    """Continuous whole-sample mirror into [0, n-1] (period 2n-2), like scipy's mode='mirror'."""
    if n == 1:
        return np.zeros_like(coordinate)
    period = 2.0 * (n - 1)
    folded = np.mod(coordinate, period)
    return np.where(folded > n - 1, period - folded, folded)


# ----------------------------------------------------------------------------------------------
# Derivatives at arbitrary points
# ----------------------------------------------------------------------------------------------

def gradient_at(data, points_xyz, spacing=(1.0, 1.0, 1.0), scheme: str = "central",
                boundary: str = "clamp", step: float = 1.0) -> np.ndarray:
    """Finite-difference gradient (..., 3) at arbitrary points, per world unit (see module doc)."""
    volume = _volume(data, "gradient_at")
    points, bad = _points(points_xyz, "gradient_at")
    world = _spacing(spacing, "gradient_at")
    if scheme not in SCHEMES:
        raise ValueError(f"gradient_at: scheme must be one of {SCHEMES}, got {scheme!r}")
    _check_boundary(boundary, "gradient_at")
    _check_step(step, "gradient_at")

    def sample(offset_voxels: np.ndarray) -> np.ndarray:
        return trilinear(volume, points + offset_voxels, boundary)

    if scheme == "filtered":
        def central_at(shift: np.ndarray) -> np.ndarray:
            return _differences(lambda offset: sample(offset + shift), "central", step)

        diagonals = [central_at(np.array(d) * step) for d in itertools.product((-1.0, 1.0), repeat=3)]
        voxel_units = 0.25 * central_at(np.zeros(3)) + 0.75 * np.mean(diagonals, axis=0)
    else:
        voxel_units = _differences(sample, scheme, step)
    return _nan_where(voxel_units / world, bad)


def _differences(sample, scheme: str, step: float) -> np.ndarray:
    """Voxel-unit difference quotients along x, y, z; sample(offset) gives values at points+offset."""
    columns = []
    here = sample(np.zeros(3)) if scheme in ("forward", "backward") else None
    for axis in range(3):
        offset = np.zeros(3)
        offset[axis] = step
        if scheme == "forward":
            columns.append((sample(offset) - here) / step)
        elif scheme == "backward":
            columns.append((here - sample(-offset)) / step)
        else:
            columns.append((sample(offset) - sample(-offset)) / (2.0 * step))
    return np.stack(columns, axis=-1)


def hessian_at(data, points_xyz, spacing=(1.0, 1.0, 1.0), boundary: str = "clamp",
               step: float = 1.0) -> np.ndarray:
    """Central-difference Hessian (..., 3, 3) at arbitrary points, per world unit squared."""
    volume = _volume(data, "hessian_at")
    points, bad = _points(points_xyz, "hessian_at")
    world = _spacing(spacing, "hessian_at")
    _check_boundary(boundary, "hessian_at")
    _check_step(step, "hessian_at")
    unit = np.eye(3) * step

    def sample(offset: np.ndarray) -> np.ndarray:
        return trilinear(volume, points + offset, boundary)

    centre = sample(np.zeros(3))
    hessian = np.empty(points.shape[:-1] + (3, 3))
    for a in range(3):
        hessian[..., a, a] = (sample(unit[a]) - 2.0 * centre + sample(-unit[a])) / step**2
        for b in range(a + 1, 3):
            mixed = (sample(unit[a] + unit[b]) - sample(unit[a] - unit[b])
                     - sample(-unit[a] + unit[b]) + sample(-unit[a] - unit[b])) / (4.0 * step**2)
            hessian[..., a, b] = hessian[..., b, a] = mixed
    return _nan_where(hessian / np.outer(world, world), bad)


# ----------------------------------------------------------------------------------------------
# Derivatives on the voxel grid
# ----------------------------------------------------------------------------------------------

def grid_gradient(data, spacing=(1.0, 1.0, 1.0), scheme: str = "central",
                  boundary: str = "clamp") -> np.ndarray:
    """Gradient at every voxel centre: float64 [z, y, x, 3] with components (x, y, z) per world unit.

    Schemes forward, backward, central (the point version with scheme="filtered" covers the
    smoothed one). Neighbours beyond the edge follow `boundary`, as in the module docstring.
    """
    padded = _padded(data, boundary, "grid_gradient")
    world = _spacing(spacing, "grid_gradient")
    if scheme not in ("forward", "backward", "central"):
        raise ValueError(f"grid_gradient: scheme must be forward, backward or central, got {scheme!r}")
    result = np.empty(tuple(n - 2 for n in padded.shape) + (3,))
    for axis in range(3):
        plus, here, minus = (_shifted(padded, axis, shift) for shift in (1, 0, -1))
        if scheme == "forward":
            difference = plus - here
        elif scheme == "backward":
            difference = here - minus
        else:
            difference = 0.5 * (plus - minus)
        result[..., axis] = difference / world[axis]
    return result


def grid_hessian(data, spacing=(1.0, 1.0, 1.0), boundary: str = "clamp") -> np.ndarray:
    """Central-difference Hessian at every voxel centre: float64 [z, y, x, 3, 3], (x, y, z) order."""
    padded = _padded(data, boundary, "grid_hessian")
    world = _spacing(spacing, "grid_hessian")
    result = np.empty(tuple(n - 2 for n in padded.shape) + (3, 3))
    here = _shifted(padded, 0, 0)
    for a in range(3):
        second = _shifted(padded, a, 1) - 2.0 * here + _shifted(padded, a, -1)
        result[..., a, a] = second / world[a] ** 2
        for b in range(a + 1, 3):
            mixed = (_shifted2(padded, a, 1, b, 1) - _shifted2(padded, a, 1, b, -1)
                     - _shifted2(padded, a, -1, b, 1) + _shifted2(padded, a, -1, b, -1)) / 4.0
            result[..., a, b] = result[..., b, a] = mixed / (world[a] * world[b])
    return result


def _padded(data, boundary: str, where: str) -> np.ndarray:
    volume = _volume(data, where)
    _check_boundary(boundary, where)
    mode = "edge" if boundary == "clamp" else "reflect"  # numpy 'reflect' = scipy 'mirror'
    return np.pad(volume.astype(np.float64, copy=False), 1, mode=mode)


def _shifted(padded: np.ndarray, axis_xyz: int, shift: int) -> np.ndarray:
    """View of the padded volume moved by `shift` voxels along axis x/y/z, cropped to the original."""
    return _shifted2(padded, axis_xyz, shift, axis_xyz, 0)


def _shifted2(padded: np.ndarray, axis_a: int, shift_a: int, axis_b: int, shift_b: int) -> np.ndarray:
    shifts = [0, 0, 0]  # in array order z, y, x
    shifts[2 - axis_a] += shift_a
    shifts[2 - axis_b] += shift_b
    return padded[tuple(slice(1 + s, n - 1 + s) for s, n in zip(shifts, padded.shape))]


# ----------------------------------------------------------------------------------------------
# Argument checks
# ----------------------------------------------------------------------------------------------

def _volume(data, where: str) -> np.ndarray:
    volume = np.asarray(data)
    if volume.ndim != 3 or 0 in volume.shape or volume.dtype.kind not in "uif":
        raise ValueError(f"{where}: need a non-empty numeric 3D [z, y, x] array, got dtype "
                         f"{volume.dtype}, shape {volume.shape}")
    return volume


def _points(points_xyz, where: str) -> tuple[np.ndarray, np.ndarray]:
    points = np.asarray(points_xyz, dtype=np.float64)
    if points.shape[-1:] != (3,):
        raise ValueError(f"{where}: points must have shape (..., 3) in (x, y, z), got {points.shape}")
    bad = ~np.all(np.isfinite(points), axis=-1)
    # unusable points are sampled at the origin and their results set to NaN by the callers
    return np.where(bad[..., None], 0.0, points), bad


def _spacing(spacing, where: str) -> np.ndarray:
    world = np.asarray(spacing, dtype=np.float64).reshape(-1)
    if world.shape != (3,) or not np.all(np.isfinite(world) & (world > 0)):
        raise ValueError(f"{where}: spacing must be three positive numbers (x, y, z), got {spacing!r}")
    return world


def _check_boundary(boundary: str, where: str) -> None:
    if boundary not in BOUNDARIES:
        raise ValueError(f"{where}: boundary must be one of {BOUNDARIES}, got {boundary!r}")


def _check_step(step: float, where: str) -> None:
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"{where}: step must be a positive number of voxels, got {step!r}")
