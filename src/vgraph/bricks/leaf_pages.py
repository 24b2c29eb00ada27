"""The leaf table of the single-pass bricked ray caster in two levels, a directory and pages, so its
memory follows the frame and not the volume (issue #33; docs/explanations/bricked-ray-casting.md,
"A page table of two levels"; the multi-level page table of Hadwiger et al. 2012).

What the shader reads per sample is the *leaf entry* of the sample's level-0 cell, the result of
the page table's walk (vgraph.bricks.page_table: PageTable.entries and PageTable.resolve define it
on whole levels, and are the reference this module is tested against): drawn, a = 1 + the level
drawn and rgb = that brick's texel offset in the atlas; not drawn, a = -(1 + the level where the
walk stopped) and r = a value that adds nothing. One texel per level-0 cell of the whole volume is
256^3 texels (256 MiB) for a 16384^3 volume in bricks of 64; here:

- **The directory**: one entry per cell of the *directory level* D. A cell where the walk stops at
  level D or coarser (drawn by a brick of level >= D, empty, missing) holds its leaf entry, final.
  A cell the plan refines below D holds a *pointer*: a = POINTER, rgb = the texel where its page
  starts.
- **The pages**: one per pointer, the leaf entries of the level-0 cells of that directory cell
  (``page_cells`` = level-0 cells per directory cell, per axis), each laid out as the cell's
  level-0 cells. Pointers only exist where the plan has a brick finer than D, so there are at most
  as many pages as the plan has bricks, which is at most the atlas's slots.
- **One texture**: the directory at texels [0, grid_D), the pages after it along z. The shader
  (bricks/paged_sampling.glsl, leaf_texel) reads the directory entry, then the page's texel where
  it is a pointer: two fetches per sample, with no branch. D = 0 (a flat leaf table, one fetch)
  while level 0 has at most FLAT_CELLS cells; above, the level where the directory plus the
  pages of a full atlas are fewest (``directory_level``), so the table's size is bounded by
  ``table_bound``: cells(D) + slots * page cells, about 2 * sqrt(cells(0) * slots).
- ``wanted`` (the ray-guided requests, vgraph.bricks.ray_requests) is laid out as the table: per
  texel, 1 + the index in ``missing`` of the planned cell there that the atlas misses, 0 where
  none is; so the request counters are one per missing cell, not one per cell of the volume.
"""

from __future__ import annotations

import math

import numpy as np

from vgraph.bricks.brick_geometry import BrickGeometry

POINTER = 1024.0       # a directory entry's alpha that means "go to the page at rgb" (levels are < 64)
FLAT_CELLS = 64 ** 3   # up to here one fetch of a flat leaf table per sample (5 MiB with `wanted`)
TEXEL_BYTES = 16 + 4   # an RGBA32F entry and its R32F `wanted`


def page_cells(geometry: BrickGeometry, level: int) -> np.ndarray:
    """Level-0 cells per cell of ``level``, (x, y, z)."""
    return np.rint(geometry.spans[level] / geometry.spans[0]).astype(np.int64)


def directory_level(geometry: BrickGeometry, slots: int) -> int:
    """The directory's level for an atlas of ``slots`` slots (module docstring)."""
    if math.prod(int(n) for n in geometry.grids[0]) <= FLAT_CELLS or len(geometry.grids) == 1:
        return 0  # (a store of one level, another tool's, has no coarser level to be a directory)
    return min(range(1, len(geometry.grids)), key=lambda level: _texels(geometry, level, slots))


def table_bound(geometry: BrickGeometry, slots: int) -> int:
    """The most texels the table has for an atlas of ``slots`` slots (its pages' padding aside)."""
    return _texels(geometry, directory_level(geometry, slots), slots)


def _texels(geometry: BrickGeometry, level: int, slots: int) -> int:
    cells = math.prod(int(n) for n in geometry.grids[level])
    return cells if level == 0 else cells + slots * math.prod(int(n) for n in page_cells(geometry, level))


class LeafPages:
    """One frame's table (module docstring): ``table`` float32 [z, y, x, 4], ``wanted`` float32
    [z, y, x], ``missing`` (int [n, 4]: the planned keys the atlas misses, in the plan's order),
    ``level`` (D), ``page_cells`` (x, y, z), ``pages`` and ``undrawn`` (whether some cell of the
    volume is not drawn: the march's jumps are worth compiling)."""

    def __init__(self, table, wanted, missing, level, cells, pages, undrawn):
        self.table, self.wanted, self.missing = table, wanted, missing
        self.level, self.page_cells, self.pages, self.undrawn = level, cells, pages, undrawn

    @property
    def nbytes(self) -> int:
        return int(self.table.nbytes + self.wanted.nbytes)


class _Regions:
    """The cells the walk visits per level, as flat arrays: every cell at the directory level and
    above, only the pointer cells' descendants below (page after page, each in [z, y, x] order)."""

    def __init__(self, geometry: BrickGeometry, level: int):
        self.geometry, self.level = geometry, level
        self.page_dirs = np.zeros((0, 3), dtype=np.int64)  # [P, (z, y, x)]: each page's directory cell
        self.page_index = None                              # per directory cell: its page, or -1

    def grid(self, level: int) -> np.ndarray:
        return self.geometry.grids[level][::-1].astype(np.int64)  # [z, y, x]

    def per_cell(self, level: int) -> np.ndarray:
        """Cells of ``level`` per directory cell, [z, y, x]."""
        return (page_cells(self.geometry, self.level) // page_cells(self.geometry, level))[::-1]

    def cells(self, level: int) -> np.ndarray:
        """[3, n] (z, y, x) indices of the region's cells of ``level``."""
        if level >= self.level:
            return np.indices(tuple(self.grid(level))).reshape(3, -1)
        per = self.per_cell(level)
        local = np.indices(tuple(per)).reshape(3, 1, -1)
        return (self.page_dirs.T[:, :, None] * per[:, None, None] + local).reshape(3, -1)

    def position(self, level: int, cells: np.ndarray) -> np.ndarray:
        """The flat index in the region of ``level`` of each of ``cells`` [3, n]; -1 outside it."""
        grid = self.grid(level)
        if level >= self.level:
            inside = np.all((cells >= 0) & (cells < grid[:, None]), axis=0)
            flat = np.ravel_multi_index(tuple(np.where(inside, cells, 0)), tuple(grid))
            return np.where(inside, flat, -1)
        per = self.per_cell(level)
        directory = cells // per[:, None]
        page = self.position(self.level, directory)
        page = np.where(page >= 0, self.page_index[np.maximum(page, 0)], -1)
        local = np.ravel_multi_index(tuple(cells - directory * per[:, None]), tuple(per))
        return np.where(page >= 0, page * int(np.prod(per)) + local, -1)


def build(geometry: BrickGeometry, planned, resident, offsets, lows, slots: int,
          directory: int | None = None) -> LeafPages:
    """The table of a frame: ``planned`` the keys its plan draws, ``resident`` the atlas's keys [n, 4]
    with their texel offsets ``offsets`` [n, 3] (page_table.texel_offsets), ``lows(level)`` the
    cells' smallest normalised intensities [z, y, x], ``slots`` the atlas's (directory_level;
    ``directory`` sets the level instead). The walk of PageTable.resolve, on the regions' cells a
    level at a time."""
    planned = np.asarray(list(planned), dtype=np.int64).reshape(-1, 4)
    resident = np.asarray(resident, dtype=np.int64).reshape(-1, 4)
    missing_keys = planned[~np.isin(_key_ids(geometry, planned), _key_ids(geometry, resident))]
    directory = directory_level(geometry, slots) if directory is None else directory
    regions = _Regions(geometry, directory)
    top = len(geometry.grids) - 1
    leaf = fallback = wanted = None
    for level in range(top, -1, -1):
        cells = regions.cells(level)
        n = cells.shape[1]
        if leaf is None:
            leaf, fallback, wanted = np.zeros((n, 4), np.float32), np.zeros((n, 4), np.float32), np.zeros(n, np.float32)
        else:
            ratio = geometry.ratios[level + 1][::-1].astype(np.int64)[:, None]
            parent = regions.position(level + 1, cells // ratio)
            leaf, fallback, wanted = leaf[parent], fallback[parent], wanted[parent]
        mark = _Marks(regions, level, n)
        is_planned = mark.keys(planned)
        refined = mark.ancestors(planned)
        offset, held = mark.values(resident, offsets)
        open_ = leaf[:, 3] == 0.0
        here = open_ & (is_planned | refined) & held
        fallback[here, :3], fallback[here, 3] = offset[here], level + 1.0
        stops = open_ & ~refined
        empty = stops & ~is_planned
        drawn = stops & ~empty & (fallback[:, 3] > 0.0)
        leaf[drawn] = fallback[drawn]
        nothing = stops & ~drawn
        leaf[nothing] = 0.0
        leaf[nothing & empty, 0] = mark.lows(lows, cells)[nothing & empty]
        leaf[nothing, 3] = -(level + 1.0)
        index, _ = mark.values(missing_keys, np.arange(1, len(missing_keys) + 1, dtype=np.float64)[:, None])
        wanted[stops] = index[stops, 0]
        if level == directory:
            table, pages = _directory(regions, leaf, wanted, refined & open_, level)
            if directory == 0:
                break
    return _assembled(regions, table, pages, leaf, wanted, missing_keys)


def _key_ids(geometry: BrickGeometry, keys: np.ndarray) -> np.ndarray:
    """One int64 per key [n, 4] (level, z, y, x), the same for the same key: for np.isin."""
    size = int(max(int(n) for grid in geometry.grids for n in grid)) + 1
    return ((keys[:, 0] * size + keys[:, 1]) * size + keys[:, 2]) * size + keys[:, 3]


class _Marks:
    """Per cell of one level's region: the keys of that level it holds, values scattered to it."""

    def __init__(self, regions: _Regions, level: int, n: int):
        self.regions, self.level, self.n = regions, level, n

    def keys(self, keys: np.ndarray) -> np.ndarray:
        """Whether the cell is one of ``keys``."""
        return self.values(keys, np.zeros((len(keys), 1)))[1]

    def ancestors(self, keys: np.ndarray) -> np.ndarray:
        """Whether the cell holds one of ``keys`` of a finer level (the walk goes down it)."""
        out = np.zeros(self.n, dtype=bool)
        spans, level = self.regions.geometry.spans, self.level
        for finer in np.unique(keys[keys[:, 0] < level, 0]):
            ratio = np.rint(spans[level] / spans[int(finer)]).astype(np.int64)[::-1][:, None]
            cells = keys[keys[:, 0] == finer, 1:].T // ratio
            position = self.regions.position(level, cells)
            out[position[position >= 0]] = True
        return out

    def values(self, keys: np.ndarray, values: np.ndarray):
        """(float [n, k] values of the cells that are ``keys`` of this level, bool [n] which are)."""
        values = np.asarray(values, dtype=np.float64)
        values = values.reshape(len(keys), values.shape[1] if values.ndim == 2 else 1)
        out, held = np.zeros((self.n, values.shape[1]), dtype=np.float64), np.zeros(self.n, dtype=bool)
        mine = keys[:, 0] == self.level
        position = self.regions.position(self.level, keys[mine, 1:].T.reshape(3, -1))
        ok = position >= 0
        out[position[ok]], held[position[ok]] = values[mine][ok], True
        return out, held

    def lows(self, lows, cells: np.ndarray) -> np.ndarray:
        """``lows(level)`` at the cells [3, n] (0 past the volume's last cells)."""
        level = self.level
        grid = self.regions.grid(level)
        inside = np.all(cells < grid[:, None], axis=0)
        out = np.zeros(self.n, dtype=np.float64)
        out[inside] = np.asarray(lows(level))[tuple(cells[:, inside])]
        return out


def _directory(regions: _Regions, leaf, wanted, pointers, level: int):
    """The directory's entries (float32 [z, y, x, 4]) and its wanted values; the pointer cells
    become pages (regions.page_dirs, page_index) whose origins _assembled fills in."""
    grid = tuple(regions.grid(level))
    table = leaf.reshape(grid + (4,)).copy()
    regions.page_dirs = np.stack(np.nonzero(pointers.reshape(grid)), axis=-1).astype(np.int64)
    regions.page_index = np.full(int(np.prod(grid)), -1, dtype=np.int64)
    regions.page_index[np.flatnonzero(pointers)] = np.arange(len(regions.page_dirs))
    return (table, wanted.reshape(grid).copy()), len(regions.page_dirs)


def _assembled(regions: _Regions, directory, pages: int, leaf, wanted, missing) -> LeafPages:
    """The directory and the pages (level 0's region, page after page) in one texture's array."""
    geometry, level = regions.geometry, regions.level
    table, wanted_table = directory
    cells = page_cells(geometry, level)
    if level == 0 or pages == 0:
        undrawn = bool((table[..., 3] < 0.0).any())
        return LeafPages(table, wanted_table, missing, level, cells, pages, undrawn)
    per = cells[::-1]  # [z, y, x]
    grid = table.shape[:3]
    side = max(1, math.ceil(pages ** (1.0 / 3.0)))
    rows = max(1, math.ceil(pages / side))
    layers = [max(1, math.ceil(pages / (side * rows))), rows, side]  # pages per axis, [z, y, x]
    shape = (grid[0] + layers[0] * per[0], max(grid[1], layers[1] * per[1]), max(grid[2], layers[2] * per[2]))
    out, out_wanted = np.zeros(shape + (4,), np.float32), np.zeros(shape, np.float32)
    out[:grid[0], :grid[1], :grid[2]], out_wanted[:grid[0], :grid[1], :grid[2]] = table, wanted_table
    page = np.arange(pages)
    origin = np.stack([grid[0] + page // (side * rows) * per[0], page // side % rows * per[1],
                       page % side * per[2]], axis=-1)  # [P, (z, y, x)]
    dirs = tuple(regions.page_dirs.T)
    out[dirs + (slice(0, 3),)] = origin[:, ::-1]
    out[dirs + (3,)] = POINTER
    local = np.indices(tuple(per)).reshape(3, -1)
    texels = (origin.T[:, :, None] + local[:, None, :]).reshape(3, -1)
    inside = np.all(regions.cells(0) < regions.grid(0)[:, None], axis=0)
    leaf[~inside], wanted[~inside] = 0.0, 0.0  # past the volume's last cells: never read
    out[tuple(texels)], out_wanted[tuple(texels)] = leaf, wanted
    undrawn = bool((table[..., 3] < 0.0).any() or (leaf[:, 3] < 0.0).any())
    return LeafPages(out, out_wanted, missing, level, cells, pages, undrawn)
