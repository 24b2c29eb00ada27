"""The Geometry data type: a triangle mesh in world coordinates (for proxy geometry, surfaces
extracted from volumes or read from files, and plug-ins that draw meshes).

Conventions: world units are the volumes' (x, y, z); a triangle's vertices run counter-clockwise
seen from its front (outside); ``normals`` are unit vectors per vertex pointing to the front;
``scalars`` are one value per vertex in the data's own units (a GeometryRenderer maps them through
a colour map); ``colors`` are RGBA per vertex in [0, 1].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.errors import VGraphError


@dataclass(eq=False)
class Geometry:
    vertices: np.ndarray                # (N, 3) float32 world positions (x, y, z)
    triangles: np.ndarray               # (M, 3) int32 vertex indices, counter-clockwise = front
    colors: np.ndarray | None = None    # (N, 4) float32 RGBA per vertex, optional
    normals: np.ndarray | None = None   # (N, 3) float32 unit normals per vertex, optional
    scalars: np.ndarray | None = None   # (N,) float32 value per vertex, optional
    source: str = ""                    # where it came from, for messages

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, dtype=np.float32)
        self.triangles = np.asarray(self.triangles, dtype=np.int32)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise VGraphError(f"geometry vertices must be (N, 3), got {self.vertices.shape}")
        if self.triangles.ndim != 2 or self.triangles.shape[1] != 3:
            raise VGraphError(f"geometry triangles must be (M, 3), got {self.triangles.shape}")
        if not np.all(np.isfinite(self.vertices)):
            raise VGraphError(f"geometry{' from ' + self.source if self.source else ''} has non-finite "
                              f"vertex coordinates (or beyond float32's range)")
        if self.triangles.size and (self.triangles.min() < 0 or self.triangles.max() >= len(self.vertices)):
            raise VGraphError("geometry triangles index vertices that do not exist")
        count = len(self.vertices)
        self.colors = _per_vertex(self.colors, (count, 4), "colors")
        self.normals = _per_vertex(self.normals, (count, 3), "normals")
        self.scalars = _per_vertex(self.scalars, (count,), "scalars")

    @classmethod
    def box(cls, low, high) -> "Geometry":
        """The 12 outward-facing triangles of an axis-aligned box."""
        low, high = np.asarray(low, float), np.asarray(high, float)
        corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
        faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
        triangles = [tri for a, b, c, d in faces for tri in ((a, b, c), (a, c, d))]
        return cls(low + corners * (high - low), np.array(triangles))

    @classmethod
    def sphere(cls, centre, radius: float, subdivisions: int = 3) -> "Geometry":
        """An icosphere: the icosahedron's faces split ``subdivisions`` times, the vertices pushed
        onto the sphere (20 * 4^subdivisions triangles), with exact normals."""
        unit, triangles = _icosphere(int(subdivisions))
        return cls(np.asarray(centre, float) + radius * unit, triangles, normals=unit)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        if not len(self.vertices):
            raise VGraphError(f"geometry{' from ' + self.source if self.source else ''} has no vertices")
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def vertex_normals(self) -> np.ndarray:
        """The given normals, else the area-weighted mean of the faces' normals at each vertex
        (the faces' winding decides which side is the front)."""
        if self.normals is not None:
            return self.normals
        corners = self.vertices[self.triangles].astype(np.float64)
        # the cross product's length is twice the area: summing it weights faces by area
        faces = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        sums = np.zeros((len(self.vertices), 3))
        for k in range(3):
            np.add.at(sums, self.triangles[:, k], faces)
        lengths = np.linalg.norm(sums, axis=1, keepdims=True)
        return (sums / np.where(lengths > 0.0, lengths, 1.0)).astype(np.float32)


def _per_vertex(values, shape: tuple, name: str):
    if values is None:
        return None
    values = np.asarray(values, dtype=np.float32)
    if values.shape != shape:
        raise VGraphError(f"geometry {name} must be {shape} (one per vertex), got {values.shape}")
    return values


def _icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    t = (1.0 + 5.0 ** 0.5) / 2.0
    vertices = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
                (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    points = [np.array(v, float) / np.linalg.norm(v) for v in vertices]
    for _ in range(subdivisions):
        middles: dict = {}

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in middles:
                point = points[a] + points[b]
                points.append(point / np.linalg.norm(point))
                middles[key] = len(points) - 1
            return middles[key]

        split = []
        for a, b, c in faces:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = split
    return np.array(points), np.array(faces)
