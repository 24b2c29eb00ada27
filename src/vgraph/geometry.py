"""The Geometry data type: a triangle mesh in world coordinates (for proxy geometry, surfaces
extracted from volumes, and plug-ins that draw meshes)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.errors import VGraphError


@dataclass(eq=False)
class Geometry:
    vertices: np.ndarray                # (N, 3) float32 world positions (x, y, z)
    triangles: np.ndarray               # (M, 3) int32 vertex indices, counter-clockwise = front
    colors: np.ndarray | None = None    # (N, 4) float32 RGBA per vertex, optional

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, dtype=np.float32)
        self.triangles = np.asarray(self.triangles, dtype=np.int32)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise VGraphError(f"geometry vertices must be (N, 3), got {self.vertices.shape}")
        if self.triangles.ndim != 2 or self.triangles.shape[1] != 3:
            raise VGraphError(f"geometry triangles must be (M, 3), got {self.triangles.shape}")
        if self.triangles.size and (self.triangles.min() < 0 or self.triangles.max() >= len(self.vertices)):
            raise VGraphError("geometry triangles index vertices that do not exist")
        if self.colors is not None:
            self.colors = np.asarray(self.colors, dtype=np.float32)
            if self.colors.shape != (len(self.vertices), 4):
                raise VGraphError(f"geometry colors must be (N, 4), got {self.colors.shape}")

    @classmethod
    def box(cls, low, high) -> "Geometry":
        """The 12 outward-facing triangles of an axis-aligned box."""
        low, high = np.asarray(low, float), np.asarray(high, float)
        corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
        faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
        triangles = [tri for a, b, c, d in faces for tri in ((a, b, c), (a, c, d))]
        return cls(low + corners * (high - low), np.array(triangles))

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)
