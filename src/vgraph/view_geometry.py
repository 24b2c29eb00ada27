"""The 3-vector geometry of cameras: a camera's orthonormal frame, rotations, the sphere around a
box and the near/far planes that enclose it. Plain functions on float64 numpy vectors and tuples,
written for the per-frame path (np.cross and friends cost tens of microseconds a call)."""

from __future__ import annotations

import functools
import math

import numpy as np

Vec3 = tuple[float, float, float]

# Near and far planes enclosing a box leave this relative margin around its bounding sphere.
CLIP_MARGIN = 1e-3


@functools.lru_cache(maxsize=64)
def frame_basis(position: Vec3, focus: Vec3, up: Vec3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # Remembered: a frame asks a few renderers' worth of times for the basis of one camera, and
    # np.cross costs tens of microseconds a call (docs/reports/gui-performance.md, per-frame Python).
    forward = unit_vector(np.subtract(focus, position, dtype=np.float64))
    right = unit_vector(cross3(forward, np.asarray(up, dtype=np.float64)))
    vectors = right, cross3(right, forward), forward
    for vector in vectors:
        vector.flags.writeable = False
    return vectors


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of two 3-vectors, the same products and differences in the same order (so the
    same bits), without np.cross's general machinery."""
    (a0, a1, a2), (b0, b1, b2) = a.tolist(), b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def unit_vector(vector: np.ndarray) -> np.ndarray:
    return vector / np.linalg.norm(vector)


def as_vec3(array) -> Vec3:
    return tuple(float(v) for v in array)


def rotation_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """Right-handed rotation by ``angle`` radians about the unit ``axis`` (Rodrigues)."""
    x, y, z = axis
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * cross + (1.0 - math.cos(angle)) * (cross @ cross)


def clipping_range(position, forward: np.ndarray, box_min, box_max) -> tuple[float, float] | None:
    """(near, far) enclosing the box's bounding sphere seen from ``position`` along ``forward``;
    None when the box is entirely behind (see Camera.with_clipping_range)."""
    centre, radius = bounding_sphere(box_min, box_max)
    depth = float((centre - np.asarray(position)) @ forward)
    far = (depth + radius) * (1.0 + CLIP_MARGIN)
    if far <= 0.0:
        return None
    near = (depth - radius) * (1.0 - CLIP_MARGIN)
    return max(near, far * 1e-4), far


def bounding_sphere(box_min, box_max) -> tuple[np.ndarray, float]:
    """(centre, radius) of the sphere around the box: remembered per box, since every frame of a
    camera that fits the data asks three times for the same one (the centre is read-only)."""
    try:
        key = (tuple(map(float, box_min)), tuple(map(float, box_max)))
    except (TypeError, ValueError):
        key = None
    if key is None or len(key[0]) != 3 or len(key[1]) != 3:
        return _sphere_of(box_min, box_max)  # it says what is wrong
    return _remembered_sphere(*key)


@functools.lru_cache(maxsize=64)
def _remembered_sphere(box_min: Vec3, box_max: Vec3) -> tuple[np.ndarray, float]:
    centre, radius = _sphere_of(box_min, box_max)
    centre.flags.writeable = False
    return centre, radius


def _sphere_of(box_min, box_max) -> tuple[np.ndarray, float]:
    lo, hi = np.asarray(box_min, dtype=np.float64), np.asarray(box_max, dtype=np.float64)
    if lo.shape != (3,) or hi.shape != (3,) or not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError(f"box corners must be three finite numbers each, got {box_min!r}, {box_max!r}")
    if np.any(hi < lo):
        raise ValueError(f"box_max {list(hi)} must not be below box_min {list(lo)}")
    # A flat or single-voxel box still needs a sphere to frame.
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-6 * (1.0 + float(np.abs(lo).max())))
    return (lo + hi) / 2.0, radius
