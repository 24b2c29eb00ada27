"""The mesh ProjectedTetrahedra draws: the mesh itself, or for an extreme box (vgraph.box_frame:
1e14 across, 1e-12 across, or near the +-1e15 limit) a copy in its box's normalised frame, where
the camera is an ordinary one.

    frame, drawn = mesh_in_frame(mesh)

The copy has the same tetrahedra and scalars (the arrays are shared), the points moved and scaled
(computed in float64 from the float32 world points), the same value range (declared, so that the
transfer function maps alike), the opacity length and any grid in frame units: the segment
integrals, which depend on lengths over the opacity length only, are unchanged. One copy per mesh
is kept while the mesh lives; an ordinary mesh is drawn as it is.
"""

from __future__ import annotations

import dataclasses

from vgraph import derived
from vgraph.box_frame import BoxFrame
from vgraph.mesh import TetMesh
from vgraph.view_geometry import as_vec3

def mesh_in_frame(mesh: TetMesh) -> tuple[BoxFrame, TetMesh]:
    """(the frame of the mesh's box, the mesh to draw in it)."""
    frame = BoxFrame.of(*mesh.box)
    if frame.is_identity:
        return frame, mesh
    return frame, derived.value(mesh, "mesh in frame", lambda: _copy(mesh, frame), params=frame)


def _copy(mesh: TetMesh, frame: BoxFrame) -> TetMesh:
    grid = mesh.grid
    if grid is not None:
        grid = dataclasses.replace(grid, origin=as_vec3(frame.points(grid.origin)),
                                   spacing=tuple(s / frame.scale for s in grid.spacing))
    return TetMesh(frame.points(mesh.points), mesh.tets, mesh.scalars,
                   declared_range=mesh.value_range, reference_length=mesh.opacity_length / frame.scale,
                   scalar_name=mesh.scalar_name, source=mesh.source, grid=grid, per_cell=mesh.per_cell)
