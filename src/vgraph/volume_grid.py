"""Where a volume's grid can lie: the checks every volume (in memory or bricked) makes of its
spacing, origin and box (docs/volumes.md, "Limits").

- spacing 1e-15 .. 1e15 and origin within +-1e15 per axis (``checked_vec3``);
- the box of voxel centres within +-1e15 (MAX_COORDINATE, what a camera holds), and the smallest
  spacing at least FLOAT64_RESOLUTION of the box's largest coordinate, so that the voxel centres
  stay distinct in float64 and the box can be moved into its normalised frame (vgraph.box_frame),
  where ray casters draw boxes too small, too large or too far out for float32 world units
  (``check_box``).
"""

from __future__ import annotations

import numpy as np

from vgraph.camera import MAX_COORDINATE
from vgraph.errors import VGraphError

Vec3 = tuple[float, float, float]

# The smallest spacing as a share of the box's largest coordinate: float64 keeps ~16 digits, so
# voxel centres are then placed to ~1e-4 voxels (box_frame subtracts the box's centre in float64);
# a spacing of 1e-15 at 1e3 from the origin merges the voxels into one point.
FLOAT64_RESOLUTION = 1e-12


class VolumeGeometryError(VGraphError):
    """A volume's grid cannot be drawn (check_box); ``field`` is the grid field to change."""

    def __init__(self, where: str, reason: str, field: str):
        self.reason, self.field = reason, field
        super().__init__(f"volume{where}: {reason}")


def check_box(dims, spacing: Vec3, origin: Vec3, where: str = "") -> None:
    """Refuse (VolumeGeometryError naming ``spacing``) a grid whose box of voxel centres, origin ..
    origin + (dims - 1) spacing, reaches beyond +-MAX_COORDINATE, or whose smallest spacing is
    below FLOAT64_RESOLUTION of the box's largest coordinate (the module docstring says why)."""
    far = [o + (d - 1) * s for d, s, o in zip(dims, spacing, origin)]
    reach = max(max(abs(v) for v in origin), max(abs(v) for v in far))
    if reach > MAX_COORDINATE:
        raise VolumeGeometryError(where, f"the box of voxel centres ({_grid(dims, spacing, origin)}) "
                                         f"reaches {reach:.3g}: beyond +-{MAX_COORDINATE:g}, what GL's "
                                         f"float32 world coordinates and a camera hold; give the "
                                         f"spacing in larger units (smaller numbers)", "spacing")
    if min(spacing) < FLOAT64_RESOLUTION * reach:
        raise VolumeGeometryError(where, f"the spacing is too small for a box {reach:.3g} from the "
                                         f"origin ({_grid(dims, spacing, origin)}): below "
                                         f"{FLOAT64_RESOLUTION:g} of that distance the voxel centres "
                                         f"are not distinct in float64; move the origin nearer the "
                                         f"volume", "spacing")


def _grid(dims, spacing: Vec3, origin: Vec3) -> str:
    return f"{' x '.join(map(str, dims))} voxels of spacing {list(spacing)} from origin {list(origin)}"


def checked_vec3(value, name: str, where: str, positive: bool = False) -> Vec3:
    try:
        vec = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise VGraphError(f"volume{where}: {name} must be three numbers (x, y, z), got {value!r}")
    if len(vec) != 3 or not all(np.isfinite(vec)):
        raise VGraphError(f"volume{where}: {name} must be three finite numbers (x, y, z), got {value!r}")
    if positive and min(vec) <= 0:
        raise VGraphError(f"volume{where}: {name} must be positive, got {vec}")
    if max(abs(v) for v in vec) > MAX_COORDINATE or positive and min(vec) < 1.0 / MAX_COORDINATE:
        raise VGraphError(f"volume{where}: {name} {vec} is outside what GL's float32 world "
                          f"coordinates hold (magnitudes {1 / MAX_COORDINATE:g} to {MAX_COORDINATE:g})")
    return vec
