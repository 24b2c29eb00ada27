"""The order MPVO misses on non-convex meshes, found in image space (MPVONC: Williams 1992, with the
image-space fix of Cook, Max, Silva & Williams 2004).

MPVO orders tetrahedra across their shared faces. Along a ray through a convex mesh, consecutive
tetrahedra always share a face, so that order is the ray's. Through a non-convex mesh a ray can
leave the mesh through a boundary face and enter it again through another: the tetrahedron it
left is in front of the one it enters, and no shared face says so. Williams' MPVONC sorts the
boundary faces by a heuristic, which Cook et al. showed can fail; they find the missing relations
by shooting rays at the boundary faces instead. Here: each pixel's ray (``Camera.rays``, the
rays the image is made of) is intersected with the mesh's boundary faces; along it, an exit face
followed by an entry face gives the edge "the entered tetrahedron is behind the exited one". With
these edges added, the topological sort orders every pixel's tetrahedra as its ray meets them
(up to cycles, which fall back to the centroid order): the image is exact wherever MPVO's
face order is, whatever the shape.

Cost: one ray/triangle test per (boundary face, pixel of its bounding box), in chunks; the
boundary faces are found once per mesh (``BoundaryFaces``), the gaps once per camera and size.
"""

from __future__ import annotations

import numpy as np

from vgraph.camera import Camera
from vgraph.numerics.reference_tetra import pixel_boxes

CHUNK_PAIRS = 1 << 20  # (face, pixel) pairs tested at a time: bounded memory


class BoundaryFaces:
    """The faces that belong to one tetrahedron only: their vertices (F, 3) oriented so that the
    normal (b - a) x (c - a) points out of the mesh, and the tetrahedron each belongs to."""

    def __init__(self, points: np.ndarray, tets: np.ndarray):
        faces = np.concatenate([np.delete(tets, f, axis=1) for f in range(4)])  # face f: without vertex f
        owner = np.tile(np.arange(len(tets)), 4)
        opposite = np.concatenate([tets[:, f] for f in range(4)])
        key = np.sort(faces, axis=1)
        _, index, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
        once = index[counts == 1]
        faces, self.owner = faces[once].copy(), owner[once]
        p = points.astype(np.float64)
        a, b, c = (p[faces[:, k]] for k in range(3))
        inwards = np.einsum("ij,ij->i", np.cross(b - a, c - a), p[opposite[once]] - a) > 0.0
        faces[inwards] = faces[inwards][:, ::-1]  # now the normal points away from the tetrahedron
        self.faces = faces
        self.corners = p[faces]  # (F, 3, 3)


def gap_edges(boundary: BoundaryFaces, camera: Camera, size) -> tuple[np.ndarray, np.ndarray]:
    """(behind, front): tetrahedra pairs where some pixel's ray leaves the mesh through a boundary
    face of ``front`` and next enters it through one of ``behind``; each pair once."""
    width, height = size
    origins, directions = (a.reshape(-1, 3) for a in camera.rays(width, height))
    hits = [_hits(boundary, face, pixel, origins, directions)
            for face, pixel in _candidate_pairs(boundary.corners, camera, width, height)]
    if not hits:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ray, t, face, leaving = (np.concatenate(v) for v in zip(*hits))
    order = np.lexsort((t, ray))
    ray, face, leaving = ray[order], face[order], leaving[order]
    gap = (ray[1:] == ray[:-1]) & leaving[:-1] & ~leaving[1:]
    behind, front = boundary.owner[face[1:][gap]], boundary.owner[face[:-1][gap]]
    pairs = np.unique(np.stack([behind, front], axis=1), axis=0) if len(behind) else np.zeros((0, 2), np.int64)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    return pairs[:, 0], pairs[:, 1]


def _candidate_pairs(corners, camera: Camera, width: int, height: int):
    """(faces, ray indices) in chunks: each face with the pixels of its projected bounding box
    (one pixel of margin); every pixel for a face reaching behind the eye."""
    c0, c1, r0, r1 = pixel_boxes(corners, camera, width, height)
    counts = np.maximum(c1 - c0 + 1, 0) * np.maximum(r1 - r0 + 1, 0)
    candidates = np.flatnonzero(counts)
    bounds = np.cumsum(counts[candidates])
    start = 0
    while start < len(candidates):
        base = bounds[start - 1] if start else 0
        stop = max(int(np.searchsorted(bounds, base + CHUNK_PAIRS, side="right")), start + 1)
        faces = candidates[start:stop]
        start = stop
        item = np.repeat(np.arange(len(faces)), counts[faces])
        k = np.arange(len(item)) - np.repeat(np.cumsum(counts[faces]) - counts[faces], counts[faces])
        face = faces[item]
        columns = c1[face] - c0[face] + 1
        yield face, (r0[face] + k // columns) * width + c0[face] + k % columns


def _hits(boundary: BoundaryFaces, face, ray, origins, directions):
    """(ray, t, face, leaving) where rays cross faces (Moller-Trumbore, t > 0): ``leaving`` when
    the ray goes out of the mesh there."""
    a, b, c = (boundary.corners[face, k] for k in range(3))
    o, d = origins[ray], directions[ray]
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - a
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = np.einsum("ij,ij->i", d, q) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
    hit = (det != 0.0) & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > 0.0)
    leaving = det < 0.0  # det = -(d . normal): negative where d points out along the outward normal
    return ray[hit], t[hit], face[hit], leaving[hit]
