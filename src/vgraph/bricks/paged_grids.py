"""The grids the single pass's rays skip by (vgraph.bricks.paged_sampling, with
``empty_space_skipping``), as bindings of its pass, each kept across frames while what it is made
from stays (vgraph.bricks.kept_frame):
- ``walk_grid``: the grid the rays walk as the RayCaster walks its blocks (vgraph.bricks.walk_grids):
  mip's block maxima in the RayCaster's order (define PAGED_MIP_WALK; where bricks are missing,
  with the blocks where rays ask for them, PAGED_MIP_ASKS), and, where the atlas holds every
  planned brick, dvr's skip radii (PAGED_WALK, march.glsl), iso's blocks of 4 level-0 voxels with
  their cells' slots (PAGED_ISO_GRID; a flat leaf table only); where bricks are missing, iso's skip
  radii with the blocks where rays ask for them (PAGED_WALK with PAGED_WALK_ASKS). mip's, dvr's and
  iso's asking grid reduce only the bricks new to the cells they are drawn in (the atlas's
  AtlasBlocks keeps the rest from the frames before: walk_grids).
- ``block_flags``: otherwise, the flags of the atlas's blocks that add nothing this frame
  (vgraph.bricks.atlas_blocks) with their Chebyshev radii (vgraph.bricks.block_radii; PAGED_BLOCKS).
"""

from __future__ import annotations

import numpy as np

from vgraph.bricks import walk_grids
from vgraph.bricks.atlas import BrickAtlas
from vgraph.bricks.atlas_blocks import kept_texture
from vgraph.bricks.block_radii import block_radii, wholly_drawn
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.brick_planning import skipping_alpha
from vgraph.bricks.cells import table_of
from vgraph.bricks.kept_frame import KeptFrame, on_context
from vgraph.bricks.ray_requests import drawn_bricks
from vgraph.bricks.selection import FramePlan
from vgraph.gl.raycasting.empty_space import occupied_blocks
from vgraph.gl.raycasting.raycaster_base import Binding, Frame


def walk_grid(processor, kept: KeptFrame, frame: Frame, source, geometry: BrickGeometry, plan: FramePlan,
              atlas: BrickAtlas, missing) -> Binding | None:
    """With ``empty_space_skipping``, the binding of the grid the rays walk, made by the mode's
    builder (``_mip_dvr_grid``, ``_iso_grid``, with ``missing`` cells [n, 4] ``_iso_asking_grid``):
    mip's and iso's in every frame, dvr's where the atlas holds every planned brick (with missing
    cells its rays march front to back with the slots' block flags, asking as they go); None
    otherwise or where the builder makes no grid. Kept in ``kept.walk`` under the builder's key (a
    frame has one grid or none)."""
    mode = processor.compositing
    # shaded dvr walks since its loops take the RayCaster's stretches of 2-3 samples (compositing_dvr.glsl);
    # its refining frames march: walked, they asked for other pixels than the march and were
    # slower (vgraph.bricks.walk_grids)
    if mode not in GRIDS or not processor.empty_space_skipping or (len(missing) and mode == "dvr"):
        return None
    grid = (_iso_asking_grid if mode == "iso" and len(missing) else GRIDS[mode])(processor, kept, frame, source,
                                                                                geometry, plan, atlas, missing)
    if grid is None:
        return None
    key, name, make = grid

    def build() -> Binding | None:
        made = make()
        if made is None:
            return None
        values, defines, uniforms = made
        return Binding(defines, textures={"blocks": kept_texture(atlas.gl, name, frame.ctx, values)}, uniforms=uniforms)
    return kept.walk.get(key, build, lambda binding: binding is None or on_context(atlas.gl, name, frame.ctx))


def _mip_dvr_grid(processor, kept: KeptFrame, frame: Frame, source, geometry: BrickGeometry, plan: FramePlan,
                  atlas: BrickAtlas, missing):
    """mip's block maxima (PAGED_MIP_WALK; with ``missing`` cells, walk_grids.asking_grid and
    PAGED_MIP_ASKS), dvr's skip radii (PAGED_WALK): (key, texture name, make), make() -> (grid,
    defines, uniforms) or None. Kept while the leaf table (the plan's keys, the atlas's bricks), the
    mode and the skipping opacity are."""
    mode = processor.compositing
    alpha = skipping_alpha(processor, frame) if mode == "dvr" else None  # (mip: maxima)

    def make():
        if len(missing):  # (mip) each cell drawn from itself or its finest resident ancestor, as the leaf table
            keys = plan.keys()
            bricks = drawn_bricks(geometry, keys, atlas.slots)
            grid, block = walk_grids.asking_grid(source, geometry, keys, atlas.slots.__getitem__, atlas.blocks.ranges,
                                                 bricks, missing, memo=atlas.blocks)
            return grid, {"PAGED_MIP_WALK": True, "PAGED_MIP_ASKS": True}, walk_grids.uniforms(geometry, block, grid[..., 0])
        grid, block, define = walk_grids.frame_grid(alpha, source, geometry, plan.keys(), atlas.slots.__getitem__,
                                                    atlas.blocks.ranges, memo=atlas.blocks)
        return None if grid is None else (grid, {define: True}, walk_grids.uniforms(geometry, block, grid))
    return (kept.table.key, mode, None if alpha is None else alpha.tobytes()), "walk_grid", make


def _iso_grid(processor, kept: KeptFrame, frame: Frame, source, geometry: BrickGeometry, plan: FramePlan,
              atlas: BrickAtlas, missing):
    """iso's grid of blocks of 4 level-0 voxels (8, ... past 512^3) holding each block's skip radius
    and its cell's slot (vgraph.bricks.walk_grids.iso_grid; PAGED_ISO_GRID): all of level 0, in a
    flat leaf table; None otherwise (the slots' distances). (key, texture name, make) as
    _mip_dvr_grid's; kept while the plan's bricks, the atlas's and the level are the same."""
    resolved = kept.table.value
    if resolved.level != 0:
        return None

    def make():
        grid, block = walk_grids.iso_grid(source, geometry, plan.keys(), atlas.slots.__getitem__, atlas.blocks,
                                          resolved.table, float(processor.iso_level), atlas.size)
        if grid is None:
            return None
        read_scale = tuple(float(n) / float(m) for n, m in zip(geometry.dims0, atlas.size))
        return grid, {"PAGED_ISO_GRID": True}, {**walk_grids.uniforms(geometry, block, grid[..., 0]),
                                                 "iso_read_scale": read_scale}
    key = ("iso", plan.key_set(), atlas.key, atlas.stats["uploads"], atlas.stats["evictions"],
           float(processor.iso_level), id(atlas.blocks))
    return key, "iso_grid", make


def _iso_asking_grid(processor, kept: KeptFrame, frame: Frame, source, geometry: BrickGeometry, plan: FramePlan,
                     atlas: BrickAtlas, missing):
    """iso's grid of a frame with ``missing`` cells: skip radii (walk_grids.skip_radii; PAGED_WALK
    with PAGED_WALK_ASKS, march.glsl), a block occupied where its largest value reaches the level,
    each cell drawn from itself or its finest resident ancestor as the leaf table draws it, the
    empty blocks of missing cells asking. (key, texture name, make) as _mip_dvr_grid's; kept while
    the leaf table and the level are."""
    level = float(processor.iso_level)

    def make():
        keys = plan.keys()
        bricks = drawn_bricks(geometry, keys, atlas.slots)
        grid, block = walk_grids.skip_radii(source, geometry, keys, atlas.slots.__getitem__, atlas.blocks.ranges,
                                            lambda low, high: ~(high < level), bricks, missing, lows=False,
                                            memo=atlas.blocks)
        return None if grid is None else (grid, {"PAGED_WALK": True, "PAGED_WALK_ASKS": True},
                                          walk_grids.uniforms(geometry, block, grid))
    return (kept.table.key, "iso asking", level), "walk_grid", make


GRIDS = {"mip": _mip_dvr_grid, "dvr": _mip_dvr_grid, "iso": _iso_grid}  # mode -> its grid's builder


def block_flags(processor, kept: KeptFrame, frame: Frame, atlas: BrickAtlas, source, plan: FramePlan) -> Binding | None:
    """With ``empty_space_skipping``, the flags of the atlas's blocks that add nothing this frame
    (vgraph.bricks.atlas_blocks; dvr: no opacity over the block's range, iso: below the level,
    mip: nothing above 0, and each block's maximum for the skipping below the ray's); None when
    no block can be skipped (none, or none in a slot drawn wholly from its brick, or in dvr's frames
    that ask, in any slot: there the stand-ins skip too). The last frame's, neither computed nor
    uploaded again, while the atlas uploaded no brick and the rule and the plan's bricks are the
    same (a frame that only moves the camera and keeps its bricks)."""
    if not processor.empty_space_skipping:
        return None
    mode = processor.compositing
    if mode == "dvr":
        alpha = skipping_alpha(processor, frame)  # the 1D TF's, or the 2D TF's largest per value
        rule, skippable = (mode, alpha.tobytes()), lambda low, high: ~occupied_blocks(low, high, alpha)
    elif mode == "iso":
        level = processor.iso_level
        rule, skippable = (mode, float(level)), lambda low, high: high < level
    else:
        rule, skippable = (mode,), lambda low, high: high <= 0.0

    def build() -> Binding | None:
        skip = atlas.blocks.skippable(skippable)
        # jumps over boxes of empty blocks ahead of the ray across cells, runs over boxes of
        # occupied ones (vgraph.bricks.block_radii); mip: with each block's maximum, skipped
        # where not above the ray's maximum (PAGED_MIP), never in a slot not drawn wholly from
        # its brick (dvr's stand-ins: below)
        drawn = set(plan.keys())
        whole = wholly_drawn(len(skip), atlas.slots, drawn)
        # dvr's frames that ask end every box at its level-0 cell (bricks/paged_sampling.glsl), so
        # the stand-ins for missing cells skip their own empty blocks too (block_radii)
        stand_ins = mode == "dvr" and len(kept.table.value.missing) > 0
        own = wholly_drawn(len(skip), atlas.slots, atlas.slots) if stand_ins else whole
        if not (whole.any() if mode == "mip" else (skip & own[:, None, None, None]).any()):
            # Nothing a ray could skip (no empty block in a slot whose blocks may be skipped):
            # the march without flags draws and asks the same, without their build and look-ups.
            return None
        values = block_radii(atlas.blocks, skip, atlas.slots, drawn, table_of(source).spans,
                             empty_cells(kept.table.value), rule, stand_ins)
        if mode == "mip":
            maxima = atlas.blocks.maxima(whole)
            values = np.stack([values, np.tile(maxima, (2, 2, 2))], axis=-1)  # beside each octant's
        return Binding({"PAGED_BLOCKS": True, "PAGED_MIP": mode == "mip"},
                       textures={"block_flags": atlas.blocks.upload(frame.ctx, values)},
                       uniforms={"blocks_per_slot": tuple(int(n) for n in atlas.blocks.per_slot)})
    # the distances follow the cells drawn too (their set: a camera that turns reorders the plan)
    key = (atlas.blocks, atlas.stats["uploads"], atlas.stats["evictions"], rule, plan.key_set(),
           len(kept.table.value.missing) > 0)
    return kept.flags.get(key, build, lambda binding: binding is None or on_context(atlas.gl, "block_flags", frame.ctx))


def empty_cells(resolved):
    """bool [z, y, x] per level-0 cell of a flat leaf table (``resolved``, LeafPages): nothing drawn,
    nothing missing (the plan leaves it out); None with a directory (its final entries cover many
    cells)."""
    if resolved.level != 0:
        return None
    return (resolved.table[..., 3] < 0.0) & (resolved.wanted == 0.0)
