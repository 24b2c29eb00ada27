"""Levels of detail of a tetrahedral mesh: the coarse mesh a renderer draws while the user drags.

    coarse = coarse_mesh(mesh)   # the same mesh, or one with about COARSE_TETRAHEDRA tetrahedra

Vertex clustering (Rossignac & Borrel 1993): the points are grouped by the cell of a coarse grid
they fall in, each group becomes one point (its members' mean position and mean scalar), every
tetrahedron is renamed to its groups' points, and those whose corners fall in fewer than four
groups (collapsed) or that repeat another's four groups are dropped.

- A mesh cut from a regular grid (``TetMesh.grid``: VolumeToTetMesh) is clustered on its own grid,
  ``factor`` voxels a side: each block of factor^3 voxels becomes one point at the block's centre
  with the mean of the block's voxels the mesh has (``np.bincount`` over the points; a block it
  has none of takes its nearest block's mean, ``scipy.ndimage.distance_transform_edt``), and the
  coarse grid is cut again into five tetrahedra a cell, keeping the coarse cells that overlap a
  kept fine cell. The coarse mesh is a grid mesh too, so the renderer keeps drawing it cell by
  cell in sweep order (no sort).
- Any other mesh is clustered on a grid ``factor`` point spacings a side (the point spacing: the
  cube root of the mesh's volume per point, as a grid's spacing is); a tetrahedron left flat
  is dropped and one turned inside out is turned back (vgraph.tetrahedralize.orient); cell scalars
  (``per_cell``) are averaged over the tetrahedra that became one.
- The coarse mesh keeps the fine one's value range and opacity length, so a transfer function
  classifies it alike and a length of it is as opaque. It is an approximation: thin features
  thinner than a cluster blur or vanish; the measured difference from the full frame is in
  docs/reports/gui-performance.md ("Meshes while dragging").
- ``factor`` is the smallest whole number that brings the tetrahedra to about COARSE_TETRAHEDRA
  (the count falls with its cube); a mesh already below that is its own coarse mesh.
- The coarse mesh is derived data (vgraph.derived): made once per mesh, on the first frame of the
  first drag, and dropped with the mesh.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from vgraph import derived
from vgraph.mesh import RegularGrid, TetMesh
from vgraph.tetrahedralize import cell_ranges, orient, volume_tetrahedra

# What llvmpipe draws in a drag's 128 x 128 frame within a tenth of a second, the GUI and the
# transfer included, on two cores that other jobs share: tets_bonsai clustered 6^3, 55 k of its
# 6.2 M tetrahedra, drew in 45 ms there, 5^3 (86 k) in 78 ms and 4^3 (150 k) in 120 ms
# (docs/reports/gui-performance.md, "Meshes while dragging").
COARSE_TETRAHEDRA = 30_000


def coarse_mesh(mesh: TetMesh, budget: int = COARSE_TETRAHEDRA) -> TetMesh:
    """``mesh`` clustered to about ``budget`` tetrahedra (module docstring), or ``mesh`` itself when
    it has no more than that; made once per mesh and budget (vgraph.derived)."""
    factor = clustering_factor(len(mesh.tets), budget)
    if factor == 1:
        return mesh
    return derived.value(mesh, "coarse mesh", lambda: clustered(mesh, factor), params=factor)


def clustering_factor(tetrahedra: int, budget: int) -> int:
    """Clusters this many points (or voxels) a side bring ``tetrahedra`` to about ``budget``."""
    if budget < 1:
        raise ValueError(f"the coarse mesh's budget must be at least 1 tetrahedron, got {budget}")
    return max(1, math.ceil(round((tetrahedra / budget) ** (1.0 / 3.0), 6)))


def clustered(mesh: TetMesh, factor: int) -> TetMesh:
    """``mesh`` clustered with ``factor`` voxels of its grid (or point spacings) a side."""
    if mesh.grid is not None:
        return _clustered_grid(mesh, factor)
    spacing = (float(np.abs(mesh.tet_volumes()).sum()) / len(mesh.points)) ** (1.0 / 3.0)
    return _clustered_points(mesh, factor * spacing, factor)


# --- meshes cut from a grid -----------------------------------------------------------------------
def _clustered_grid(mesh: TetMesh, factor: int) -> TetMesh:
    grid = mesh.grid
    shape = tuple(-(-n // factor) for n in grid.dims)  # coarse points (blocks) along x, y, z
    means, counts = _block_means(_block_of(_voxel_indices(mesh), factor, shape), mesh.scalars, shape)
    if not counts.all():  # blocks without any of the mesh's voxels: their nearest block's mean
        nearest = ndimage.distance_transform_edt(counts == 0, return_distances=False, return_indices=True)
        means = means[tuple(nearest)]
    spacing = np.asarray(grid.spacing) * factor
    origin = np.asarray(grid.origin) + (factor - 1) / 2.0 * np.asarray(grid.spacing)
    cells = _coarse_cells(grid, factor, shape)
    points, tets, voxels = volume_tetrahedra(means, spacing, origin, cells, where="coarse mesh")
    coarse_grid = RegularGrid(shape, tuple(map(float, origin)), tuple(map(float, spacing)),
                              np.flatnonzero(cells.reshape(-1)))
    return _like(mesh, points, tets, means.reshape(-1)[voxels], factor, grid=coarse_grid)


def _voxel_indices(mesh: TetMesh) -> np.ndarray:
    """(N, 3) int64: the (i, j, k) of the grid voxel each point of the mesh is."""
    grid = mesh.grid
    return np.rint((mesh.points - np.asarray(grid.origin)) / np.asarray(grid.spacing)).astype(np.int64)


def _block_of(ijk: np.ndarray, factor: int, shape) -> np.ndarray:
    """The linear index (x fastest) of the block of ``factor``^3 grid points or cells holding each
    of ``ijk``, on a grid of ``shape`` (x, y, z) blocks."""
    block = ijk // factor
    return block[:, 0] + shape[0] * (block[:, 1] + shape[1] * block[:, 2])


def _block_means(blocks: np.ndarray, scalars: np.ndarray, shape) -> tuple[np.ndarray, np.ndarray]:
    """([z, y, x] float64 mean scalar of each block's points, [z, y, x] how many it has)."""
    size = int(np.prod(shape))
    counts = np.bincount(blocks, minlength=size)
    sums = np.bincount(blocks, weights=scalars.astype(np.float64), minlength=size)
    return (sums / np.maximum(counts, 1)).reshape(shape[::-1]), counts.reshape(shape[::-1])


def _coarse_cells(grid: RegularGrid, factor: int, shape) -> np.ndarray:
    """[z, y, x] bool over the coarse cells: those overlapping a kept fine cell. Coarse cell I
    spans the centres of blocks I and I + 1, so it overlaps fine cells of both blocks."""
    occupied = np.zeros(int(np.prod(shape)), dtype=np.uint8)  # blocks holding a kept fine cell
    occupied[_block_of(grid.cell_indices(), factor, shape)] = 1
    return cell_ranges(occupied.reshape(shape[::-1]), 0, 1)[1] > 0  # the highest of its eight blocks


# --- any mesh -------------------------------------------------------------------------------------
def _clustered_points(mesh: TetMesh, size: float, factor: int) -> TetMesh:
    low = mesh.bounds[0]
    keys = np.floor((mesh.points - low) / size).astype(np.int64)
    extent = keys.max(axis=0) + 1
    _, group = np.unique(keys[:, 0] + extent[0] * (keys[:, 1] + extent[1] * keys[:, 2]), return_inverse=True)
    group = group.reshape(-1)
    members = np.bincount(group).astype(np.float64)
    points = np.stack([np.bincount(group, mesh.points[:, a].astype(np.float64)) for a in range(3)], axis=1)
    points /= members[:, None]
    tets = group[mesh.tets]
    corners = np.sort(tets, axis=1)
    whole = np.all(corners[:, 1:] != corners[:, :-1], axis=1)  # four distinct groups
    tets, corners = tets[whole], corners[whole]
    _, first, merged = np.unique(corners, axis=0, return_index=True, return_inverse=True)
    tets = tets[first]
    if mesh.per_cell:  # the mean of the tetrahedra that became one
        merged = merged.reshape(-1)
        scalars = np.bincount(merged, mesh.scalars[whole].astype(np.float64)) / np.bincount(merged)
    else:
        scalars = np.bincount(group, mesh.scalars.astype(np.float64)) / members
    tets, _, kept = orient(points, tets, with_kept=True)
    if mesh.per_cell:
        scalars = scalars[kept]
    if len(tets) == 0:  # clustered away entirely (a tiny mesh): nothing coarser to draw
        return mesh
    return _like(mesh, points, tets, scalars, factor)


def _like(mesh: TetMesh, points, tets, scalars, factor: int, grid: RegularGrid | None = None) -> TetMesh:
    """A coarse mesh classified as ``mesh`` is: its value range and opacity length."""
    return TetMesh(points, tets, scalars, declared_range=mesh.value_range, reference_length=mesh.opacity_length,
                   scalar_name=mesh.scalar_name, source=f"{mesh.source or 'mesh'} (clustered {factor}^3)",
                   grid=grid, per_cell=mesh.per_cell)
