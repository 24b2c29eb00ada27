"""Boxes of the CPU references (reference_raycast, multivolume_reference): where the rays of
one volume or of several start and end, the box a camera frames, and which points a volume holds,
for volumes whose index axes may be turned against the world (Volume.direction).

- A volume's box of voxel centres is the index box [0, n - 1] through its affine: an oriented box
  in the world. It is axis-aligned in the turned coordinates ``q = rotation^T p`` of a rotation
  whose columns are its index axes, up to order and sign: the volume's own direction. A ray keeps
  its parameter t under that turn (it keeps lengths), so the slab test of rule 2 of
  reference_raycast runs there unchanged, and its t are the world ray's.
- Several volumes (the multi-volume rays) are turned alike (the MultiVolumeRayCaster refuses
  others): their union box is taken in the turned coordinates of the first one's direction.
- The crop box is a box along the WORLD axes (vgraph.clipping); for turned volumes it cuts each
  ray's interval by its own slab test in the world.
- Framing: a camera frames a box by its bounding sphere (Camera.framing, clipping_range), so the
  box it is resolved on (``volume_box``, ``RayBox.framing``) is the box along the world axes with
  the oriented box's centre and sphere: the world box of a volume whose axes only permute and
  mirror the world's (an LPS file's: the oriented box is that box), else the box as it lies in its
  own axes, moved to its world centre (as the ray casters frame a tilted volume in its turned
  frame, vgraph.box_frame).
- Volumes on the world axes (identity direction) take exactly the arithmetic they took before
  volumes had directions: the same numbers to the last bit.
"""

from __future__ import annotations

import numpy as np

from vgraph.clipping import cropped_box
from vgraph.grid_axes import axes_against
from vgraph.volume import Volume
from vgraph.volume_grid import IDENTITY

BOX_EPSILON = 1e-9  # relative growth of the box (reference_raycast, rule 2)


def volume_box(volume: Volume) -> tuple[np.ndarray, np.ndarray]:
    """World-space (min, max) corners of the box spanned by the voxel centres, (x, y, z), for a
    volume on the world axes; for an oriented one the box a camera frames it by (module
    docstring)."""
    if volume.is_axis_aligned:
        lo = np.asarray(volume.origin, dtype=np.float64)
        return lo, lo + volume.extent
    return RayBox.of([volume]).framing()


def turned_alike(direction, other) -> bool:
    """Whether two directions differ only in the order and sign of their axes (vgraph.grid_axes):
    the two grids' boxes are then axis-aligned in the same turned coordinates."""
    return axes_against(direction, other) is not None


class RayBox:
    """The box the rays of some volumes span: [low, high] in the turned coordinates q =
    rotation^T p (``rotation`` None: the world axes, every volume axis-aligned)."""

    def __init__(self, low, high, rotation: np.ndarray | None = None):
        self.low, self.high, self.rotation = np.asarray(low), np.asarray(high), rotation

    @classmethod
    def of(cls, volumes) -> "RayBox":
        """The union of the volumes' boxes of voxel centres (one volume: its own box, exactly)."""
        if all(volume.is_axis_aligned for volume in volumes):
            boxes = [volume_box(volume) for volume in volumes]
            return cls(np.min([low for low, _ in boxes], axis=0), np.max([high for _, high in boxes], axis=0))
        rotation = np.asarray(volumes[0].direction, dtype=np.float64)
        turned = np.concatenate([volume_corners(volume) @ rotation for volume in volumes])
        return cls(turned.min(axis=0), turned.max(axis=0), rotation)

    def framing(self) -> tuple[np.ndarray, np.ndarray]:
        """The world box a camera is resolved on (module docstring)."""
        if self.rotation is None:
            return self.low, self.high
        centre = self.rotation @ ((self.low + self.high) / 2.0)
        half = (self.high - self.low) / 2.0
        if turned_alike(self.rotation, IDENTITY):
            half = np.abs(self.rotation) @ half  # the world box itself
        return centre - half, centre + half

    def clip(self, origins, directions, t_far, min_spacing, crop_box=None):
        """(t_entry, t_exit) per ray: the slab test against this box (reference_raycast, rule 2)
        and the crop box; t_exit < t_entry for misses."""
        if self.rotation is None:
            box = cropped_box(self.low, self.high, crop_box)  # the crop box narrows the box
            t_entry, t_exit = slab_interval(origins, directions, *(box or (self.low, self.high)),
                                            t_far, min_spacing)
            if box is None:  # the crop box leaves nothing: every ray misses
                t_exit[:] = -np.inf
            return t_entry, t_exit
        t_entry, t_exit = slab_interval(origins @ self.rotation, directions @ self.rotation, self.low,
                                        self.high, t_far, min_spacing)
        if crop_box is not None:
            crop = np.asarray(crop_box, dtype=np.float64)
            crop_entry, crop_exit = slab_interval(origins, directions, crop[:3], crop[3:], t_far, min_spacing)
            t_entry, t_exit = np.maximum(t_entry, crop_entry), np.minimum(t_exit, crop_exit)
        return t_entry, t_exit


def volume_corners(volume: Volume) -> np.ndarray:
    """The 8 world corners (8, 3) of the box of voxel centres."""
    last = np.asarray(volume.dims, dtype=np.float64) - 1.0
    return volume.voxel_to_world(np.array([(i, j, k) for i in (0.0, last[0]) for j in (0.0, last[1])
                                           for k in (0.0, last[2])]))


def slab_interval(origins, directions, box_min, box_max, t_far, min_spacing):
    """Slab test (reference_raycast, rule 2): (t_entry, t_exit) per ray against the box grown by
    BOX_EPSILON * (max |corner coordinate| + min spacing); t_exit < t_entry for misses."""
    eps = BOX_EPSILON * (max(np.abs(box_min).max(), np.abs(box_max).max()) + min_spacing)
    lo, hi = box_min - eps, box_max + eps
    t_in = np.zeros(len(origins))
    t_out = np.array(t_far, dtype=np.float64)
    for axis in range(3):
        o, d = origins[:, axis], directions[:, axis]
        parallel = d == 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            t0, t1 = (lo[axis] - o) / d, (hi[axis] - o) / d
        near_t, far_t = np.minimum(t0, t1), np.maximum(t0, t1)
        # A ray parallel to the slab is inside it for all t or for none.
        inside = (o >= lo[axis]) & (o <= hi[axis])
        near_t[parallel] = np.where(inside[parallel], -np.inf, np.inf)
        far_t[parallel] = np.where(inside[parallel], np.inf, -np.inf)
        t_in, t_out = np.maximum(t_in, near_t), np.minimum(t_out, far_t)
    return t_in, t_out


def inside_grown_box(volume: Volume, points: np.ndarray, relative_growth: float) -> np.ndarray:
    """Which world points lie in the volume's box of voxel centres grown by ``relative_growth`` *
    (max |world corner coordinate| + min spacing) on every side (multivolume_reference, rule 3),
    measured along its own index axes."""
    if volume.is_axis_aligned:
        low, high = volume_box(volume)
        eps = relative_growth * (max(np.abs(low).max(), np.abs(high).max()) + min(volume.spacing))
        return np.all((points >= low - eps) & (points <= high + eps), axis=1)
    eps = relative_growth * (np.abs(volume_corners(volume)).max() + min(volume.spacing))
    along = (np.asarray(points, dtype=np.float64) - np.asarray(volume.origin)) @ np.asarray(volume.direction)
    return np.all((along >= -eps) & (along <= volume.extent + eps), axis=1)
