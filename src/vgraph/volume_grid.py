"""Where a volume's grid can lie: the checks every volume (in memory or bricked) makes of its
spacing, direction, origin and box (docs/guide/volumes.md, "Limits"), and the grid's affine.

Voxel (i, j, k) has its centre at ``origin + direction @ ((i, j, k) * spacing)`` in patient space
(RAS, docs/explanations/conventions.md): ``direction`` is the 3x3 matrix of direction cosines, its columns the
world directions of the index axes i, j, k (``grid_affine``).

- direction: finite, columns of unit length and perpendicular to each other within
  ORTHOGONALITY_TOLERANCE, then made exactly orthonormal (a file's float32 cosines differ from
  orthonormal by ~1e-7); a sheared grid is refused by name (``checked_direction``): vgraph draws
  volumes as boxes, and dropping the shear silently moved the anatomy;

- spacing 1e-15 .. 1e15 and origin within +-1e15 per axis (``checked_vec3``);
- the box of voxel centres (all 8 corners, turned by the direction) within +-1e15 (MAX_COORDINATE, what a camera holds), and the smallest
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
Matrix3 = tuple[Vec3, Vec3, Vec3]  # rows of a 3x3 matrix

IDENTITY: Matrix3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
# How far a file's direction cosines may be from orthonormal (dot products of the columns, lengths
# from 1) and still be read as a rotation: NIfTI stores them as float32 (~1e-7), DICOM as decimal
# strings of up to 16 characters. A shear of 1e-4 moves a voxel 256 voxels away by 0.03 voxels.
ORTHOGONALITY_TOLERANCE = 1e-4

# The smallest spacing as a share of the box's largest coordinate: float64 keeps ~16 digits, so
# voxel centres are then placed to ~1e-4 voxels (box_frame subtracts the box's centre in float64);
# a spacing of 1e-15 at 1e3 from the origin merges the voxels into one point.
FLOAT64_RESOLUTION = 1e-12


class VolumeGeometryError(VGraphError):
    """A volume's grid cannot be drawn (check_box); ``field`` is the grid field to change."""

    def __init__(self, where: str, reason: str, field: str):
        self.reason, self.field = reason, field
        super().__init__(f"volume{where}: {reason}")


def check_box(dims, spacing: Vec3, origin: Vec3, where: str = "", direction: Matrix3 = IDENTITY) -> None:
    """Refuse (VolumeGeometryError naming ``spacing``) a grid whose box of voxel centres (its 8
    corners) reaches beyond +-MAX_COORDINATE, or whose smallest spacing is below
    FLOAT64_RESOLUTION of the box's largest coordinate (the module docstring says why)."""
    reach = float(np.abs(box_corners(dims, spacing, origin, direction)).max())
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


def grid_affine(spacing: Vec3, origin: Vec3, direction: Matrix3 = IDENTITY) -> np.ndarray:
    """The 4x4 matrix that takes homogeneous voxel indices (i, j, k, 1) to world points (float64):
    ``direction @ diag(spacing)`` and ``origin`` (nibabel's ``affine``, in RAS)."""
    affine = np.eye(4)
    affine[:3, :3] = np.asarray(direction, dtype=np.float64) * np.asarray(spacing, dtype=np.float64)
    affine[:3, 3] = origin
    return affine


def box_corners(dims, spacing: Vec3, origin: Vec3, direction: Matrix3 = IDENTITY) -> np.ndarray:
    """The 8 world corners (8, 3) of the box of voxel centres."""
    last = np.asarray(dims, dtype=np.float64) - 1.0
    indices = np.array([(i, j, k) for i in (0.0, last[0]) for j in (0.0, last[1]) for k in (0.0, last[2])])
    return indices @ grid_affine(spacing, origin, direction)[:3, :3].T + np.asarray(origin, dtype=np.float64)


def checked_direction(value, where: str = "") -> Matrix3:
    """``value`` (3x3, columns = world directions of the index axes) as an exactly orthonormal
    matrix of plain floats. VolumeGeometryError naming ``direction`` for anything else: not 3x3
    finite numbers, a column of zero length, or columns that are not perpendicular and of unit
    length within ORTHOGONALITY_TOLERANCE (a sheared or scaled grid, which a box cannot draw)."""
    try:
        matrix = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        matrix = None
    if matrix is None or matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise VolumeGeometryError(where, f"direction must be a 3x3 matrix of finite numbers (its "
                                         f"columns the world directions of the index axes), got "
                                         f"{value!r}", "direction")
    gram = matrix.T @ matrix
    error = float(np.abs(gram - np.eye(3)).max())
    if error > ORTHOGONALITY_TOLERANCE:
        raise VolumeGeometryError(where, f"the direction cosines {np.round(matrix, 6).tolist()} are "
                                         f"{_shear_words(gram)}: vgraph draws grids whose axes are "
                                         f"perpendicular unit vectors (a rotation, possibly mirrored); "
                                         f"resample the volume onto such a grid first (e.g. "
                                         f"nibabel.processing.resample_to_output)", "direction")
    u, _, vt = np.linalg.svd(matrix)  # the nearest orthonormal matrix (polar decomposition)
    return tuple(tuple(float(v) for v in row) for row in u @ vt)


def _shear_words(gram: np.ndarray) -> str:
    lengths = np.sqrt(np.diag(gram))
    if np.abs(lengths - 1.0).max() > ORTHOGONALITY_TOLERANCE and np.abs(gram - np.diag(np.diag(gram))).max() \
            <= ORTHOGONALITY_TOLERANCE:
        return f"not of unit length (lengths {np.round(lengths, 6).tolist()})"
    with np.errstate(divide="ignore", invalid="ignore"):  # a zero column: its angles are nan
        cosines = gram / np.outer(lengths, lengths)
    angles = [float(np.degrees(np.arccos(np.clip(cosines[a, b], -1.0, 1.0)))) for a, b in ((0, 1), (0, 2), (1, 2))]
    return (f"sheared: the index axes meet at {angles[0]:.4g}, {angles[1]:.4g} and {angles[2]:.4g} "
            f"degrees (i-j, i-k, j-k), not 90")


def is_identity(direction: Matrix3) -> bool:
    return tuple(map(tuple, direction)) == IDENTITY


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
