"""A volume sampled along a straight line between two world points: what the LineProfile
processor tabulates and plots.

Conventions:
- The points are world points in patient space (the volume's ``affine``: voxel (i, j, k) sits at
  origin + direction @ ((i, j, k) * spacing)); distances are in world units along the line, from
  the start point (0) to the end point (the line's length).
- Sample positions: ``samples`` points evenly spaced from start to end, both ends included; or,
  by ``step``, the points at 0, step, 2 step ... up to the length (the end point only when the
  length is a whole number of steps, to 1e-9 of a step).
- Values are those of scipy.ndimage.map_coordinates at the points' voxel coordinates: nearest
  (order 0) and linear (order 1) on the samples; cubic is the cubic B-spline through the samples
  (Cabral 2010, ch. 3): the coefficients from vgraph.numerics.bspline.prefilter (equal to
  scipy.ndimage.spline_filter with mode='mirror'), evaluated with the same mirror boundary. A
  volume that already holds B-spline coefficients (CubicSplineProcessor) is evaluated as it is,
  by cubic only.
- A point outside the box of voxel centres (voxel coordinates outside [0, n - 1] on some axis, by
  more than 1e-9 voxel) has no value: it gets NaN, and the caller warns (the renderers' clamped
  textures would repeat the edge voxel there, which is no measurement). Points inside get their
  value whatever the boundary rule, since the rules differ only outside.
- A store (a BrickedVolume: ``volume.bricks``) is read only where the line runs, for nearest and
  linear: each run of consecutive samples in one brick reads the box of voxels their
  interpolation touches (BRICK_MARGIN voxels around them) from the full-resolution level, so a
  line through a store larger than memory is measured, with the values the whole array gives
  (map_coordinates on the box, the coordinates shifted by whole voxels). Cubic needs the
  B-spline prefilter over whole lines of the volume: it reads the array whole (within the store's
  memory budget, else MemoryBudgetError).
- Values are float64; NaN voxels give NaN where they enter (nearest: that voxel; linear: the
  cell; cubic: NaN and Inf are replaced by the value range's ends before the prefilter, as the
  CubicSplineProcessor does, or they would spread along whole lines of the volume).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from vgraph.numerics.bspline import prefilter
from vgraph.volume import Volume

ORDERS = {"nearest": 0, "linear": 1, "cubic": 3}
INSIDE_TOLERANCE = 1e-9  # voxels: a point computed on the box's face counts as inside
BRICK_MARGIN = 2  # voxels read beyond a run's samples: nearest and linear reach 1 voxel from a point
MAX_SAMPLES = 1_000_000  # a step of 1e-9 world units would ask for more memory than any profile needs


@dataclass(frozen=True)
class LineSamples:
    distance: np.ndarray  # (n,) world units from the start point
    points: np.ndarray  # (n, 3) world points (x, y, z)
    voxels: np.ndarray  # (n, 3) voxel coordinates (i, j, k), fractional
    values: np.ndarray  # (n,) float64, NaN outside the volume
    outside: np.ndarray  # (n,) bool: the points outside the box of voxel centres


def sample_distances(length: float, samples: int | None = None, step: float | None = None) -> np.ndarray:
    """Distances from the start of a line of ``length`` at which it is sampled (module docstring):
    ``samples`` evenly spaced points, ends included, or one every ``step``."""
    if samples is not None:
        return np.linspace(0.0, length, samples)
    return np.arange(sample_count(length, step)) * step


def sample_count(length: float, step: float) -> int:
    """How many points ``sample_distances(length, step=step)`` gives, without making them."""
    return int(np.floor(length / step + 1e-9)) + 1  # a whole number of steps, to 1e-9 of a step


def sample_line(volume: Volume, start, end, distances: np.ndarray, interpolation: str,
                coefficients: np.ndarray | None = None) -> LineSamples:
    """The volume's values at ``distances`` along start -> end. ``coefficients``: the volume's
    B-spline coefficients, when the caller keeps them between calls (cubic only)."""
    start, end = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    direction = (end - start) / np.linalg.norm(end - start)
    points = start + distances[:, None] * direction
    voxels = volume.world_to_voxel(points)
    outside = outside_voxels(voxels, volume.dims)
    values = np.full(len(distances), np.nan)
    inside = ~outside
    if inside.any():
        values[inside] = _interpolated(volume, voxels[inside], interpolation, coefficients)
    return LineSamples(distances, points, voxels, values, outside)


def outside_voxels(voxels: np.ndarray, dims) -> np.ndarray:
    """Which voxel coordinates (n, 3) lie outside the box of voxel centres of a grid of ``dims``."""
    top = np.asarray(dims, dtype=np.float64) - 1.0
    return np.any((voxels < -INSIDE_TOLERANCE) | (voxels > top + INSIDE_TOLERANCE), axis=1)


def spline_coefficients(volume: Volume) -> np.ndarray:
    """The cubic B-spline coefficients of a volume of samples (float64 work, float32 result, as
    vgraph.numerics.bspline.prefilter gives them); NaN/Inf replaced by the value range's ends."""
    if volume.is_spline_coefficients:
        return volume.data
    data = volume.data
    if volume.nonfinite_count:
        lo, hi = volume.value_range
        data = np.nan_to_num(data.astype(np.float64), nan=lo, posinf=hi, neginf=lo)
    return prefilter(data)


def _interpolated(volume: Volume, voxels: np.ndarray, interpolation: str,
                  coefficients: np.ndarray | None) -> np.ndarray:
    # map_coordinates takes coordinates in array order [z, y, x]; clip the points within the
    # tolerance onto the box, so that no boundary rule is ever consulted
    top = np.asarray(volume.dims, dtype=np.float64) - 1.0
    coordinates = np.clip(voxels, 0.0, top)[:, ::-1].T
    order = ORDERS[interpolation]
    if order == 3:
        data = spline_coefficients(volume) if coefficients is None else coefficients
        return ndimage.map_coordinates(data.astype(np.float64, copy=False), coordinates, order=3,
                                       mode="mirror", prefilter=False)
    if getattr(volume, "bricks", None) is not None:
        return _interpolated_from_bricks(volume.bricks, volume.shape, coordinates, order)
    return _map(volume.data, coordinates, order)


def _map(data: np.ndarray, coordinates: np.ndarray, order: int) -> np.ndarray:
    data = data if order == 0 else data.astype(np.float64, copy=False)
    return ndimage.map_coordinates(data, coordinates, order=order, mode="nearest").astype(np.float64)


def _interpolated_from_bricks(bricks, shape, coordinates: np.ndarray, order: int) -> np.ndarray:
    """``_map`` of the store's level 0, reading only the boxes around runs of consecutive samples
    in one brick (module docstring). ``coordinates``: (3, n) [z, y, x], within the box."""
    brick = np.array(bricks.brick[::-1])[:, None]   # (x, y, z) voxels per brick, as [z, y, x]
    cells = np.floor(coordinates / brick).astype(np.int64)
    breaks = np.flatnonzero(np.any(cells[:, 1:] != cells[:, :-1], axis=0)) + 1
    top = np.asarray(shape, dtype=np.int64)
    values = np.empty(coordinates.shape[1])
    for run in np.split(np.arange(coordinates.shape[1]), breaks):
        part = coordinates[:, run]
        low = np.clip(np.floor(part.min(axis=1)).astype(np.int64) - BRICK_MARGIN, 0, top)
        high = np.clip(np.floor(part.max(axis=1)).astype(np.int64) + BRICK_MARGIN + 1, 0, top)
        block = np.asarray(bricks.read(0, tuple(map(int, low)), tuple(map(int, high))))
        values[run] = _map(block, part - low[:, None], order)   # whole-voxel shifts: exact
    return values
