"""Meshes cut from a regular grid (TetMesh.grid), drawn cell by cell: the sweep order of the cells
and the per-cell data the cell projection shaders read (shaders/tetrahedra/cells.*.glsl).

Sweep order (no sort): along each axis the cells are taken farthest first, as seen from the eye's
position on that axis: for the orthographic camera all of them in the direction of view; for the
perspective camera those wholly below the eye's coordinate ascending, those wholly above it
descending, and the one the eye's coordinate passes through last. The order of the grid is these
three 1D orders nested (z, then y, then x). Two cells that share a face differ along one axis
only, and that axis's order draws the one farther from the eye first: every face of the grid is
crossed back to front, which for a convex mesh of convex cells is a visibility order (Williams
1992, as MPVO). The grid's order is taken whole and the kept cells picked from it, so no culled
cell changes the order of the others.

Inside a cell the five tetrahedra need no order: the fragment stage splits each pixel's ray at the
faces of the central tetrahedron and composites the (at most three) pieces itself, front to back.
"""

from __future__ import annotations

import numpy as np

from vgraph import derived
from vgraph.camera import Camera
from vgraph.mesh import RegularGrid, TetMesh
from vgraph.tetrahedralize import CELL_TETS, visible_cells

# For each parity, where corner c of a cell first appears among the 5 x 4 vertex slots of the
# cell's tetrahedra (CELL_TETS): the mesh point of the corner is tets[5 k : 5 k + 5].ravel()[slot].
CORNER_SLOTS = np.array([[int(np.flatnonzero(CELL_TETS[parity].ravel() == c)[0]) for c in range(8)]
                         for parity in range(2)])


def axis_runs(count: int, eye: float | None, towards: float) -> tuple:
    """All that axis_order(count, eye, towards) depends on: the sign of the view direction's
    component (orthographic, ``eye`` None), or the cells below and above the eye's coordinate
    (perspective). A camera moving outside the grid's slab along the axis keeps it."""
    if eye is None:
        return (bool(towards > 0),)
    below = int(np.clip(np.floor(eye), 0, count))   # cells 0..below-1 end at or below the eye
    above = int(np.clip(np.ceil(eye), 0, count))    # cells above..count-1 start at or above it
    return below, above


def axis_order(count: int, eye: float | None, towards: float) -> np.ndarray:
    """The cells 0..count-1 of one axis, farthest from the eye first. ``eye``: the eye's
    coordinate in cell units (perspective), or None with ``towards`` the view direction's
    component (orthographic)."""
    runs = axis_runs(count, eye, towards)
    if eye is None:
        return np.arange(count - 1, -1, -1) if runs[0] else np.arange(count)
    below, above = runs
    middle = [below] if below < above else []       # the cell the eye's coordinate passes through
    return np.concatenate([np.arange(below), np.arange(count - 1, above - 1, -1), middle]).astype(np.int64)


def _axis_arguments(grid: RegularGrid, camera: Camera) -> list[tuple]:
    """axis_order's (count, eye, towards) for the x, y and z axes of ``grid`` seen by ``camera``."""
    origin, spacing = np.asarray(grid.origin), np.asarray(grid.spacing)
    perspective = camera.projection == "perspective"
    eye = (np.asarray(camera.position, dtype=np.float64) - origin) / spacing
    forward = camera.basis()[2]
    return [(n, eye[a] if perspective else None, forward[a]) for a, n in enumerate(grid.cell_dims)]


def sweep_key(grid: RegularGrid, camera: Camera) -> tuple:
    """What sweep_order(grid, camera) depends on (each axis's axis_runs): the same key, the same
    order, so a camera turning about a grid it sees from outside need not sweep it again."""
    return camera.projection, tuple(axis_runs(*arguments) for arguments in _axis_arguments(grid, camera))


def sweep_order(grid: RegularGrid, camera: Camera) -> np.ndarray:
    """Positions in ``grid.cells`` (int32), back to front."""
    x, y, z = (axis_order(*arguments) for arguments in _axis_arguments(grid, camera))
    swept = grid.positions[np.ix_(z, y, x)].reshape(-1)
    return swept[swept >= 0]


def cell_attributes(mesh: TetMesh) -> np.ndarray:
    """(K, 12) float32 per kept cell: its corner 0 in world units and its parity (0 or 1), then the
    normalised scalars of its 8 corners (corner c at offset (c & 1, c >> 1 & 1, c >> 2 & 1)).
    Computed once per mesh (vgraph.derived)."""
    return derived.value(mesh, "cell attributes", lambda: _cell_attributes(mesh))


def cell_buffer(ctx, mesh: TetMesh):
    """cell_attributes(mesh) as a vertex buffer on ``ctx``, uploaded once per mesh and context and
    released with either (vgraph.derived)."""
    return derived.value(mesh, "cell buffer", lambda: ctx.buffer(cell_attributes(mesh).tobytes()), ctx=ctx)


def _cell_attributes(mesh: TetMesh) -> np.ndarray:
    grid = mesh.grid
    ijk = grid.cell_indices()
    parity = ijk.sum(axis=1) & 1
    slots = mesh.tets.reshape(-1, 20)
    corners = np.take_along_axis(slots, CORNER_SLOTS[parity], axis=1)
    scalars = mesh.normalized().astype(np.float32)[corners]
    corner0 = np.asarray(grid.origin) + ijk * np.asarray(grid.spacing)
    return np.ascontiguousarray(np.concatenate([corner0, parity[:, None], scalars], axis=1),
                                dtype=np.float32)


def visible_cells_of(mesh: TetMesh, alpha: np.ndarray) -> np.ndarray:
    """(K,) bool: the kept cells whose scalars reach an opacity > 0 under the LUT ``alpha``
    (vgraph.tetrahedralize.visible_cells on the range of the cell's eight corners, which is the
    union of its tetrahedra's ranges). Cells with a non-finite scalar are kept."""
    scalars = cell_attributes(mesh)[:, 4:]
    low, high = scalars.min(axis=1), scalars.max(axis=1)
    finite = np.isfinite(low) & np.isfinite(high)
    visible = np.ones(len(scalars), dtype=bool)
    visible[finite] = visible_cells(low[finite].astype(np.float64), high[finite].astype(np.float64), alpha)
    return visible
