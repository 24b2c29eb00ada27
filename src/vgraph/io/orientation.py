"""A file's grid in patient space: what readers make of the axis vectors a file declares, and what
writers make of a volume's affine (docs/guide/volumes.md, "World coordinates"; the frame itself:
docs/explanations/conventions.md).

vgraph's world is RAS+, as nibabel's: +x points to the patient's Right, +y Anterior, +z Superior.
DICOM, ITK (MetaImage) and NRRD's ``left-posterior-superior`` use LPS+: a point or an axis vector
goes from one to the other by negating x and y (``lps_ras``, its own inverse).

Readers hand ``split_axes`` the world vector of one step along each index axis (the columns of
a 3x3 matrix, as nibabel's affine[:3, :3]): the spacing is each column's length, the direction
the unit columns, checked to be a rotation (possibly mirrored) by vgraph.volume_grid. A sheared
grid is refused naming the file and its header field; a column the file leaves out (a 2D image,
a NRRD axis of kind ``none``, a zero pixdim) is completed perpendicular to the others with
spacing 1.
"""

from __future__ import annotations

import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.volume_grid import Matrix3, VolumeGeometryError, checked_direction

LPS_TO_RAS = np.diag([-1.0, -1.0, 1.0])  # and back: negating x and y twice changes nothing


def split_axes(axes, file, field: str) -> tuple[tuple[float, float, float], Matrix3, list[int]]:
    """(spacing, direction, missing) of a grid whose index axes step by the columns of ``axes``
    (3x3). ``missing``: the axes the file left without a usable vector (zero length or not
    finite), given spacing 1 and a direction perpendicular to the others (callers warn if they
    must). VolumeFileError naming ``field`` for a sheared or scaled grid."""
    matrix = np.array(axes, dtype=np.float64).reshape(3, 3)
    with np.errstate(invalid="ignore"):
        lengths = np.linalg.norm(matrix, axis=0)
    missing = [c for c in range(3) if not (np.isfinite(lengths[c]) and lengths[c] > 0)]
    unit = np.zeros((3, 3))
    for c in range(3):
        if c not in missing:
            unit[:, c] = matrix[:, c] / lengths[c]
    direction = file_direction(_completed(unit, missing), file, field)
    spacing = tuple(1.0 if c in missing else float(lengths[c]) for c in range(3))
    return spacing, direction, missing


def file_direction(matrix, file, field: str, context: str = "") -> Matrix3:
    """``matrix`` (columns: unit vectors of the index axes) checked by vgraph.volume_grid, its
    refusal (shear, scale, not numbers) raised as a VolumeFileError naming the file's field."""
    try:
        return checked_direction(matrix)
    except VolumeGeometryError as error:
        raise VolumeFileError(file, context + error.reason, field) from None


def _completed(unit: np.ndarray, missing: list[int]) -> np.ndarray:
    """The unit columns with the missing ones filled in perpendicular to the rest (Gram-Schmidt
    on the world axes, the index axis's own first), right-handed where the choice is free."""
    if not missing:
        return unit
    out = unit.copy()
    for c in missing:
        for candidate in (c, *(a for a in range(3) if a != c)):
            vector = np.eye(3)[:, candidate]
            for other in range(3):
                if other != c and (other not in missing or other < c):
                    vector = vector - np.dot(vector, out[:, other]) * out[:, other]
            if np.linalg.norm(vector) > 0.5:  # at most two columns are removed from a unit axis
                out[:, c] = vector / np.linalg.norm(vector)
                break
    if np.linalg.det(out) < 0:  # a filled-in axis may point either way: choose a rotation
        out[:, missing[-1]] *= -1.0
    return out


def lps_ras(vectors) -> np.ndarray:
    """LPS points or axis vectors (a 3-vector, or the columns of a 3x3) in RAS, or RAS ones in
    LPS: the map is its own inverse."""
    return LPS_TO_RAS @ np.asarray(vectors, dtype=np.float64)
