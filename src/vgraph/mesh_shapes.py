"""Meshes made in code for tests and benchmarks: shapes the shared data lacks.

``c_shape`` is a non-convex mesh: a thick slab bent into a C (an annular sector of 300 degrees),
a regular grid in (radius, angle, height) cut into five tetrahedra per cell
(vgraph.tetrahedralize.volume_tetrahedra) whose points are then bent, so its cells are long thin
wedges and many rays leave the mesh through one arm and enter it again through the other: the
case for which MPVO's order across shared faces is not enough (vgraph.gl.tetrahedra.nonconvex).
"""

from __future__ import annotations

import numpy as np

from vgraph.mesh import TetMesh
from vgraph.tetrahedralize import volume_tetrahedra


def c_shape(radial: int = 4, around: int = 16, high: int = 4, opening_degrees: float = 60.0) -> TetMesh:
    """A C of inner radius 1, outer 1.6, height 0.6 in the xy-plane, open towards +x by
    ``opening_degrees``; grid nodes radial x around x high. The scalar rises around the C and
    with the radius (0 at one end's inner edge, about 1 at the other's outer edge), opacity
    length 0.2."""
    r, a, h = np.meshgrid(np.linspace(0.0, 1.0, radial), np.linspace(0.0, 1.0, around),
                          np.linspace(0.0, 1.0, high), indexing="ij")
    field = (0.8 * a + 0.2 * r).transpose(2, 1, 0)  # [z, y, x] = [height, angle, radius]
    points, tets, voxels = volume_tetrahedra(field.astype(np.float32), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    grid = points.astype(np.float64) / [radial - 1, around - 1, high - 1]
    half = np.radians(opening_degrees) / 2.0
    angle = half + grid[:, 1] * (2.0 * np.pi - 2.0 * half)
    radius = 1.0 + 0.6 * grid[:, 0]
    bent = np.stack([radius * np.cos(angle), radius * np.sin(angle), 0.6 * grid[:, 2]], axis=1)
    return TetMesh(bent.astype(np.float32), tets, field.reshape(-1)[voxels], reference_length=0.2)
