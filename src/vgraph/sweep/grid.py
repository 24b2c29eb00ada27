"""The grid RZSweep sweeps: its vertices are the voxel centres (the box the ray casters sample),
its cells the boxes between eight of them, its faces the quads between four.

- Values are normalised intensities (Volume.normalized), as the transfer function reads them.
- Depth of a vertex = its distance from the eye along the camera's forward axis: the sweep plane is
  parallel to the image plane (ZSweep) for both projections.
- Threshold classification (Retondaro 2008 ch. 4: only vertices inside the threshold are sent to the
  heap): a cell is kept when the range of its eight values meets [low, high] (so a cell whose values
  cross the interval is kept even with no vertex inside it); a vertex is swept when one of its cells
  is kept; a face is projected when one of its cells is kept; a segment of a pixel's ray is
  composited only inside a kept cell. Without a threshold every cell is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.volume import Volume


@dataclass(frozen=True)
class SweptGrid:
    values: np.ndarray  # (nz, ny, nx) float64 normalised intensities
    positions: np.ndarray  # (nz, ny, nx, 3) world positions of the vertices
    depths: np.ndarray  # (nz, ny, nx) distance from the eye along forward
    kept_cells: np.ndarray  # (nz - 1, ny - 1, nx - 1) bool
    kept_vertices: np.ndarray  # (nz, ny, nx) bool
    inverse: np.ndarray  # (3, 4): world point -> continuous index (x, y, z)


def swept_grid(volume: Volume, camera: Camera, threshold, owner: str) -> SweptGrid:
    """The grid of ``volume`` seen by the resolved ``camera``; ``threshold`` (low, high) in
    normalised intensity or None. ``owner`` names the processor in errors."""
    check_volume(volume, owner)
    values = volume.normalized(np.asarray(volume.data, dtype=np.float64))
    return grid_of(values, volume, camera, threshold)


def grid_of(values: np.ndarray, where, camera: Camera, threshold) -> SweptGrid:
    """The grid of normalised ``values`` [z, y, x] placed by ``where``'s spacing, origin (of
    values[0, 0, 0]) and direction (a Volume, or a leaf of a store: vgraph.sweep.leaves)."""
    positions = vertex_positions(values.shape, where)
    right, up, forward = camera.basis()
    depths = (positions - np.asarray(camera.position, dtype=np.float64)) @ forward
    kept_cells = classified_cells(values, threshold)
    return SweptGrid(values, positions, depths, kept_cells, cell_vertices(kept_cells),
                     index_transform(where))


def vertex_positions(shape, where) -> np.ndarray:
    """World position of every vertex of a [z, y, x] ``shape``, origin + D @ (index * spacing),
    (nz, ny, nx, 3)."""
    nz, ny, nx = shape
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    index = np.stack([i, j, k], axis=-1).astype(np.float64) * np.asarray(where.spacing, dtype=np.float64)
    return index @ np.asarray(where.direction, dtype=np.float64).T + np.asarray(where.origin, dtype=np.float64)


def index_transform(where) -> np.ndarray:
    """(3, 4) affine from world points to continuous (x, y, z) indices: the inverse of the grid's
    placement (its direction is orthonormal)."""
    direction = np.asarray(where.direction, dtype=np.float64)
    spacing = np.asarray(where.spacing, dtype=np.float64)
    linear = direction.T / spacing[:, None]
    return np.concatenate([linear, -(linear @ np.asarray(where.origin, dtype=np.float64))[:, None]], axis=1)


def classified_cells(values: np.ndarray, threshold) -> np.ndarray:
    """Cells whose value range meets the threshold interval (all cells without one)."""
    shape = tuple(n - 1 for n in values.shape)
    if threshold is None:
        return np.ones(shape, dtype=bool)
    low, high = threshold
    corners = [values[z:z + shape[0], y:y + shape[1], x:x + shape[2]]
               for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    return (np.minimum.reduce(corners) <= high) & (np.maximum.reduce(corners) >= low)


def cell_vertices(kept_cells: np.ndarray) -> np.ndarray:
    """Vertices of at least one kept cell."""
    nz, ny, nx = kept_cells.shape
    kept = np.zeros((nz + 1, ny + 1, nx + 1), dtype=bool)
    for z in (0, 1):
        for y in (0, 1):
            for x in (0, 1):
                kept[z:z + nz, y:y + ny, x:x + nx] |= kept_cells
    return kept


def check_volume(volume: Volume, owner: str) -> None:
    """Refuse what the sweep cannot render, by name (metadata only for a store)."""
    where = f" from {volume.source}" if volume.source else ""
    if volume.is_spline_coefficients:
        raise VGraphError(f"{owner}: the volume{where} holds B-spline coefficients, not samples")
    if min(volume.dims) < 2:
        raise VGraphError(f"{owner}: the volume{where} has no cells to sweep: its dims (x, y, z) "
                          f"{tuple(volume.dims)} need at least 2 voxels along every axis")
    if volume.nonfinite_count:
        raise VGraphError(f"{owner}: the volume{where} holds {volume.nonfinite_count} NaN or infinite "
                          "voxels, which a cell's interpolation cannot use; replace them first")
