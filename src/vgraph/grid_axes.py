"""How a grid's index axes line up with a frame's axes: the renderers draw a volume as an
axis-aligned box, so an oriented volume (Volume.direction) is drawn on its axes reordered and
mirrored (a view of the same voxels, nothing resampled) in a frame turned by what remains.

    rotation, axes = nearest_rotation(direction)   # direction @ axes.matrix = rotation
    axes = axes_against(direction, rotation)       # None: the grid is turned against that frame
    volume.on_axes(axes)                           # its direction is then the rotation

``GridAxes(order, signs)``: frame axis w is index axis ``order[w]``, counted backwards where
``signs[w]`` is -1. Its matrix P (P[order[w], w] = signs[w]) is a signed permutation. Every
direction that only permutes and mirrors the world axes (LPS, RAS, coronal or sagittal slice
order: almost every scan) gets the identity rotation, so it is drawn exactly as an axis-aligned
volume is; only a tilted acquisition is drawn in a turned frame (vgraph.box_frame).
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass

import numpy as np

from vgraph.errors import VGraphError
from vgraph.volume import Volume, keep_value_statistics
from vgraph.volume_grid import IDENTITY, Matrix3

# Directions that agree this closely (largest element of the difference) are the same: readers
# give float32 or decimal-string cosines, made orthonormal by checked_direction.
SAME_DIRECTION = 1e-6


@dataclass(frozen=True)
class GridAxes:
    order: tuple[int, int, int] = (0, 1, 2)
    signs: tuple[int, int, int] = (1, 1, 1)

    @property
    def is_identity(self) -> bool:
        return self.order == (0, 1, 2) and self.signs == (1, 1, 1)

    @property
    def matrix(self) -> np.ndarray:
        matrix = np.zeros((3, 3))
        for w, (axis, sign) in enumerate(zip(self.order, self.signs)):
            matrix[axis, w] = sign
        return matrix


_ALL_AXES = tuple(GridAxes(order, signs) for order in itertools.permutations(range(3))
                  for signs in itertools.product((1, -1), repeat=3))


def nearest_rotation(direction: Matrix3) -> tuple[Matrix3, GridAxes]:
    """(rotation, axes) with direction @ axes.matrix = rotation, rotation proper (det +1) and as
    near the identity as any such pair (largest trace): the identity whenever the direction only
    permutes and mirrors the world axes."""
    matrix = np.asarray(direction, dtype=np.float64)
    best = max((axes for axes in _ALL_AXES if np.linalg.det(matrix @ axes.matrix) > 0.0),
               key=lambda axes: float(np.trace(matrix @ axes.matrix)))
    rotation = matrix @ best.matrix
    if np.abs(rotation - np.eye(3)).max() <= SAME_DIRECTION:
        return IDENTITY, best
    return tuple(tuple(float(v) for v in row) for row in rotation), best


def axes_against(direction: Matrix3, rotation: Matrix3) -> GridAxes | None:
    """The axes with direction @ axes.matrix = rotation (within SAME_DIRECTION), or None when the
    grid is turned against the frame by more than a permutation and mirroring of its axes."""
    turned = np.asarray(direction, dtype=np.float64).T @ np.asarray(rotation, dtype=np.float64)
    for axes in _ALL_AXES:
        if np.abs(turned - axes.matrix).max() <= SAME_DIRECTION:
            return axes
    return None


def on_axes(volume: Volume, axes: GridAxes) -> Volume:
    """``volume``'s voxels on reordered and mirrored index axes (a vgraph.grid_axes.GridAxes: new
    axis w is old axis order[w], counted backwards where signs[w] < 0): a view of the same array,
    every voxel at the same world point, the value statistics kept (they do not depend on the
    voxels' order). How a volume in a direction that permutes and mirrors the world axes is drawn
    as an axis-aligned box."""
    if axes.is_identity:
        return volume
    if volume.bricks is not None:
        raise VGraphError(f"volume{' from ' + volume.source if volume.source else ''}: a bricked "
                          f"volume cannot be drawn on reordered or mirrored axes; convert it again "
                          f"with vgraph convert, which stores it on axes that need neither")
    data = np.transpose(volume.data, [2 - axes.order[2 - a] for a in range(3)])
    data = np.flip(data, axis=[2 - w for w in range(3) if axes.signs[w] < 0])
    direction = np.asarray(volume.direction) @ axes.matrix
    old_spacing, dims = np.asarray(volume.spacing), np.asarray(volume.dims)
    origin = np.asarray(volume.origin, dtype=np.float64).copy()
    for w, (axis, sign) in enumerate(zip(axes.order, axes.signs)):
        if sign < 0:  # the new first voxel is the old last one along that axis
            origin += np.asarray(volume.direction)[:, axis] * old_spacing[axis] * (dims[axis] - 1)
    changes = {"data": data, "spacing": tuple(float(old_spacing[a]) for a in axes.order),
               "origin": tuple(float(v) for v in origin),
               "direction": tuple(tuple(float(v) for v in row) for row in direction)}
    moved = dataclasses.replace(volume, **changes)
    keep_value_statistics(volume, moved)
    return moved
