"""Tetrahedra from cells: regular volumes (5 per cell, Monsalve 2016 ch. 3) and the cells of
unstructured meshes (hexahedra, wedges, pyramids), always with matching faces between neighbours.

Regular grids (``volume_tetrahedra``): cell (i, j, k) spans the voxel centres (i..i+1, j..j+1,
k..k+1). It is cut into five tetrahedra, four corner tetrahedra and a central one, and the
orientation alternates with the parity of i + j + k, so that every face diagonal joins two voxels
of odd global parity: the diagonals of neighbouring cells agree and every interior triangle is
shared by exactly two tetrahedra. Points are the voxel centres in world coordinates
(origin + direction @ (index * spacing): the volume's affine), scalars the voxel values. Where the
direction mirrors (det -1) every tetrahedron's last two vertices are swapped, so that all stay
positively oriented in the world. Cell culling (Retondaro 2008's threshold
classification) emits only the cells a caller keeps (``cell_mask``), and only the points those
cells use.

Memory: a tetrahedron costs 16 bytes (four int32 indices) and a point 16 bytes (three float32
coordinates and a float32 scalar), so a volume cut whole costs about 5 * 16 + 16 = 96 bytes per
voxel (a 256^3 volume: 83 M tetrahedra, 1.3 GiB of indices plus 256 MiB of points) before any GL
buffer is made. The work is done in chunks of cells, and the result's size is checked against the
available memory before it is allocated.

Unstructured cells (``split_cells``): a cell is the cone from its smallest global vertex index
over the faces that do not contain that vertex, each quad face cut along the diagonal through its
own smallest vertex. Faces that do contain the apex are then cut along the diagonal through the
apex, which is their smallest vertex too: every quad face, wherever it lies, is cut along the
diagonal through its smallest global index, so two cells sharing a face cut it alike. A
hexahedron gives 6 tetrahedra, a wedge 3, a pyramid 2.
"""

from __future__ import annotations

import numpy as np

from vgraph.errors import VGraphError
from vgraph.volume_grid import IDENTITY, is_identity

# --- regular grids --------------------------------------------------------------------------------
# Corner c of a cell is at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) in (x, y, z).
_CORNERS = np.array([(c & 1, (c >> 1) & 1, (c >> 2) & 1) for c in range(8)])
_EVEN = [(0, 1, 2, 4), (3, 1, 2, 7), (5, 1, 4, 7), (6, 2, 4, 7), (1, 2, 4, 7)]
_ODD = [(1, 0, 3, 5), (2, 0, 3, 6), (4, 0, 5, 6), (7, 3, 5, 6), (0, 3, 5, 6)]


def _positively_oriented(template):
    """The template with two corners swapped where the unit-cube tetrahedron is negative."""
    fixed = []
    for tet in template:
        a, b, c, d = (_CORNERS[v].astype(float) for v in tet)
        volume = np.dot(np.cross(b - a, c - a), d - a)
        fixed.append(tet if volume > 0 else (tet[0], tet[1], tet[3], tet[2]))
    return np.array(fixed, dtype=np.int64)


CELL_TETS = np.stack([_positively_oriented(_EVEN), _positively_oriented(_ODD)])  # [parity, 5, 4]
BYTES_PER_TET = 16
BYTES_PER_POINT = 16
_CHUNK_CELLS = 1 << 18


def cell_ranges(data: np.ndarray, low_fill: float, high_fill: float):
    """(min, max) over the eight voxels of every cell, arrays [z-1, y-1, x-1] of the data's dtype
    (float64 where the data hold non-finite values, which count as ``low_fill`` for NaN and -Inf
    and ``high_fill`` for +Inf, as the GL textures clamp them)."""
    if data.dtype.kind == "f" and not np.all(np.isfinite(data)):
        data = np.nan_to_num(data.astype(np.float64), nan=low_fill, posinf=high_fill, neginf=low_fill)
    low = high = None
    for dz, dy, dx in ((c >> 2 & 1, c >> 1 & 1, c & 1) for c in range(8)):
        view = data[dz:data.shape[0] - 1 + dz, dy:data.shape[1] - 1 + dy, dx:data.shape[2] - 1 + dx]
        low = view.copy() if low is None else np.minimum(low, view, out=low)
        high = view.copy() if high is None else np.maximum(high, view, out=high)
    return low, high


def visible_cells(low: np.ndarray, high: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """True for cells whose normalised range [low, high] reaches a LUT entry with opacity > 0.

    The LUT is read as the renderer reads it, linearly between entries: every value in the range
    lies between entries floor(low * last) and ceil(high * last), so a cell is dropped only where
    all of those are transparent. This is the empty-space rule of the ray caster
    (vgraph.gl.raycasting.empty_space.occupied_blocks) without its one-entry margin, which there
    covers trilinear texture filtering; inside a tetrahedron the scalar is the exact linear
    interpolation of the cell's own voxel values."""
    last = len(alpha) - 1
    lo = np.clip(np.floor(np.clip(low, 0.0, 1.0) * last).astype(np.int64), 0, last)
    hi = np.clip(np.ceil(np.clip(high, 0.0, 1.0) * last).astype(np.int64), 0, last)
    count = np.concatenate([[0], np.cumsum(alpha > 0.0)])
    return count[hi + 1] - count[lo] > 0


def volume_tetrahedra(data: np.ndarray, spacing, origin, cell_mask: np.ndarray | None = None,
                      available_bytes: int | None = None, where: str = "volume", direction=IDENTITY):
    """(points (N, 3) float32, tets (M, 4) int32, voxel index of each point (N,) int64) for the
    cells of a [z, y, x] grid where ``cell_mask`` ([z-1, y-1, x-1] bool) is True (all cells if
    None), on the grid with that spacing, origin and direction (vgraph.volume_grid). Only the
    voxels the kept cells use become points. ``available_bytes`` refuses a result that would not
    fit, naming the size."""
    nz, ny, nx = data.shape
    if min(nz, ny, nx) < 2:
        raise VGraphError(f"{where}: a volume needs at least 2 voxels along every axis to have "
                          f"cells, got (x, y, z) = ({nx}, {ny}, {nz})")
    if cell_mask is None:
        cell_mask = np.ones((nz - 1, ny - 1, nx - 1), dtype=bool)
    kept = int(np.count_nonzero(cell_mask))
    used = np.zeros(data.shape, dtype=bool)
    for dz, dy, dx in _CORNERS[:, ::-1]:
        used[dz:nz - 1 + dz, dy:ny - 1 + dy, dx:nx - 1 + dx] |= cell_mask
    point_count = int(np.count_nonzero(used))
    needed = kept * 5 * BYTES_PER_TET + point_count * BYTES_PER_POINT
    if available_bytes is not None and needed > available_bytes:
        raise VGraphError(f"{where}: {kept} cells make {5 * kept} tetrahedra and {point_count} "
                          f"points, {needed / 2**20:.0f} MiB, but only {available_bytes / 2**20:.0f} "
                          f"MiB of memory are available: cull more cells (culling = "
                          f"transfer_function or threshold) or crop the volume")
    flat_used = used.reshape(-1)
    voxel_index = np.flatnonzero(flat_used)
    del used
    index_map = np.full(nz * ny * nx, -1, dtype=np.int32)
    index_map[voxel_index] = np.arange(point_count, dtype=np.int32)
    points = np.empty((point_count, 3), dtype=np.float32)
    origin, spacing = np.asarray(origin, dtype=np.float64), np.asarray(spacing, dtype=np.float64)
    turned = None if is_identity(direction) else np.asarray(direction, dtype=np.float64).T
    for start in range(0, point_count, 4 * _CHUNK_CELLS):
        k, j, i = np.unravel_index(voxel_index[start:start + 4 * _CHUNK_CELLS], data.shape)
        steps = np.stack([i, j, k], axis=1) * spacing
        points[start:start + len(i)] = origin + (steps if turned is None else steps @ turned)
    offsets = _CORNERS @ np.array([1, nx, nx * ny])  # linear offset of each corner
    templates = offsets[CELL_TETS]  # [parity, 5, 4] linear offsets
    if turned is not None and np.linalg.det(turned) < 0.0:  # a mirror turns them inside out
        templates = templates[..., [0, 1, 3, 2]]
    tets = np.empty((5 * kept, 4), dtype=np.int32)
    cells = np.flatnonzero(cell_mask.reshape(-1))
    for start in range(0, kept, _CHUNK_CELLS):
        chunk = cells[start:start + _CHUNK_CELLS]
        ck, cj, ci = np.unravel_index(chunk, cell_mask.shape)
        base = ci + nx * (cj + ny * ck)  # linear index of the cell's corner 0 in the volume
        parity = (ci + cj + ck) & 1
        tets[5 * start:5 * (start + len(chunk))] = \
            index_map[base[:, None, None] + templates[parity]].reshape(-1, 4)
    return points, tets, voxel_index


# --- unstructured cells ---------------------------------------------------------------------------
# Faces in the VTK (and meshio) vertex order, each listed cyclically.
CELL_FACES = {
    "hexahedron": [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)],
    "wedge": [(0, 1, 2), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)],
    "pyramid": [(0, 1, 2, 3), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)],
}
TETS_PER_CELL = {"tetra": 1, "hexahedron": 6, "wedge": 3, "pyramid": 2}


def split_cells(kind: str, cells: np.ndarray) -> np.ndarray:
    """(n * TETS_PER_CELL[kind], 4) tetrahedra of n cells (corner indices in VTK order), cell by
    cell, with faces that match between neighbours (module docstring). Orientation is left as it
    comes: ``orient`` fixes it."""
    cells = np.asarray(cells, dtype=np.int64)
    if kind == "tetra":
        return cells[:, :4].copy()
    if len(cells) > _CHUNK_CELLS:  # the temporaries cost ~400 bytes per cell
        return np.concatenate([split_cells(kind, cells[start:start + _CHUNK_CELLS])
                               for start in range(0, len(cells), _CHUNK_CELLS)])
    faces = CELL_FACES[kind]
    n = len(cells)
    apex_local = np.argmin(cells, axis=1)
    apex = cells[np.arange(n), apex_local]
    pieces, masks = [], []
    for face in faces:
        corners = cells[:, face]  # (n, 3 or 4)
        outside = ~np.isin(apex_local[:, None], np.array(face)[None, :]).reshape(n)
        if len(face) == 3:
            pieces.append(np.concatenate([apex[:, None], corners], axis=1)[:, None, :])
        else:
            first = np.argmin(corners, axis=1) % 2 == 0  # diagonal 0-2 (else 1-3) holds the minimum
            a, b, c, d = corners.T
            tri1 = np.where(first[:, None], np.stack([a, b, c], 1), np.stack([a, b, d], 1))
            tri2 = np.where(first[:, None], np.stack([a, c, d], 1), np.stack([b, c, d], 1))
            pieces.append(np.stack([np.concatenate([apex[:, None], tri1], 1),
                                    np.concatenate([apex[:, None], tri2], 1)], axis=1))
        masks.append(outside)
    width = max(p.shape[1] for p in pieces)
    padded = np.full((n, len(faces), width, 4), -1, dtype=np.int64)
    keep = np.zeros((n, len(faces), width), dtype=bool)
    for f, (piece, outside) in enumerate(zip(pieces, masks)):
        padded[:, f, :piece.shape[1]] = piece
        keep[:, f, :piece.shape[1]] = outside[:, None]
    tets = padded[keep]
    repeats = np.any(np.sort(cells, axis=1)[:, 1:] == np.sort(cells, axis=1)[:, :-1], axis=1)
    if repeats.any():  # a cell naming one vertex twice (collapsed): cell by cell, in order
        per_cell = tets.reshape(n, TETS_PER_CELL[kind], 4)
        tets = np.concatenate([_split_one(kind, cell) if bad else per_cell[c]
                               for c, (cell, bad) in enumerate(zip(cells, repeats))])
    return tets


def _split_one(kind: str, cell: np.ndarray) -> np.ndarray:
    """One cell that repeats a vertex (a collapsed hexahedron): the cone from its smallest index
    over the faces without it (fewer tetrahedra than a proper cell; flat ones are dropped later)."""
    apex_local = int(np.argmin(cell))
    out = []
    for face in CELL_FACES[kind]:
        corners = cell[list(face)]
        if cell[apex_local] in corners:
            continue
        if len(face) == 3:
            out.append([cell[apex_local], *corners])
        else:
            a, b, c, d = corners
            tris = [(a, b, c), (a, c, d)] if np.argmin(corners) % 2 == 0 else [(a, b, d), (b, c, d)]
            out.extend([cell[apex_local], *t] for t in tris)
    return np.array(out, dtype=np.int64).reshape(-1, 4)


def orient(points: np.ndarray, tets: np.ndarray, relative_tolerance: float = 1e-7, *,
           with_kept: bool = False):
    """(tets with every one positively oriented, number of flat ones dropped), and with
    ``with_kept`` the (M,) bool mask of the tetrahedra kept (for what travels with them, such as
    cell values). A tetrahedron is flat when |volume| <= relative_tolerance * (longest edge)^3 / 6
    (also when it repeats a vertex); a negative one gets its last two vertices swapped."""
    p = points.astype(np.float64)[tets]
    six = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    longest = np.zeros(len(tets))
    for a in range(4):
        for b in range(a + 1, 4):
            longest = np.maximum(longest, np.linalg.norm(p[:, b] - p[:, a], axis=1))
    flat = np.abs(six) <= relative_tolerance * longest ** 3
    tets = tets[~flat].copy()
    negative = six[~flat] < 0
    tets[negative, 2], tets[negative, 3] = tets[negative, 3], tets[negative, 2]
    if with_kept:
        return tets, int(np.count_nonzero(flat)), ~flat
    return tets, int(np.count_nonzero(flat))
