"""Slice planes: where a SliceViewer's image lies in the world, and its pixel <-> world maps.

Conventions (the SliceViewer's docstring and docs/exploring.md say the same for users):
- Named orientations are shown as vgraph.camera's named views show them (world x right, y front,
  z up; radiological display, the patient's right on the image's left): axial = constant z seen
  from below (the "bottom" view: image right = -x, image up = +y), coronal = constant y seen from
  the front ("front": right = -x, up = +z), sagittal = constant x seen from the left ("left":
  right = -y, up = +z).
- A custom plane's ``normal`` points towards the viewer, like a named view's eye direction, so the
  normals (0, 0, -1), (0, 1, 0) and (-1, 0, 0) give exactly the axial, coronal and sagittal images.
  Its image up is world z projected onto the plane (world y when the normal is along z), image
  right = up x normal (the camera's forward x up with forward = -normal).
- The plane passes through the cursor (default: the centre of the volume's box).
- The volume's box here is its cells' box, [origin - spacing / 2, origin + (dims - 1/2) spacing]:
  every voxel shown whole, so an axis-aligned slice of n voxels drawn at n pixels has each pixel
  centre on a voxel centre. By default the image fits the box's projection onto the plane with
  square pixels (aspect kept), centred on the box's projection; ``zoom`` z magnifies about the
  cursor: the view centre is cursor + (box centre - cursor) / z in the plane, pixels 1 / z as big.
- Image coordinates (u, v) in [0, 1]: u to the right, v UP (GL's uv, row v = 0 at the bottom).
  Pixel (column c, row r), row 0 at the TOP (Image.to_numpy, Qt), has its centre at
  u = (c + 0.5) / width, v = 1 - (r + 0.5) / height.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.camera import VIEWS
from vgraph.errors import VGraphError

# orientation -> the named view it is seen from (vgraph.camera.VIEWS: eye direction, up)
ORIENTATIONS = {"axial": "bottom", "coronal": "front", "sagittal": "left"}
_TINY = 1e-12


@dataclass(frozen=True)
class SlicePlane:
    """An image's rectangle in the world: plain tuples, so it pickles to the GUI process."""
    centre: tuple[float, float, float]  # the world point at the image centre, (u, v) = (0.5, 0.5)
    right: tuple[float, float, float]   # world vector from the left edge to the right edge
    up: tuple[float, float, float]      # world vector from the bottom edge to the top edge
    normal: tuple[float, float, float]  # unit, towards the viewer
    box_low: tuple[float, float, float] | None = None   # the volume's cell box (cell_box), for
    box_size: tuple[float, float, float] | None = None  # outline(): where the plane cuts it

    def world_at(self, u, v) -> np.ndarray:
        """World points (..., 3) at image coordinates u, v (module docstring)."""
        u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
        return (np.asarray(self.centre) + (u - 0.5)[..., None] * np.asarray(self.right)
                + (v - 0.5)[..., None] * np.asarray(self.up))

    def pixel_to_world(self, column, row, size: tuple[int, int]) -> np.ndarray:
        """World points at pixel centres (column, row); row 0 at the top; size = (width, height).
        Fractional pixels are allowed: column 0.0 is the left pixel's centre, -0.5 its left edge."""
        width, height = size
        u = (np.asarray(column, dtype=np.float64) + 0.5) / width
        v = 1.0 - (np.asarray(row, dtype=np.float64) + 0.5) / height
        return self.world_at(u, v)

    def uv_of(self, points) -> np.ndarray:
        """Image coordinates (..., 2) of world points projected onto the plane."""
        offset = np.asarray(points, dtype=np.float64) - np.asarray(self.centre)
        right, up = np.asarray(self.right), np.asarray(self.up)
        return np.stack([offset @ right / (right @ right) + 0.5, offset @ up / (up @ up) + 0.5],
                        axis=-1)

    def corners(self) -> np.ndarray:
        """The image's four corners in the world (4, 3): bottom-left, bottom-right, top-right,
        top-left (for drawing the plane's outline in a 3D view)."""
        return self.world_at(np.array([0.0, 1.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0, 1.0]))


    def outline(self) -> np.ndarray:
        """Where the plane cuts the volume's cell box: the polygon's corners (k, 3), k = 0 or 3
        to 6, in order around it (counter-clockwise as the image shows them), for drawing the
        slice in a 3D view. Empty when the plane misses the box or the box is unknown."""
        if self.box_low is None or self.box_size is None:
            return np.zeros((0, 3))
        low, size = np.asarray(self.box_low), np.asarray(self.box_size)
        corners = low + size * _CORNER_BITS
        depth = (corners - np.asarray(self.centre)) @ np.asarray(self.normal)
        points = []
        for a, b in _BOX_EDGES:
            if (depth[a] <= 0.0) != (depth[b] <= 0.0):  # the edge crosses the plane
                t = depth[a] / (depth[a] - depth[b])
                points.append(corners[a] + t * (corners[b] - corners[a]))
        if len(points) < 3:
            return np.zeros((0, 3))
        points = np.array(points)
        uv = self.uv_of(points) - self.uv_of(points.mean(axis=0))
        return points[np.argsort(np.arctan2(uv[:, 1], uv[:, 0]))]


# Corner k of a box takes the high side along axis a where bit a of k is set; edges join corners
# one bit apart.
_CORNER_BITS = np.array([[(k >> axis) & 1 for axis in range(3)] for k in range(8)], dtype=np.float64)
_BOX_EDGES = [(k, k | 1 << axis) for k in range(8) for axis in range(3) if not k & 1 << axis]


def plane_axes(orientation: str, normal=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(normal towards the viewer, image right, image up), unit vectors, of an orientation; a
    ``custom`` one takes ``normal`` (any non-zero length). ValueError for a zero normal."""
    if orientation in ORIENTATIONS:
        towards_eye, up = VIEWS[ORIENTATIONS[orientation]]
        n, up = np.asarray(towards_eye, dtype=np.float64), np.asarray(up, dtype=np.float64)
        return n, np.cross(up, n), up
    if orientation != "custom":
        raise ValueError(f"unknown orientation {orientation!r}; choose one of "
                         f"{', '.join([*ORIENTATIONS, 'custom'])}")
    n = np.asarray(normal, dtype=np.float64)
    length = float(np.linalg.norm(n)) if n.shape == (3,) else 0.0
    if not np.isfinite(length) or length < _TINY:
        raise ValueError(f"the normal {tuple(normal) if normal is not None else None} has no "
                         f"direction; give a non-zero (x, y, z)")
    n = n / length
    up = np.array([0.0, 0.0, 1.0]) - n[2] * n  # world z in the plane ...
    if np.linalg.norm(up) < 1e-6:
        up = np.array([0.0, 1.0, 0.0]) - n[1] * n  # ... or world y when the normal is along z
    up /= np.linalg.norm(up)
    return n, np.cross(up, n), up


def cell_box(origin, spacing, dims) -> tuple[np.ndarray, np.ndarray]:
    """(lowest corner, size) of the voxels' cells in the world (module docstring)."""
    spacing = np.asarray(spacing, dtype=np.float64)
    low = np.asarray(origin, dtype=np.float64) - 0.5 * spacing
    return low, np.asarray(dims, dtype=np.float64) * spacing


def slice_plane(orientation: str, normal, cursor, zoom: float, origin, spacing, dims,
                size: tuple[int, int]) -> SlicePlane:
    """The rectangle an image of ``size`` pixels shows of a volume with that geometry (module
    docstring). ``cursor`` None = the box centre. ValueError for a zero normal or zoom <= 0."""
    if not zoom > 0.0:
        raise ValueError(f"the zoom must be positive, got {zoom!r}")
    n, right, up = plane_axes(orientation, normal)
    low, extent = cell_box(origin, spacing, dims)
    box_centre = low + 0.5 * extent
    point = box_centre if cursor is None else np.asarray(cursor, dtype=np.float64)
    corners = low + extent * np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    width_world = float(np.ptp(corners @ right))
    height_world = float(np.ptp(corners @ up))
    width, height = size
    pixel = max(width_world / width, height_world / height) / zoom
    towards = box_centre - point
    in_plane = towards - (towards @ n) * n
    centre = point + in_plane / zoom
    return SlicePlane(centre=_tuple(centre), right=_tuple(right * pixel * width),
                      up=_tuple(up * pixel * height), normal=_tuple(n), box_low=_tuple(low),
                      box_size=_tuple(extent))


def checked_plane(where: str, **arguments) -> SlicePlane:
    """slice_plane(), with its ValueError as a VGraphError naming ``where``."""
    try:
        return slice_plane(**arguments)
    except ValueError as error:
        raise VGraphError(f"{where}: {error}") from None


def _tuple(vector) -> tuple[float, float, float]:
    return tuple(float(x) for x in vector)
