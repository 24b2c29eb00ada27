"""The geometry checks of the mesh and surface readers: the coordinates a file gives must be ones
GL's float32 world coordinates hold, as a volume's spacing and origin must (vgraph.volume:
magnitudes 1e-15 to 1e15).

    check_points(path, points, cells)    # float64 (N, 3) points; (M, k) corner indices into them

Refused with MeshFileError naming the file and ``[points]``:

- non-finite coordinates (NaN, +-Inf), naming the first such point;
- coordinates beyond +-1e15 (MAX_COORDINATE, the cameras' limit), naming the first such point;
- cells whose scale, the median length of their edges, is under 1e-15 (1 / MAX_COORDINATE);
- cells too small for float32 at their distance from the origin: under RESOLUTION (1e-5) of the
  largest coordinate, i.e. fewer than about 80 float32 steps across a typical cell. Rounded to
  float32 such cells collapse or bend (a unit cube 1e14 from the origin becomes flat); the
  message says to move the mesh nearer the origin.

The median edge, not the shortest: real meshes have slivers (boundary layers, split wedges) whose
shortest edges are far below the rest, and those render well enough; what must hold is the scale
of the cells a picture is made of. It is taken over at most SAMPLE_CELLS cells spread evenly over
the file, so the check costs the same for a mesh of millions of cells.
"""

from __future__ import annotations

import numpy as np

from vgraph.camera import MAX_COORDINATE
from vgraph.errors import MeshFileError

SMALLEST_SCALE = 1.0 / MAX_COORDINATE
RESOLUTION = 1e-5
SAMPLE_CELLS = 100_000


def check_points(path, points: np.ndarray, cells: np.ndarray, numbers=None) -> None:
    """Refuse points (float64, (N, 3), the ones ``cells`` use) that GL's float32 world coordinates
    cannot draw (module docstring). ``numbers`` are the points' numbers in the file, for the
    messages (default: their positions in ``points``)."""
    numbers = np.arange(len(points)) if numbers is None else numbers
    bad = ~np.all(np.isfinite(points), axis=1)
    if bad.any():
        first = int(np.argmax(bad))
        raise MeshFileError(path, f"{int(bad.sum())} points used by cells have non-finite "
                                  f"coordinates (the first is point {int(numbers[first])}: "
                                  f"{points[first].tolist()})", "points")
    reach = float(np.abs(points).max())
    if reach > MAX_COORDINATE:
        first = int(np.argmax(np.abs(points).max(axis=1) > MAX_COORDINATE))
        raise MeshFileError(path, f"coordinates reach {reach:.3g}: beyond +-{MAX_COORDINATE:g}, "
                                  f"what GL's float32 world coordinates hold (the first such point "
                                  f"is {int(numbers[first])}: {points[first].tolist()})", "points")
    scale = cell_scale(points, cells)
    if scale < SMALLEST_SCALE:
        raise MeshFileError(path, f"the cells are {scale:.3g} across (their median edge), below the "
                                  f"{SMALLEST_SCALE:g} GL's float32 world coordinates resolve: "
                                  f"scale the mesh up (e.g. give its coordinates in smaller units)",
                            "points")
    if scale < RESOLUTION * reach:
        raise MeshFileError(path, f"the cells ({scale:.3g} across) are too small for the float32 "
                                  f"coordinates the GL draws with at {reach:.3g} from the origin "
                                  f"(float32 keeps about 7 digits; cells need at least "
                                  f"{RESOLUTION:g} of their distance from the origin): move the "
                                  f"mesh nearer the origin", "points")


def cell_scale(points: np.ndarray, cells: np.ndarray) -> float:
    """The median edge length of the cells (every pair of corners of a sample of them)."""
    if len(cells) > SAMPLE_CELLS:
        cells = cells[np.linspace(0, len(cells) - 1, SAMPLE_CELLS).astype(np.int64)]
    corners = points[cells]
    k = cells.shape[1]
    lengths = [np.linalg.norm(corners[:, j] - corners[:, i], axis=1)
               for i in range(k) for j in range(i + 1, k)]
    return float(np.median(np.concatenate(lengths)))
