"""Back-to-front visibility order of the tetrahedra: a sort of their centroids (Monsalve 2016
ch. 4; the approximate order of VTK's and Inviwo's projected-tetrahedra renderers).

- Orthographic: by the centroid's depth along the view direction; perspective: by the centroid's
  distance from the eye. The farthest comes first (drawn first, composited under the nearer).
- A centroid sort is exact for many meshes (e.g. the five-tetrahedra cells of a regular grid seen
  from most directions) but not for every one: two tetrahedra whose centroids order differently
  from the tetrahedra themselves are composited in the wrong order (small errors where they
  overlap). The exact orders, MPVO (Williams 1992) and its extensions for non-convex meshes, and
  the power-distance sort of Delaunay meshes, are not done; neither is the sweep order of meshes
  from regular grids.
- The order is recomputed only when the mesh, the concrete camera or the set of tetrahedra to draw
  changes (``VisibilityOrder``). Tetrahedra whose scalars all have zero opacity under the TF can be
  left out first (``transparent_tetrahedra``): they add nothing, and are neither sorted nor drawn.
"""

from __future__ import annotations

import numpy as np

from vgraph.camera import Camera


def centroids(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """(M, 3) float64 centroids of the tetrahedra."""
    p = points.astype(np.float64, copy=False)
    return (p[tets[:, 0]] + p[tets[:, 1]] + p[tets[:, 2]] + p[tets[:, 3]]) * 0.25


def back_to_front(points: np.ndarray, tets: np.ndarray, camera: Camera) -> np.ndarray:
    """Indices of the tetrahedra, farthest first (int64, a stable sort: ties keep their order)."""
    c = centroids(points, tets)
    eye = np.asarray(camera.position, dtype=np.float64)
    if camera.projection == "perspective":
        key = np.einsum("ij,ij->i", c - eye, c - eye)  # squared distance orders like distance
    else:
        key = (c - eye) @ camera.basis()[2]
    return np.argsort(-key, kind="stable")


def visible_tetrahedra(mesh, alpha: np.ndarray) -> np.ndarray:
    """(M,) bool: the tetrahedra whose normalised scalar range reaches an entry of the TF LUT
    ``alpha`` with opacity > 0 (vgraph.tetrahedralize.visible_cells: the LUT read linearly between
    entries, as the shader reads it; the scalar inside a tetrahedron lies between its vertices').
    Tetrahedra with a non-finite scalar are kept."""
    from vgraph.tetrahedralize import visible_cells
    s = mesh.normalized()[mesh.tets]
    low, high = s.min(axis=1), s.max(axis=1)
    finite = np.isfinite(low) & np.isfinite(high)
    visible = np.ones(len(mesh.tets), dtype=bool)
    visible[finite] = visible_cells(low[finite], high[finite], alpha)
    return visible


class VisibilityOrder:
    """The sorted tetrahedra of the last (mesh, camera), as int32 (M, 4) vertex indices ready to be
    an index buffer; ``sorts`` counts the sorts done (tests)."""

    def __init__(self):
        self.key = None
        self.indices: np.ndarray | None = None
        self.sorts = 0

    def update(self, mesh, camera: Camera, selection=None) -> tuple[np.ndarray, bool]:
        """(indices, whether they changed). ``selection``: (key, function returning the (M,) bool
        mask of the tetrahedra to draw), or None for all; the mask is computed when its key
        changes."""
        eye = tuple(camera.position)
        key = (id(mesh), camera.projection, eye,
               tuple(camera.basis()[2]) if camera.projection != "perspective" else None,
               None if selection is None else selection[0])
        if key == self.key and self.indices is not None:
            return self.indices, False
        tets = mesh.tets
        if selection is not None:
            tets = tets[selection[1]()]
        order = back_to_front(mesh.points, tets, camera)
        self.indices = np.ascontiguousarray(tets[order], dtype=np.int32)
        self.key, self._mesh = key, mesh  # keep the mesh alive while its id is the key
        self.sorts += 1
        return self.indices, True
