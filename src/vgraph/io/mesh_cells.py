"""The tetrahedra of a mesh file's 3D cells, and the cell each one comes from (so that a cell
array can follow its cell into its tetrahedra).

    cell_tetrahedra(kind, nodes, points) -> (tets (T, 4) int64, parents (T,) int64)

- Linear cells ("tetra", "hexahedron", "wedge", "pyramid"): vgraph.tetrahedralize.split_cells, 1, 6,
  3 and 2 tetrahedra with faces matching between neighbours; a cell naming a corner twice gives
  fewer.
- 10-node tetrahedra (meshio's "tetra10", VTK_QUADRATIC_TETRA): meshio holds them in VTK's node
  order, corners 0-3 and then the mid-edge nodes of the edges 01, 12, 02, 03, 13, 23 (its Gmsh
  reader permutes Gmsh's order into this one). Each is split into 8 linear tetrahedra over all 10
  nodes, the regular subdivision of Bey 1995: 4 at the corners (a corner and the mid-nodes of its
  three edges) and 4 filling the octahedron of the six mid-nodes, which is cut along one of its
  three diagonals (the segments joining the mid-nodes of opposite edges), the shortest, which
  gives the best-shaped tetrahedra. Whatever the diagonal, every face of the cell is cut into the
  same four triangles (its corner triangles and its mid-edge triangle), so neighbours still share
  their faces. The field is then linear on each of the 8, through the values at all 10 nodes:
  the quadratic field is followed on a mesh twice as fine instead of being cut to its corners.
- Other higher-order cells (hexahedron20, wedge15, pyramid13 ...) keep their corner nodes; the
  reader says so (vgraph.io.meshes).
"""

from __future__ import annotations

import numpy as np

from vgraph.tetrahedralize import TETS_PER_CELL, split_cells

QUADRATIC_TETRA = "tetra10"
TETRA10_EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))  # mid-node 4 + i is on edge i
NODES_PER_CELL = {**{kind: count for kind, count in
                     (("tetra", 4), ("hexahedron", 8), ("wedge", 6), ("pyramid", 5))},
                  QUADRATIC_TETRA: 10}


def _mid(a: int, b: int) -> int:
    """The local node number of the mid-node of edge (a, b) of a tetra10."""
    return 4 + TETRA10_EDGES.index((min(a, b), max(a, b)))


def _corner_tets() -> list[tuple[int, int, int, int]]:
    return [(v, *(_mid(v, w) for w in range(4) if w != v)) for v in range(4)]


def _octahedron_tets(i: int, j: int, k: int, l: int) -> list[tuple[int, int, int, int]]:
    """The 4 tetrahedra of the inner octahedron around its diagonal from mid(i, j) to mid(k, l)
    ({i, j, k, l} = {0, 1, 2, 3}): the other four mid-nodes form a ring around it, each next to
    the following one (their edges share a corner)."""
    ring = [_mid(i, k), _mid(j, k), _mid(j, l), _mid(i, l)]
    return [(_mid(i, j), _mid(k, l), ring[n], ring[(n + 1) % 4]) for n in range(4)]


DIAGONALS = ((0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2))  # diagonal mid(i, j) - mid(k, l)
# [diagonal, 8, 4] local node numbers: the corner tetrahedra, then the octahedron's.
TETRA10_SPLITS = np.array([_corner_tets() + _octahedron_tets(*d) for d in DIAGONALS], dtype=np.int64)


def split_quadratic_tetra(nodes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n * 8, 4) tetrahedra of n 10-node tetrahedra ``nodes`` (n, 10), cell by cell (module
    docstring); orientation is left as it comes."""
    nodes = np.asarray(nodes, dtype=np.int64)
    p = np.asarray(points, dtype=np.float64)
    lengths = np.stack([np.linalg.norm(p[nodes[:, _mid(i, j)]] - p[nodes[:, _mid(k, l)]], axis=1)
                        for i, j, k, l in DIAGONALS], axis=1)
    local = TETRA10_SPLITS[np.argmin(lengths, axis=1)]  # (n, 8, 4)
    return np.take_along_axis(nodes[:, None, :], local.reshape(len(nodes), 1, 32), axis=2).reshape(-1, 4)


def _repeats_a_node(cells: np.ndarray) -> np.ndarray:
    ordered = np.sort(cells, axis=1)
    return np.any(ordered[:, 1:] == ordered[:, :-1], axis=1)


def cell_tetrahedra(kind: str, nodes: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(tetrahedra (T, 4) int64, the number of the cell each comes from (T,) int64) of one block
    of cells of ``kind`` with ``nodes`` (n, NODES_PER_CELL[kind]) (module docstring)."""
    nodes = np.asarray(nodes, dtype=np.int64)
    count = len(nodes)
    if kind == QUADRATIC_TETRA:
        return split_quadratic_tetra(nodes, points), np.repeat(np.arange(count), 8)
    collapsed = _repeats_a_node(nodes) if kind != "tetra" else np.zeros(count, dtype=bool)
    proper = np.flatnonzero(~collapsed)
    tets = [split_cells(kind, nodes[proper])]
    parents = [np.repeat(proper, TETS_PER_CELL[kind])]
    for cell in np.flatnonzero(collapsed):  # fewer tetrahedra each: one by one (rare)
        piece = split_cells(kind, nodes[cell:cell + 1])
        tets.append(piece)
        parents.append(np.full(len(piece), cell))
    return np.concatenate(tets).reshape(-1, 4), np.concatenate(parents).astype(np.int64)
