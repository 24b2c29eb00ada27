"""The page table of the single-pass bricked ray caster (issue #33, item 1): for every cell (brick)
of every level, whether the shader refines it, draws it from an atlas slot, skips it as empty or
finds it missing (docs/explanations/bricked-ray-casting.md, "One pass, a page table").

Conventions:
- ``entries`` lays the cells of all levels out in one float32 array (RGBA, as a 3D texture would
  hold them): level L's grid (x, y, z cells, the octree of vgraph.bricks.cells) starts at z =
  ``z_offsets[L]``; x and y span the largest grid. The GPU gets its resolved form (below).
- An entry's alpha is a sum of flags: RESIDENT (its brick is in the atlas; rgb = the texel offset
  that takes the level's voxel coordinate u of a sample into the atlas, slot origin - core start +
  apron + 1/2), REFINE (the frame's plan draws finer cells inside it: the walk descends to the
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
- The shader does not walk: the walk of every level-0 cell is done on the CPU into the *leaf
  table*, one RGBA32F entry per level-0 cell that the shader reads once per sample
  (bricks/paged_sampling.glsl): drawn, a = 1 + the level drawn, rgb = that brick's texel offset;
  not drawn, a = -(1 + the level of the cell where the walk stopped, whose box a ray may jump
  over), r = the value. Why flat: llvmpipe runs every ``if`` for all 8 pixels of a SIMD group
  whether or not one takes it, so a walk "only when a ray enters a new cell" cost a walk per
  sample (5-8x the in-core frame); one fetch of a small table costs about one sample's.
- ``entries`` and ``resolve`` define the walk on whole levels (a table over the whole volume:
  256 MiB for a 16384^3 volume in bricks of 64). A frame builds its leaf table with
  vgraph.bricks.leaf_pages instead, the same walk on the cells its plan reaches, in a directory
  and pages whose size follows the plan (tests/test_leaf_pages.py checks it against these).
"""

from __future__ import annotations

import numpy as np

from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.cache import HALO
from vgraph.bricks.cells import table_of
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl_context import release_quietly

RESIDENT, REFINE, EMPTY = 1, 2, 4


def _masks(geometry: BrickGeometry, keys: np.ndarray) -> list[np.ndarray]:
    """Per level, a bool [z, y, x] array: True at the cells of ``keys`` ([n, 4]: level, z, y, x)."""
    masks = [np.zeros(tuple(int(n) for n in grid[::-1]), dtype=bool) for grid in geometry.grids]
    for level, mask in enumerate(masks):
        mask[tuple(keys[keys[:, 0] == level, 1:].T)] = True
    return masks


def _children(geometry: BrickGeometry, parents: np.ndarray, level: int) -> np.ndarray:
    """A bool per cell of ``level``: whether its parent (at level + 1) is True in ``parents``."""
    ratio = geometry.ratios[level + 1][::-1]
    shape = tuple(int(n) for n in geometry.grids[level][::-1])
    return parents[np.ix_(*[np.arange(n) // int(r) for n, r in zip(shape, ratio)])]


def texel_offsets(source, keys: np.ndarray, origins: np.ndarray) -> np.ndarray:
    """(x, y, z) texels per brick, ``keys`` [n, 4] in slots at ``origins`` [n, 3] (x, y, z): the atlas
    texel coordinate of the brick level's voxel coordinate u is u + this (slot origin - core start
    + apron + 1/2)."""
    spans = table_of(source).spans  # per level, per axis [z, y, x]: (starts, stops)
    start = np.zeros((len(keys), 3), dtype=np.float64)  # [z, y, x]
    for level in np.unique(keys[:, 0]):
        mine = keys[:, 0] == level
        for axis in range(3):
            start[mine, axis] = spans[int(level)][axis][0][keys[mine, 1 + axis]]
    return np.asarray(origins, dtype=np.float64) - start[:, ::-1] + HALO + 0.5


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
    def entries(geometry: BrickGeometry, planned, offsets, lows) -> np.ndarray:
        """The float32 [z, y, x, 4] entries: ``planned`` the keys the frame's plan draws, ``offsets``
        the texel offsets (texel_offsets) of the resident bricks, a dict key -> (x, y, z) or a pair
        of arrays (keys [n, 4], offsets [n, 3]), ``lows(level)`` the cells' smallest normalised
        intensities [z, y, x] (the value of an EMPTY cell). Whole levels at a time (numpy): a
        1024^3 volume in bricks of 32 has 32768 cells at level 0."""
        (size_x, size_y, size_z), z_offsets = PageTable.layout(geometry)
        table = np.zeros((size_z, size_y, size_x, 4), dtype=np.float32)
        top = len(geometry.grids) - 1
        planned = _masks(geometry, np.asarray(list(planned), dtype=np.int64).reshape(-1, 4))
        refined = [np.zeros_like(mask) for mask in planned]
        for level in range(top):  # a cell that holds planned or refined cells is refined
            below = np.nonzero(planned[level] | refined[level])
            ratio = geometry.ratios[level + 1][::-1]  # children per axis, [z, y, x]
            refined[level + 1][tuple(index // int(r) for index, r in zip(below, ratio))] = True
        if isinstance(offsets, dict):
            offsets = (np.asarray(list(offsets), dtype=np.int64).reshape(-1, 4),
                       np.asarray(list(offsets.values()), dtype=np.float64).reshape(-1, 3))
        keys, values = offsets
        for level in range(top + 1):
            cells = table[z_offsets[level]:z_offsets[level] + planned[level].shape[0],
                          :planned[level].shape[1], :planned[level].shape[2]]
            reached = planned[level] | refined[level]
            # Not reached, in reach of the walk: at the top, or a child of a refined cell.
            empty = ~reached if level == top else ~reached & _children(geometry, refined[level + 1], level)
            if empty.any():
                cells[empty, 0] = lows(level)[empty]
                cells[empty, 3] = EMPTY
            cells[refined[level], 3] = REFINE
            mine = keys[:, 0] == level
            index = tuple(keys[mine, 1:].T)
            hit = reached[index]
            resident = tuple(axis[hit] for axis in index)
            cells[resident + (slice(0, 3),)] = values[mine][hit]
            cells[resident + (3,)] += RESIDENT
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
        """``table`` (the leaf table, leaf_pages.LeafPages.table) as the RGBA32F texture (kept while its size and context stay)."""
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


def pyramid_uniforms(geometry: BrickGeometry, source, atlas_size, slot_shape, fmt) -> dict:
    """The uniforms of the pyramid, the atlas's shape and the bricks' format that
    bricks/paged_sampling.glsl reads beside the page table."""
    spacing0, origin0, dims0 = geometry.spacing0, geometry.origin0, geometry.dims0
    level_scale, level_offset = [], []
    for level in source.levels:
        spacing, origin = np.asarray(level.spacing), np.asarray(level.origin)
        level_scale.append(dims0 * spacing0 / spacing)
        level_offset.append((origin0 - 0.5 * spacing0 - origin) / spacing)
    return {"intensity_scale": float(fmt.scale), "intensity_offset": float(fmt.offset),
            "atlas_texels": vec(np.asarray(atlas_size, dtype=np.float64)),
            "slot_texels": vec(np.asarray(slot_shape, dtype=np.float64)),
            "page_grid": np.asarray([np.asarray(g) for g in geometry.grids], dtype=np.int32),
            "cell_scale": np.asarray([dims0 / span for span in geometry.spans], dtype=np.float32),
            "leaf_grid": tuple(int(n) for n in geometry.grids[0]),
            "leaf_scale": vec(dims0 / geometry.spans[0]),
            "level_scale": np.asarray(level_scale, dtype=np.float32),
            "level_offset": np.asarray(level_offset, dtype=np.float32)}
