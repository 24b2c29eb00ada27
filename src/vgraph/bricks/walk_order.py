"""The front-to-back order of the bricked renderer's octree walk (vgraph.bricks.selection), on
whole arrays of cells.

Conventions (docs/explanations/bricked-ray-casting.md):
- Along each axis the cells of a block are taken in the sweep order of the cell projection
  (vgraph.gl.tetrahedra.cells.axis_order) reversed, front first; a block's cells go z before y
  before x (``front_to_back``). The walk takes the top level's grid in that order and, for every
  cell it refines, the block of its children in that order, with the eye in the children's units.
- On arrays: a cell's place in the walk is a mixed-radix number whose digits are the top cell's
  rank in the grid's order, then at each level the rank of the cell among its parent's children
  (``axis_ranks`` per axis). Sorting those numbers (a cell kept at a coarser level padded with
  zeros, as no kept cell is another's ancestor) gives the recursive walk's order exactly, for
  orthographic and perspective cameras alike.
- The small levels at the top (level_tables.joined_levels) are walked whole (JoinedCells): every
  cell's digit in one axis_ranks call, the top level's as the children of one block (the grid),
  where the walk level by level paid numpy's calls per level (their cost, not the cells', there).
"""

from __future__ import annotations

import math

import numpy as np

from vgraph.bricks.level_tables import joined_levels, kept_per_level, kept_whole
from vgraph.gl.tetrahedra.cells import axis_order


def front_to_back(counts, eye, forward, perspective: bool, offset=(0, 0, 0)):
    """Cells of a [x, y, z] block of ``counts`` starting at ``offset``, front to back, as (x, y, z)
    indices; ``eye`` in cell units."""
    axes = [axis_order(int(n), float(eye[a] - offset[a]) if perspective else None, float(forward[a]))[::-1] + offset[a]
            for a, n in enumerate(counts)]
    return [(int(x), int(y), int(z)) for z in axes[2] for y in axes[1] for x in axes[0]]


def axis_ranks(cells, counts, eye, towards: float, perspective: bool) -> np.ndarray:
    """The place of each of ``cells`` (0..count - 1 along one axis, int arrays with ``counts``
    and ``eye`` broadcast against them; ``eye`` the eye's coordinate in cell units) in its axis's
    front-to-back order, axis_order(count, eye, towards) reversed, whole arrays at a time: the cell
    the eye's coordinate passes through first, then those above it ascending, then those below it
    descending (perspective); all ascending or all descending with the view (orthographic)."""
    if not perspective:
        return cells if towards > 0 else counts - 1 - cells
    below = np.clip(np.floor(eye), 0, counts).astype(np.int64)  # axis_runs, for arrays
    above = np.clip(np.ceil(eye), 0, counts).astype(np.int64)
    middle = (below < above).astype(np.int64)
    ranks = np.where(cells >= above, middle + cells - above, middle + (counts - above) + (below - 1 - cells))
    return np.where((middle == 1) & (cells == below), 0, ranks)


def top_cells(geometry, camera, forward, perspective: bool):
    """Every cell (z, y, x int arrays) of the top level of ``geometry`` (a brick_geometry.BrickGeometry)
    and its order number: its rank in the top grid's front_to_back."""
    top = len(geometry.grids) - 1
    grid = np.asarray(geometry.grids[top], dtype=np.int64)  # (x, y, z)
    z, y, x = kept_per_level(geometry, "top cells", top, lambda: _cell_indices(grid))
    eye = geometry.eye_in_bricks(camera.position, top)
    if perspective:  # the three axes stacked [3, m], one call (as children)
        ranks = axis_ranks(np.stack((x, y, z)), grid[:, None], eye[:, None], 0.0, True)
    else:
        ranks = [axis_ranks(cells, grid[a], None, float(forward[a]), False) for a, cells in enumerate((x, y, z))]
    return z, y, x, (ranks[2] * grid[1] + ranks[1]) * grid[0] + ranks[0]


def _cell_indices(grid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every cell (z, y, x int arrays, read-only) of a (x, y, z) ``grid``."""
    cells = tuple(axis.ravel() for axis in np.meshgrid(*[np.arange(n) for n in grid[::-1]], indexing="ij"))
    for axis in cells:
        axis.setflags(write=False)
    return cells


def _child_offsets(rx: int, ry: int, rz: int) -> np.ndarray:
    """The children's offsets in their parent's block, [3 (x, y, z), 1, r], read-only."""
    dz, dy, dx = np.meshgrid(np.arange(rz), np.arange(ry), np.arange(rx), indexing="ij")
    local = np.stack([d.ravel()[None, :] for d in (dx, dy, dz)])
    local.setflags(write=False)
    return local


def children(geometry, camera, forward, perspective: bool, level: int, z, y, x, order):
    """The children (at level - 1) of the cells (z, y, x) of ``level`` and their order numbers
    (select_bricks' walk): each parent's number times its block's radix plus the child's rank in
    front_to_back of the parent's block."""
    ratio = np.asarray(geometry.ratios[level], dtype=np.int64)        # (x, y, z) children per parent
    grid = np.asarray(geometry.grids[level - 1], dtype=np.int64)      # (x, y, z)
    eye = geometry.eye_in_bricks(camera.position, level) * ratio      # as front_to_back is given it
    # the axes stacked (x, y, z first): [3, n] per parent, [3, n, r] per child; a level's arrays
    # are small, so numpy's calls are the cost and fewer calls on stacked arrays pay
    first = np.stack([x, y, z]) * ratio[:, None]
    counts = (np.minimum(first + ratio[:, None], grid[:, None]) - first)[:, :, None]
    rx, ry, rz = (int(r) for r in ratio)
    local = kept_per_level(geometry, "child offsets", level, lambda: _child_offsets(rx, ry, rz))
    inside = (local < counts).all(axis=0)                               # [n, r]
    if perspective:
        ranks = axis_ranks(local, counts, (eye[:, None] - first)[:, :, None], 0.0, True)
    else:
        ranks = [axis_ranks(local[a], counts[a], None, float(forward[a]), False) for a in range(3)]
    digits = (ranks[2] * ry + ranks[1]) * rx + ranks[0]
    numbers = (order[:, None] * (rx * ry * rz) + digits)[inside]
    cells = (first[:, :, None] + local)[:, inside]                      # [3, m] (x, y, z)
    return cells[2], cells[1], cells[0], numbers


class JoinedCells:
    """The cells of the levels from joined_levels up, flat, the finest level's first and each
    level's in [z, y, x] order (as level_tables.joined_boxes), with what their digits need: each
    cell's (x, y, z) place in its parent's block (``local`` [3, n]), the block's first cell and
    extent (``first``, ``counts``), its radices and its parent's index within the parent's level.
    The top level's block is the whole grid (top_cells' ranks as digits). Made once per geometry."""

    def __init__(self, geometry):
        top = len(geometry.grids) - 1
        self.first_level = joined_levels(geometry)
        levels = range(self.first_level, top + 1)
        per_level = []
        for level in levels:
            grid = np.asarray(geometry.grids[level], dtype=np.int64)  # (x, y, z)
            z, y, x = _cell_indices(grid)
            cells = np.stack([x, y, z])
            if level == top:
                ratio, parent_grid = grid, np.ones(3, dtype=np.int64)
            else:
                ratio, parent_grid = np.asarray(geometry.ratios[level + 1], dtype=np.int64), geometry.grids[level + 1]
            parents = cells // ratio[:, None]
            first = parents * ratio[:, None]
            counts = np.minimum(first + ratio[:, None], grid[:, None]) - first
            parent = (parents[2] * int(parent_grid[1]) + parents[1]) * int(parent_grid[0]) + parents[0]
            per_level.append((z, y, x, cells - first, first, counts, parent, np.broadcast_to(ratio[:, None], cells.shape)))
        self.offsets = np.cumsum([0] + [len(parts[0]) for parts in per_level]).tolist()
        self.z, self.y, self.x, self.local, self.first, self.counts, self.parent, radices = (
            np.concatenate([parts[i] for parts in per_level], axis=-1) for i in range(8))
        self.radix_x, self.radix_y = radices[0], radices[1]
        self.radix = [math.prod(int(r) for r in parts[7][:, 0]) if len(parts[0]) else 1 for parts in per_level]
        self.level_of = np.repeat(np.arange(len(levels)), np.diff(self.offsets))
        # the eye in the units of each level's blocks: eye_in_bricks of the parent level times the
        # ratio, as children() has it (the same operations: the same floats)
        self.spans = np.stack([geometry.spans[min(level + 1, top)] for level in levels])
        self.ratios = np.stack([np.ones(3) if level == top else geometry.ratios[level + 1] for level in levels])
        for array in (self.z, self.y, self.x, self.local, self.first, self.counts, self.parent, self.radix_x,
                      self.radix_y, self.level_of):
            array.setflags(write=False)

    def cells(self, level: int) -> slice:
        """The flat range of ``level``'s cells."""
        index = level - self.first_level
        return slice(self.offsets[index], self.offsets[index + 1])

    def digits(self, geometry, camera, forward, perspective: bool) -> np.ndarray:
        """Every cell's rank among its block's cells, front to back (children's digits; the top
        level's: top_cells' order numbers), flat."""
        if perspective:
            eye = ((np.asarray(camera.position) - geometry.origin0) / geometry.spacing0 + 0.5) / self.spans * self.ratios
            ranks = axis_ranks(self.local, self.counts, eye[self.level_of].T - self.first, 0.0, True)
        else:
            ranks = [axis_ranks(self.local[a], self.counts[a], None, float(forward[a]), False) for a in range(3)]
        return (ranks[2] * self.radix_y + ranks[1]) * self.radix_x + ranks[0]


def joined_cells(geometry) -> JoinedCells:
    """The JoinedCells of ``geometry``, made once (kept in it)."""
    return kept_whole(geometry, "joined cells", lambda: JoinedCells(geometry))
