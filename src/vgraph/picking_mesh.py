"""The value of a tetrahedral mesh at a picked point: the tetrahedron holding it and the barycentric
interpolation of its point scalars, as the ProjectedTetrahedra and the exact reference
(vgraph.numerics.reference_tetra) interpolate them (issue 36).

The candidates are the tetrahedra whose centroids lie nearest the point (a k-d tree of the
centroids, scipy's cKDTree, made once per mesh: vgraph.derived), more of them when none of the
first holds it; the one whose smallest barycentric coordinate is largest wins. A point picked from
the depth lies on a face, so "holds" allows a small tolerance (TOLERANCE, relative to the
tetrahedron). Per-cell scalars give the cell's value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from vgraph import derived
from vgraph.gl.tetrahedra.order import centroids

CANDIDATES = (16, 256, 4096)  # how many nearest centroids are tried, in turn
TOLERANCE = 1e-4              # a barycentric coordinate this far below 0 still counts as inside


@dataclass(frozen=True)
class MeshValue:
    value: float
    cell: int                      # the tetrahedron's index
    weights: tuple[float, ...]     # its barycentric coordinates of the point


def mesh_value(mesh, point) -> MeshValue | None:
    """The mesh's interpolated value at a world point, or None outside every tetrahedron."""
    point = np.asarray(point, dtype=np.float64)
    tree = derived.value(mesh, "centroid tree", lambda: cKDTree(centroids(mesh.points, mesh.tets)))
    count = len(mesh.tets)
    for k in CANDIDATES:
        k = min(k, count)
        _, cells = tree.query(point, k=k)
        cells = np.atleast_1d(cells)
        weights = _barycentric(mesh, cells, point)
        best = int(np.argmax(weights.min(axis=1)))
        if weights[best].min() >= -TOLERANCE:
            return _value(mesh, int(cells[best]), weights[best])
        if k == count:
            break
    return None


def _barycentric(mesh, cells: np.ndarray, point: np.ndarray) -> np.ndarray:
    """(k, 4) barycentric coordinates of ``point`` in each of ``cells`` (degenerate cells: -inf)."""
    corners = mesh.points[mesh.tets[cells]].astype(np.float64)       # (k, 4, 3)
    edges = np.transpose(corners[:, 1:] - corners[:, :1], (0, 2, 1))  # (k, 3, 3): columns p1-p0, p2-p0, p3-p0
    weights = np.full((len(cells), 4), -np.inf)
    solvable = np.abs(np.linalg.det(edges)) > 1e-300
    if solvable.any():
        rest = np.linalg.solve(edges[solvable], (point - corners[solvable, 0])[..., None])[..., 0]
        weights[solvable] = np.concatenate([1.0 - rest.sum(axis=1, keepdims=True), rest], axis=1)
    return weights


def _value(mesh, cell: int, weights: np.ndarray) -> MeshValue:
    weights = np.clip(weights, 0.0, None)
    weights = weights / weights.sum()
    if mesh.per_cell:
        value = float(mesh.scalars[cell])
    else:
        value = float(weights @ mesh.scalars[mesh.tets[cell]].astype(np.float64))
    return MeshValue(value, cell, tuple(float(w) for w in weights))
