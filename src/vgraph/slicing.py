"""Slice planes: where a SliceViewer's image lies in the world, and its pixel <-> world maps.

Conventions (the SliceViewer's docstring and docs/guide/exploring.md say the same for users):
- World axes are the patient's, RAS (docs/explanations/conventions.md): +x towards the patient's right, +y
  to the front (anterior), +z up (superior), as vgraph.camera's named views read them.
- Named orientations are shown as named views show them. ``display`` radiological (the default,
  the patient's right on the image's left, as DICOM viewers and 3D Slicer show axial and coronal
  slices): axial = constant z seen from below (the "bottom" view: image right = -x, image up =
  +y), coronal = constant y seen from the front ("front": right = -x, up = +z). ``display``
  neurological (the patient's right on the image's right): axial seen from above ("top": right =
  +x, up = +y), coronal from behind ("back": right = +x, up = +z): the radiological images
  mirrored left to right. Sagittal = constant x seen from the left ("left": right = -y, up = +z)
  in both: its image has no left and right of the patient.
- A custom plane's ``normal`` points towards the viewer, like a named view's eye direction, so the
  normals (0, 0, -1), (0, 1, 0) and (-1, 0, 0) give exactly the radiological axial, coronal and
  sagittal images. Its image up is world z projected onto the plane (world y when the normal is
  along z), image right = up x normal (the camera's forward x up with forward = -normal); the
  display does not change it (the normal says which side it is seen from).
- The plane passes through the cursor (default: the centre of the volume's box).
- The volume's box here is its cells' box (``GridBox``): the index box [-1/2, n - 1/2] on every
  axis through the volume's affine (origin, direction, spacing), an oriented box in the world:
  every voxel shown whole, so an axis-aligned slice of n voxels drawn at n pixels has each pixel
  centre on a voxel centre. By default the image fits the box's projection onto the plane with
  square pixels (aspect kept), centred on the box's projection; ``zoom`` z magnifies about the
  cursor: the view centre is cursor + (box centre - cursor) / z in the plane, pixels 1 / z as big.
- Image coordinates (u, v) in [0, 1]: u to the right, v UP (GL's uv, row v = 0 at the bottom).
  Pixel (column c, row r), row 0 at the TOP (Image.to_numpy, Qt), has its centre at
  u = (c + 0.5) / width, v = 1 - (r + 0.5) / height.
- Sampling goes world -> voxel indices through the inverse of the affine (``GridBox.indices`` and
  ``index_vectors``), in float64: the SliceViewer hands its shader the plane in voxel indices.
  For an axis-aligned volume every number is what it was before volumes had directions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.camera import VIEWS
from vgraph.errors import VGraphError
from vgraph.volume_grid import IDENTITY, Matrix3, is_identity

Vec3 = tuple[float, float, float]

DISPLAYS = ("radiological", "neurological")
# orientation -> the named view it is seen from (vgraph.camera.VIEWS: eye direction, up), by display
ORIENTATIONS = {"axial": "bottom", "coronal": "front", "sagittal": "left"}
_SEEN_FROM = {"radiological": ORIENTATIONS,
              "neurological": {"axial": "top", "coronal": "back", "sagittal": "left"}}
_TINY = 1e-12


@dataclass(frozen=True)
class GridBox:
    """A volume's grid as plain tuples (it pickles to the GUI process): voxel (i, j, k) at
    origin + direction @ ((i, j, k) * spacing) (vgraph.volume_grid), ``dims`` voxels (x, y, z)."""
    origin: Vec3
    spacing: Vec3
    direction: Matrix3  # rows; column c = the world direction of index axis c
    dims: tuple[int, int, int]

    @classmethod
    def of(cls, volume) -> "GridBox":
        return cls(_tuple(volume.origin), _tuple(volume.spacing),
                   tuple(_tuple(row) for row in volume.direction), tuple(int(n) for n in volume.dims))

    def turned(self, vectors) -> np.ndarray:
        """Vectors (..., 3) in the index axes' frame -> world (untouched for an axis-aligned grid,
        so its numbers stay exactly what they were)."""
        vectors = np.asarray(vectors, dtype=np.float64)
        return vectors if is_identity(self.direction) else vectors @ np.asarray(self.direction).T

    def _low_and_extent(self, cells: bool) -> tuple[np.ndarray, np.ndarray]:
        spacing, dims = np.asarray(self.spacing), np.asarray(self.dims, dtype=np.float64)
        if not cells:
            return np.asarray(self.origin, dtype=np.float64), (dims - 1.0) * spacing
        return self.origin + self.turned(-0.5 * spacing), dims * spacing

    def corners(self, cells: bool = True) -> np.ndarray:
        """The 8 world corners (8, 3) of the box of the voxels' cells (or, ``cells`` False, of
        their centres); corner k takes the high side along index axis a where bit a of k is set."""
        low, extent = self._low_and_extent(cells)
        return low + self.turned(extent * _CORNER_BITS)

    def centre(self) -> np.ndarray:
        low, extent = self._low_and_extent(True)
        return low + self.turned(0.5 * extent)

    def indices(self, points) -> np.ndarray:
        """Voxel indices (..., 3) (i, j, k) of world points (Volume.world_to_voxel)."""
        return index_vectors(np.asarray(points, dtype=np.float64) - np.asarray(self.origin),
                             self.spacing, self.direction)


def index_vectors(vectors, spacing, direction: Matrix3 = IDENTITY) -> np.ndarray:
    """World vectors (..., 3) in voxel-index units along the index axes: the linear part of the
    inverse affine (an orthonormal direction's inverse is its transpose)."""
    vectors = np.asarray(vectors, dtype=np.float64)
    if not is_identity(direction):
        vectors = vectors @ np.asarray(direction)
    return vectors / np.asarray(spacing, dtype=np.float64)


def voxel_step(normal, spacing, direction: Matrix3 = IDENTITY) -> float:
    """World distance along the unit ``normal`` that spans one voxel of a grid with that spacing
    and direction: the distance whose displacement, counted in voxels, is 1 long (for an axial,
    coronal or sagittal slice of an axis-aligned volume, the spacing along its axis). The wheel
    pages by it and a thick slab samples at it."""
    return 1.0 / float(np.linalg.norm(index_vectors(normal, spacing, direction)))


@dataclass(frozen=True)
class SlicePlane:
    """An image's rectangle in the world: plain tuples, so it pickles to the GUI process."""
    centre: Vec3  # the world point at the image centre, (u, v) = (0.5, 0.5)
    right: Vec3   # world vector from the left edge to the right edge
    up: Vec3      # world vector from the bottom edge to the top edge
    normal: Vec3  # unit, towards the viewer
    box: GridBox | None = None  # the sliced volume's grid: outline() cuts its cells' box

    @property
    def box_low(self) -> Vec3 | None:
        """The lowest world corner of the axis-aligned box around the cells' box."""
        return None if self.box is None else _tuple(self.box.corners().min(axis=0))

    @property
    def box_size(self) -> Vec3 | None:
        """The size of the axis-aligned box around the cells' box."""
        return None if self.box is None else _tuple(np.ptp(self.box.corners(), axis=0))

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
        """Where the plane cuts the volume's cells' box (oriented as the volume): the polygon's
        corners (k, 3), k = 0 or 3 to 6, in order around it (counter-clockwise as the image shows
        them), for drawing the slice in a 3D view. Empty when the plane misses the box or the
        box is unknown. The affine map takes the index box's edges to the oriented box's, so
        cutting the world edges is cutting the index box and mapping the polygon back."""
        if self.box is None:
            return np.zeros((0, 3))
        corners = self.box.corners()
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


def plane_axes(orientation: str, normal=None, display: str = "radiological"
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(normal towards the viewer, image right, image up), unit vectors, of an orientation in a
    display (DISPLAYS); a ``custom`` one takes ``normal`` (any non-zero length). ValueError for a
    zero normal or an unknown orientation or display."""
    if display not in _SEEN_FROM:
        raise ValueError(f"unknown display {display!r}; choose one of {', '.join(DISPLAYS)}")
    if orientation in ORIENTATIONS:
        towards_eye, up = VIEWS[_SEEN_FROM[display][orientation]]
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


def slice_plane(orientation: str, normal, cursor, zoom: float, origin, spacing, dims,
                size: tuple[int, int], direction: Matrix3 = IDENTITY,
                display: str = "radiological", pan=None) -> SlicePlane:
    """The rectangle an image of ``size`` pixels shows of a volume with that grid (module
    docstring). ``cursor`` None = the box centre; ``pan`` a world vector whose part in the plane
    moves the image's centre (so one pan vector linked between views pans them together).
    ValueError for a zero normal or zoom <= 0."""
    if not zoom > 0.0:
        raise ValueError(f"the zoom must be positive, got {zoom!r}")
    n, right, up = plane_axes(orientation, normal, display)
    box = GridBox(_tuple(origin), _tuple(spacing), tuple(_tuple(row) for row in direction),
                  tuple(int(d) for d in dims))
    box_centre = box.centre()
    point = box_centre if cursor is None else np.asarray(cursor, dtype=np.float64)
    corners = box.corners()
    width_world = float(np.ptp(corners @ right))
    height_world = float(np.ptp(corners @ up))
    width, height = size
    pixel = max(width_world / width, height_world / height) / zoom
    towards = box_centre - point
    in_plane = towards - (towards @ n) * n
    centre = point + in_plane / zoom
    if pan is not None and np.any(np.asarray(pan, dtype=np.float64)):
        pan = np.asarray(pan, dtype=np.float64)
        centre = centre + pan - (pan @ n) * n
    return SlicePlane(centre=_tuple(centre), right=_tuple(right * pixel * width),
                      up=_tuple(up * pixel * height), normal=_tuple(n), box=box)


def checked_plane(where: str, **arguments) -> SlicePlane:
    """slice_plane(), with its ValueError as a VGraphError naming ``where``."""
    try:
        return slice_plane(**arguments)
    except ValueError as error:
        raise VGraphError(f"{where}: {error}") from None


def _tuple(vector) -> tuple[float, float, float]:
    return tuple(float(x) for x in vector)
