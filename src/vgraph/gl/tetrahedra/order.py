"""Back-to-front visibility order of the tetrahedra: a sort of their centroids (Monsalve 2016
ch. 4; the approximate order of VTK's and Inviwo's projected-tetrahedra renderers).

- Orthographic: by the centroid's depth along the view direction; perspective: by the centroid's
  distance from the eye. The farthest comes first (drawn first, composited under the nearer).
- A centroid sort is exact for many meshes (e.g. the five-tetrahedra cells of a regular grid seen
  from most directions) but not for every one: two tetrahedra whose centroids order differently
  from the tetrahedra themselves are composited in the wrong order (small errors where they
  overlap; slivers of split wedges show it). ``mpvo_back_to_front`` is MPVO (Williams 1992): the
  topological order of the "in front of" relation across shared faces, exact for convex acyclic
  meshes; "mpvonc" adds the relations across the gaps of a non-convex mesh, found by the pixels'
  rays (vgraph.gl.tetrahedra.nonconvex: MPVONC with Cook et al.'s image-space fix), exact for
  any acyclic mesh at the image's pixels. The power-distance sort of Delaunay meshes is not done.
  Meshes cut from a regular grid are drawn cell by cell in the grid's sweep order instead
  (vgraph.gl.tetrahedra.cells), which needs no sort.
- The order is recomputed only when the mesh, the concrete camera or the set of tetrahedra to draw
  changes (``VisibilityOrder``); a grid's sweep only when the eye crosses one of its cell planes
  or the view direction's signs change (``cells.sweep_key``), so a camera turning about a grid
  from outside keeps its order and its uploaded index buffer. Tetrahedra whose scalars all have zero opacity under the TF can be
  left out first (``transparent_tetrahedra``): they add nothing, and are neither sorted nor drawn.
"""

from __future__ import annotations

import numpy as np

from vgraph.camera import Camera
from vgraph.gl.tetrahedra.cells import sweep_key, sweep_order
from vgraph.gl.tetrahedra.nonconvex import BoundaryFaces, gap_edges
from vgraph.tetrahedralize import visible_cells


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
    low, high = mesh.tet_scalar_ranges()
    finite = np.isfinite(low) & np.isfinite(high)
    visible = np.ones(len(mesh.tets), dtype=bool)
    visible[finite] = visible_cells(low[finite], high[finite], alpha)
    return visible


class VisibilityOrder:
    """What to draw for the last (mesh, camera), back to front, ready to be an index buffer: int32
    (M, 4) vertex indices of tetrahedra ("centroid", "mpvo"; ``mesh.vertex_indices``, which are
    the points' for point scalars), or int32 (K,) positions of grid cells ("sweep",
    vgraph.gl.tetrahedra.cells). The order itself comes from the points and tetrahedra, so cells
    of a per-cell mesh are ordered across their shared faces as any. ``sorts`` counts the orders
    computed (tests)."""

    def __init__(self):
        self.key = None
        self.indices: np.ndarray | None = None
        self.sorts = 0
        self._mask_key, self._mask = None, None

    def update(self, mesh, camera: Camera, selection=None, method: str = "centroid",
               size=None) -> tuple[np.ndarray, bool]:
        """(indices, whether they changed). ``selection``: (key, function returning the bool mask
        of the tetrahedra, or for "sweep" the cells, to draw), or None for all; the mask is
        computed when its key changes, not with every camera. "mpvo" and "sweep" order the whole
        mesh and then take the selection in that order, so hidden tetrahedra or cells still order
        their neighbours; the face adjacency MPVO needs is built once per mesh. "mpvonc" also
        needs the image ``size`` (width, height): its rays are the pixels'."""
        if method == "sweep":  # the grid's order changes only when the eye crosses a cell plane
            view = sweep_key(mesh.grid, camera)
        else:
            view = (camera.projection, tuple(camera.position),
                    tuple(camera.basis()[2]) if camera.projection != "perspective" else None)
        key = (id(mesh), view, None if selection is None else selection[0], method,
               tuple(size) if method == "mpvonc" else None)
        if key == self.key and self.indices is not None:
            return self.indices, False
        mask = self.selected(mesh, selection)
        if method == "sweep":
            order = sweep_order(mesh.grid, camera)
            indices = order if mask is None else order[mask[order]]
        elif method in ("mpvo", "mpvonc"):
            if getattr(self, "_adjacency_of", None) is not mesh:
                self._adjacency, self._adjacency_of = FaceAdjacency(mesh.points, mesh.tets), mesh
                self._boundary = None
            gaps = None
            if method == "mpvonc":
                if self._boundary is None:
                    self._boundary = BoundaryFaces(mesh.points, mesh.tets)
                gaps = gap_edges(self._boundary, camera, size)
            order = mpvo_back_to_front(mesh.points, mesh.tets, camera, self._adjacency, gaps)
            indices = mesh.vertex_indices[order if mask is None else order[mask[order]]]
        else:
            tets = mesh.tets if mask is None else mesh.tets[mask]
            drawn = mesh.vertex_indices if mask is None else mesh.vertex_indices[mask]
            indices = drawn[back_to_front(mesh.points, tets, camera)]
        self.indices = np.ascontiguousarray(indices, dtype=np.int32)
        self.key, self._mesh = key, mesh  # keep the mesh alive while its id is the key
        self.sorts += 1
        return self.indices, True

    def selected(self, mesh, selection):
        """The mask of ``selection`` for ``mesh`` (None: all), computed when its key changes."""
        if selection is None:
            return None
        key = (id(mesh), selection[0])
        if key != self._mask_key:
            self._mask_key, self._mask = key, selection[1]()
        return self._mask


# --- MPVO ---------------------------------------------------------------------------------------
class FaceAdjacency:
    """The interior faces of a mesh: the two tetrahedra sharing each (``first``, ``second``), a
    vertex of the face and its normal pointing into ``first`` (float64)."""

    def __init__(self, points: np.ndarray, tets: np.ndarray):
        m = len(tets)
        faces = np.concatenate([np.delete(tets, f, axis=1) for f in range(4)])  # face f: without vertex f
        owner = np.tile(np.arange(m), 4)
        opposite = np.concatenate([tets[:, f] for f in range(4)])
        key = np.sort(faces, axis=1)
        order = np.lexsort(key.T[::-1])
        key, owner, opposite, faces = key[order], owner[order], opposite[order], faces[order]
        same = np.all(key[1:] == key[:-1], axis=1)
        pair = np.flatnonzero(same)  # faces pair[i] and pair[i] + 1 are one face of two tets
        self.first, self.second = owner[pair], owner[pair + 1]
        p = points.astype(np.float64)
        a, b, c = (p[key[pair, k]] for k in range(3))
        normal = np.cross(b - a, c - a)
        inwards = np.einsum("ij,ij->i", normal, p[opposite[pair]] - a) < 0.0
        normal[inwards] *= -1.0  # now it points into `first`
        self.vertex, self.normal = a, normal
        self.count = m


def mpvo_back_to_front(points: np.ndarray, tets: np.ndarray, camera: Camera,
                       adjacency: FaceAdjacency | None = None, extra=None) -> np.ndarray:
    """Back-to-front order by MPVO (Williams 1992): across every interior face the tetrahedron on
    the eye's side is drawn after the other; a topological sort of that graph (Kahn's algorithm by
    levels, each level farthest centroid first). Exact for convex meshes whose graph is acyclic
    (Delaunay meshes); tetrahedra left in cycles follow in centroid order. Non-convex meshes are
    not handled unless ``extra`` (behind, front) adds the relations across their gaps
    (vgraph.gl.tetrahedra.nonconvex.gap_edges); without them the levels' centroid order only
    approximates it."""
    adjacency = adjacency or FaceAdjacency(points, tets)
    m = adjacency.count
    eye = np.asarray(camera.position, dtype=np.float64)
    if camera.projection == "perspective":
        towards_eye = eye - adjacency.vertex
    else:
        towards_eye = -np.broadcast_to(camera.basis()[2], adjacency.vertex.shape)
    side = np.einsum("ij,ij->i", adjacency.normal, towards_eye)
    first_in_front = side > 0.0  # the eye is on first's side of the face
    behind = np.where(first_in_front, adjacency.second, adjacency.first)
    front = np.where(first_in_front, adjacency.first, adjacency.second)
    keep = side != 0.0  # a face seen edge-on orders nothing
    behind, front = behind[keep], front[keep]
    if extra is not None:
        behind, front = np.concatenate([behind, extra[0]]), np.concatenate([front, extra[1]])
    indegree = np.bincount(front, minlength=m)
    by_source = np.argsort(behind, kind="stable")
    starts = np.concatenate([[0], np.cumsum(np.bincount(behind, minlength=m))])
    targets = front[by_source]
    c = centroids(points, tets)
    key = (np.einsum("ij,ij->i", c - eye, c - eye) if camera.projection == "perspective"
           else (c - eye) @ camera.basis()[2])
    levels = []
    level = np.flatnonzero(indegree == 0)
    done = np.zeros(m, dtype=bool)
    while level.size:
        level = level[np.argsort(-key[level], kind="stable")]
        levels.append(level)
        done[level] = True
        counts = starts[level + 1] - starts[level]
        if counts.sum() == 0:
            break
        index = np.repeat(starts[level], counts) + (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
        hit = targets[index]
        np.subtract.at(indegree, hit, 1)
        candidates = np.unique(hit)
        level = candidates[(indegree[candidates] == 0) & ~done[candidates]]
    rest = np.flatnonzero(~done)
    if rest.size:
        levels.append(rest[np.argsort(-key[rest], kind="stable")])
    return np.concatenate(levels)
