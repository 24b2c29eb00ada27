"""The page table of the single-pass bricked ray caster (issue #33, item 1): for every cell (brick)
of every level, whether the shader refines it, draws it from an atlas slot, skips it as empty or
finds it missing (docs/explanations/bricked-ray-casting.md, "One pass, a page table").

Conventions:
- One RGBA32F 3D texture holds the cells of all levels: level L's grid (x, y, z cells, the octree
  of vgraph.bricks.cells) starts at z = ``z_offsets[L]``; x and y span the largest grid.
- An entry's alpha is a sum of flags: RESIDENT (its brick is in the atlas; rgb = the texel offset
  that takes the level's voxel coordinate u of a sample into the atlas, slot origin - core start +
  apron + 1/2), REFINE (the frame's plan draws finer cells inside it: the shader descends to the
  child holding the sample) and EMPTY (the plan draws nothing here: its cells are empty under the
  transfer function, or off screen; r = a normalised intensity every sample there may take, the
  cell's smallest, which adds nothing in any mode). No flag: MISSING, a cell the plan draws but
  the atlas does not hold; r = 0.
- The walk of a sample from the top level down: through REFINE cells, remembering the last
  RESIDENT one, it stops at a cell without REFINE. EMPTY skips the cell; RESIDENT draws it;
  MISSING draws the last resident ancestor's brick (a coarser level: the finest resident level the
  plan allows), or nothing when there is none. So the plan is the LOD rule (BrickSampling's:
  footprint, lod_bias, max_error, the budget's floor level) and the page table says how much of
  it is resident.
- The shader does not walk: ``resolve`` walks every level-0 cell on the CPU (a few numpy passes,
  top down) into the *leaf table*, one RGBA32F entry per level-0 cell that the shader reads once
  per sample (bricks/paged_sampling.glsl): drawn, a = 1 + the level drawn, rgb = that brick's
  texel offset; not drawn, a = -(1 + the level of the cell where the walk stopped, whose box a
  ray may jump over), r = the value. Why flat: llvmpipe runs every ``if`` for all 8 pixels of a
  SIMD group whether or not one takes it, so a walk "only when a ray enters a new cell" cost a
  walk per sample (5-8x the in-core frame); one fetch of a small table costs about one sample's.
  Its size is level 0's cell grid (a 16384^3 volume in bricks of 64: 256^3 cells, 256 MB), which
  a page table of several levels would avoid (not done yet).
"""

from __future__ import annotations

import numpy as np

from vgraph.bricks.cache import HALO, brick_extent
from vgraph.bricks.selection import BrickGeometry
from vgraph.gl_context import release_quietly

RESIDENT, REFINE, EMPTY = 1, 2, 4


def parent_of(geometry: BrickGeometry, key) -> tuple | None:
    """The cell of the next coarser level that holds ``key`` (None at the top level)."""
    level = key[0]
    if level + 1 >= len(geometry.grids):
        return None
    ratio = geometry.ratios[level + 1][::-1]  # children per axis, [z, y, x]
    return (level + 1, *(int(i) // int(r) for i, r in zip(key[1:], ratio)))


def children_of(geometry: BrickGeometry, key) -> list[tuple]:
    """The cells of the next finer level inside ``key``."""
    level = key[0]
    ratio = geometry.ratios[level][::-1]
    grid = geometry.grids[level - 1][::-1]  # [z, y, x]
    ranges = [range(int(i) * int(r), min((int(i) + 1) * int(r), int(n))) for i, r, n in zip(key[1:], ratio, grid)]
    return [(level - 1, z, y, x) for z in ranges[0] for y in ranges[1] for x in ranges[2]]


def texel_offset(source, key, slot_origin) -> np.ndarray:
    """(x, y, z) texels: the atlas texel coordinate of level voxel coordinate u is u + this."""
    start, _ = brick_extent(source, key)
    return np.asarray(slot_origin, dtype=np.float64) - start[::-1] + HALO + 0.5


class PageTable:
    """The entries of one frame and their texture (module docstring)."""

    def __init__(self):
        self.gl: dict = {}  # "texture", released with the owner

    @staticmethod
    def layout(geometry: BrickGeometry) -> tuple[tuple[int, int, int], list[int]]:
        """The texture's size (x, y, z) and each level's z offset."""
        grids = [np.asarray(g, dtype=np.int64) for g in geometry.grids]  # (x, y, z)
        offsets = np.concatenate([[0], np.cumsum([int(g[2]) for g in grids])]).tolist()
        return (max(int(g[0]) for g in grids), max(int(g[1]) for g in grids), offsets[-1]), offsets[:-1]

    @staticmethod
    def entries(geometry: BrickGeometry, planned, offsets: dict, lows) -> np.ndarray:
        """The float32 [z, y, x, 4] entries: ``planned`` the keys the frame's plan draws, ``offsets``
        the texel offsets (texel_offset) of the resident bricks, ``lows(level)`` the cells' smallest
        normalised intensities [z, y, x] (the value of an EMPTY cell)."""
        (size_x, size_y, size_z), z_offsets = PageTable.layout(geometry)
        table = np.zeros((size_z, size_y, size_x, 4), dtype=np.float32)
        planned = set(planned)
        refined: set = set()
        for key in planned:
            parent = parent_of(geometry, key)
            while parent is not None and parent not in refined:
                refined.add(parent)
                parent = parent_of(geometry, parent)
        reached = planned | refined
        top = len(geometry.grids) - 1
        tops = [(top, z, y, x) for z, y, x in np.ndindex(*geometry.grids[top][::-1])]
        unreached = [key for key in tops if key not in reached]
        unreached += [child for key in refined for child in children_of(geometry, key) if child not in reached]
        low_tables: dict = {}

        def entry(key):
            level, z, y, x = key
            return table[z_offsets[level] + z, y, x]

        for key in unreached:
            if key[0] not in low_tables:
                low_tables[key[0]] = lows(key[0])
            entry(key)[:] = (float(low_tables[key[0]][key[1:]]), 0.0, 0.0, EMPTY)
        for key in refined:
            entry(key)[3] = REFINE
        for key in reached:
            if key in offsets:
                cell = entry(key)
                cell[:3] = offsets[key]
                cell[3] += RESIDENT
        return table

    @staticmethod
    def resolve(geometry: BrickGeometry, table: np.ndarray) -> np.ndarray:
        """The leaf table of ``table`` (entries()): float32 [z, y, x, 4] over level 0's cells (module
        docstring), the walk of every level-0 cell done top down with whole levels at a time."""
        _, z_offsets = PageTable.layout(geometry)
        top = len(geometry.grids) - 1
        leaf = fallback = None  # per cell of the level: the walk's result so far, its last resident
        for level in range(top, -1, -1):
            nx, ny, nz = (int(n) for n in geometry.grids[level])
            entries = table[z_offsets[level]:z_offsets[level] + nz, :ny, :nx]
            if leaf is None:
                leaf = np.zeros(entries.shape, dtype=np.float32)  # a = 0: not decided yet
                fallback = np.zeros(entries.shape, dtype=np.float32)  # a = 0: no resident ancestor
            else:
                ratio = geometry.ratios[level + 1][::-1]  # children per axis, [z, y, x]
                index = np.ix_(*[np.arange(n) // int(r) for n, r in zip(entries.shape[:3], ratio)])
                leaf, fallback = leaf[index], fallback[index]
            flags = np.rint(entries[..., 3]).astype(np.int64)
            open_ = leaf[..., 3] == 0.0
            resident = open_ & ((flags & RESIDENT) != 0)
            fallback[resident] = np.concatenate([entries[resident][:, :3],
                                                 np.full((int(resident.sum()), 1), level + 1.0)], axis=1)
            stops = open_ & ((flags & REFINE) == 0)
            empty = stops & ((flags & EMPTY) != 0)
            drawn = stops & ~empty & (fallback[..., 3] > 0.0)
            leaf[drawn] = fallback[drawn]
            nothing = stops & ~drawn  # empty, or missing without a resident ancestor (value 0)
            leaf[nothing] = 0.0
            leaf[nothing & empty, 0] = entries[nothing & empty][:, 0]
            leaf[nothing, 3] = -(level + 1.0)
        return leaf

    def upload(self, ctx, table: np.ndarray):
        """``table`` (the leaf table) as the RGBA32F texture (kept while its size and context stay)."""
        size = table.shape[2], table.shape[1], table.shape[0]
        texture = self.gl.get("texture")
        if texture is None or texture.ctx is not ctx or texture.size != size:
            self.release()
            texture = self.gl["texture"] = ctx.texture3d(size, 4, dtype="f4")
            texture.filter = (0x2600, 0x2600)  # GL_NEAREST: entries are read by texelFetch anyway
        texture.write(np.ascontiguousarray(table).tobytes())
        return texture

    def release(self) -> None:
        release_quietly(self.gl)
        self.gl.clear()
