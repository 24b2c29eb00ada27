"""PagedSampling: the BrickedRayCaster's single-pass sampling (issue #33, item 1; its ``method``
``single_pass``): every ray walks the volume in one fullscreen pass of the RayCaster's own shader
(raycasting/raycaster.frag.glsl), sampling the frame's bricks through a page table
(vgraph.bricks.page_table) from a brick atlas (vgraph.bricks.atlas) instead of one volume texture.
The contract of components: vgraph.gl.raycasting.raycaster_base.

Conventions (docs/explanations/bricked-ray-casting.md, "One pass, a page table"):
- Its GLSL (bricks/paged_sampling.glsl) replaces VolumeSampling's: raw_sample(t) and intensity(t)
  of a level-0 texture coordinate, so the compositing modes (dvr, mip, iso), FrontToBack's opacity
  correction and early termination, the transfer function, the gradients and the lighting are the
  RayCaster's, unchanged. march.glsl's PAGED_SKIPPING hook walks each ray in runs: one leaf-table
  look-up where a ray enters a drawn cell (or cube of blocks), whose slot its samples and their
  gradients then read; cells that are not drawn are jumped over.
- The frame's plan is BrickSampling's (the same pyramid, brick cache, levels of detail by
  footprint, ``lod_bias``, ``max_error`` and the budget's floor level, the GUI's ``load_limit``):
  its bricks, and the planned ones already in memory, are placed in the atlas (read through the
  brick cache), the page table marks them, their ancestors (REFINE) and the cells the plan leaves
  out (EMPTY), and its leaf table (PageTable.resolve's walk, in a directory and pages:
  vgraph.bricks.leaf_pages) is what the shader reads. A planned brick
  the atlas does not hold is drawn from its finest resident ancestor. Under a ``load_limit`` a
  frame with missing bricks reads only a coarser plan within the limit (``fallback``, for those
  ancestors); the planned bricks that rays reached missing are counted by the shader
  (vgraph.bricks.ray_requests) and read after the frame by priority within what is left of the
  limit, never a brick no ray reached. ``last_frame`` (vgraph.bricks.paged_report): ``complete``
  (no ray reached a missing brick), ``levels`` drawn and ``coarsest_level``, ``error_bound`` (dvr,
  lod_error), ``missing`` (bricks rays reached missing), ``unreached`` (planned, missing, reached by
  no ray) and ``requests`` ((key, pixels), in the order read), ``sample_stride`` (level-0 steps per sample: 1,
  or in a drag's frame, ``FrameContext.interactive``, the finest planned level's,
  vgraph.bricks.coarse_step; such a frame reports no ``error_bound``).
- ``empty_space_skipping``: the blocks of 8^3 voxels inside the atlas's bricks that add nothing
  this frame (vgraph.bricks.atlas_blocks) are jumped over too, by cubes of them as the RayCaster's
  skipping (their Chebyshev radii; occupied blocks' radii size the runs) (define PAGED_BLOCKS);
  where every planned brick is resident, rays walk a grid of the frame as the RayCaster's walk
  (vgraph.bricks.paged_grids makes both).
- The atlas holds ``gl_budget`` MB of slots at most (no more than the pyramid's bricks); a budget
  that needs a texture past GL_MAX_3D_TEXTURE_SIZE, or holds not one brick, is a VGraphError
  naming ``<processor>.gl_budget``.
- Shading normals: the Gradients component's differences one voxel of level 0 apart (exact at
  level 0; a coarser brick is differenced at level 0's step, which its slot's apron covers);
  ``precomputed`` is drawn as ``central``, as brick by brick.
- Not done yet (issue #33): ``leaf`` (the leaves split) does not apply: a frame with a leaf is
  refused by name.
"""

from __future__ import annotations

import time
import weakref

import numpy as np

from vgraph.bricks.atlas import BrickAtlas
from vgraph.bricks.cache import MB, bricks_bytes
from vgraph.bricks import leaf_pages, paged_grids, paged_report
from vgraph.bricks.coarse_step import sample_stride, strided
from vgraph.bricks.kept_frame import KeptFrame, on_context
from vgraph.bricks.page_table import PageTable, pyramid_uniforms, texel_offsets
from vgraph.bricks.paged_strides import stride_binding
from vgraph.bricks.ray_requests import RayRequests, by_priority
from vgraph.bricks.sampling import BrickSampling
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.selection import FramePlan, coarse_first, normalised_ranges
from vgraph.bricks.targets import level_voxel
from vgraph.errors import VGraphError
from vgraph.frame_context import FrameContext
from vgraph.gl.raycasting.components import (Background, CameraRays, EntryExit, FrontToBack, IsoSurface, Sampling,
                                             TransferFunctionLut, ray_main_missed)
from vgraph.gl.raycasting.gradient_classification import GradientClassification
from vgraph.gl.raycasting.light import Gradients, Light
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame
from vgraph.gl.raycasting.textures import linear_sampler
from vgraph.gl_context import release_quietly

SHADER = "raycasting/raycaster.frag.glsl"  # the RayCaster's own


def atlas_state(atlas: BrickAtlas) -> tuple:
    """What says the atlas's bricks have not changed since: its texture and format, its uploads and
    evictions."""
    return atlas.key, id(atlas.gl.get("texture")), atlas.stats["uploads"], atlas.stats["evictions"]


class PagedSampling(Component):
    """The volume through a page table and a brick atlas, in one pass (module docstring). Its
    properties are BrickSampling's (the processor lists both)."""

    glsl = ("bricks/paged_sampling.glsl", "raycasting/gradients.glsl")

    def start(self) -> None:
        self.atlas = BrickAtlas()
        self.page_table = PageTable()
        weakref.finalize(self.processor, release_quietly, self.atlas.gl)
        weakref.finalize(self.processor, release_quietly, self.page_table.gl)
        self.frame_binding = Binding()
        self.last_frame: dict = {}
        self.warned_level = None  # the level the atlas's slots last raised the frame to
        self.kept = KeptFrame()

    @property
    def resolved(self):
        """The last frame's leaf table (vgraph.bricks.leaf_pages.LeafPages)."""
        return self.kept.table.value

    def bind(self, frame: Frame) -> Binding:
        return self.frame_binding  # made by draw_frame, which draws the pass

    # --- the frame ------------------------------------------------------------------------------
    def draw_frame(self, frame: Frame, context: FrameContext, target, own: Binding) -> None:
        """Draw the frame into ``target`` (image and depth) in one pass; ``own``: the processor's
        binding (its compositing define). Sets ``last_frame``."""
        processor = self.processor
        if context.leaf is not None:
            raise VGraphError(f"{processor.id}.method: single_pass does not draw the leaves split's "
                              f"runs of bricks yet; use method 'passes'")
        started = time.perf_counter()
        bricks: BrickSampling = processor.parts[BrickSampling]
        source = bricks.brick_source(frame.volume)
        cache = bricks.cache
        cache.use_source(source, frame.volume.value_range)
        cache.set_budgets(processor.ram_budget, processor.gl_budget)
        geometry = BrickGeometry.of(source)
        errors = bricks.lod_errors(source, geometry, frame)
        atlas = self.ensure_atlas(frame.ctx, source, cache.format)
        plan = self.fitted(bricks.plan(source, frame, errors), source, atlas.capacity)
        read_before, seconds_before = cache.stats["bricks_read"], cache.stats["read_seconds"]
        drawn = self.fallback(source, plan, frame.ctx, context.load_limit)
        # The planned bricks already in memory (read for earlier frames' requests: their upload costs
        # no reading, and the page table draws each cell at the finest it holds), then the bricks
        # read for this frame. Planned ones first: the plan fits the atlas, so where the fallback
        # and they do not fit together, every brick rays asked for still gets a slot and refining
        # ends (a fallback brick left out leaves its missing cells undrawn until their own come).
        placed = self.placed(plan, drawn, atlas, cache)
        every_resident = self.kept.placed is not None  # (placed: set where every planned brick has a slot)
        resolved, leaf = self.leaf_table(frame, source, geometry, plan, atlas)
        missing = resolved.missing  # the plan's cells the atlas misses
        requests = processor.parts[RayRequests]
        requests.prepare(frame.ctx, resolved)  # the rays ask for what they reach of these
        self.frame_binding = self.binding_of(frame, geometry, source, resolved, leaf)
        walk = paged_grids.walk_grid(processor, self.kept, frame, source, geometry, plan, atlas, missing)
        # (mip's walk grid already holds what the blocks' flags say: without them a run is its cell)
        blocks = paged_grids.block_flags(processor, self.kept, frame, atlas, source, plan) if walk is None else None
        for extra in (blocks, walk):
            if extra is not None:
                self.frame_binding = self.frame_binding.merge(extra)
        # march.glsl's runs: every sample is read from the slot its run's look-up found (also where
        # every cell is drawn: one look-up a run, not one a sample)
        self.frame_binding.defines["PAGED_SKIPPING"] = True
        # a drag's frame steps at the finest planned level's step (vgraph.bricks.coarse_step)
        stride = sample_stride(geometry, plan.keys() if context.interactive else (), context.interactive)
        lattice = stride_binding(processor.compositing, geometry, plan, missing, atlas.slots, stride)
        if lattice is not None:  # dvr's coarse cells on their own lattice (vgraph.bricks.paged_strides)
            self.frame_binding = self.frame_binding.merge(lattice)
        self.draw(strided(frame, stride), target, own)
        requested = requests.read(frame.ctx, missing)  # (key, pixels) of the missing cells rays reached
        if requested and context.load_limit is not None:  # the next frame refines (the GUI asks again)
            cache.begin_frame(plan.keys())
            cache.read_ahead([key for key, _ in by_priority(requested) if key not in cache.ram], context.load_limit,
                             cache.stats["bricks_read"] - read_before,
                             cache.stats["read_seconds"] - seconds_before)
        self.last_frame = {"bricks": len(placed), "floor_level": drawn.floor_level, "bytes": drawn.bytes,
                           # lod_error bounds level-0 steps, not a drag's longer ones: no bound then
                           **paged_report.drawn_report(frame, geometry, plan, atlas, requested,
                                                        errors if stride == 1 else None, every_resident),
                           "planned_floor_level": plan.floor_level, "missing": len(requested),
                           "unreached": len(missing) - len(requested), "requests": by_priority(requested),
                           "bricks_read": cache.stats["bricks_read"] - read_before,
                           "atlas_slots": atlas.capacity, "sample_stride": stride,
                           "seconds": time.perf_counter() - started}

    def placed(self, plan: FramePlan, drawn: FramePlan, atlas: BrickAtlas, cache) -> list:
        """The bricks of the plan in memory and those read for this frame placed in the atlas, the
        plan's resident ones pinned (draw_frame): the keys that got a slot. Where the last frame
        placed the same bricks (in any order: a turning camera reorders them), every one resident,
        and the atlas has changed nothing since, there is nothing to place: a frame of thousands of
        bricks skips its loops over them (the 768^3 torus in 1728 bricks: about 0.6 ms of Python a
        frame). Their least-recently-used order stays the last frame's: the bricks of one frame are
        all pinned and used alike."""
        same = plan.key_set()  # (arrays compared: no set of thousands of keys made a frame)
        if (self.kept.placed == (same, atlas_state(atlas))
                and (drawn is plan or drawn.key_sequence() == plan.key_sequence())):
            return plan.key_array
        keys = plan.keys()
        resident_before = set(atlas.slots)
        wanted = list(dict.fromkeys([key for key in keys if key in cache.ram] + drawn.keys()))
        atlas.begin_frame(set(wanted) | (set(keys) & resident_before))
        placed = atlas.place_all(wanted, cache.brick)
        complete = wanted == keys and len(placed) == len(keys)
        self.kept.placed = (same, atlas_state(atlas)) if complete else None
        return placed

    def fallback(self, source, plan: FramePlan, ctx, load_limit) -> FramePlan:
        """The bricks read for this frame, pinned in the cache with the plan's resident ones:
        without a load limit the plan; under one, where planned bricks are missing, the finest
        plan coarser than the plan's floor whose missing bricks the limit can read (coarse_first),
        the level the page table draws missing cells from. The plan's own missing bricks are read
        only once rays ask for them (vgraph.bricks.ray_requests), never ahead: a brick no ray
        reaches is never read. Where the fallback does not fit the budget beside the plan's bricks
        in memory, none is read: missing cells are drawn from the coarser bricks the atlas still
        holds, else not at all, until the bricks rays ask for come. The coarsest plan as
        BrickSampling.limited."""
        bricks: BrickSampling = self.processor.parts[BrickSampling]
        cache = bricks.cache
        if load_limit is None or plan.floor_level >= len(source.levels) - 1:
            return bricks.limited(source, plan, ctx, load_limit)
        resident = cache.resident(ctx)
        if all(key in resident for key in plan.keys()):
            return bricks.limited(source, plan, ctx, load_limit)
        drawn = coarse_first(source, plan.at_floor(plan.floor_level + 1, source), resident, load_limit,
                             cache.seconds_per_byte(), bricks.budget())
        pinned = set(drawn.keys()) | (set(plan.keys()) & resident)
        if bricks_bytes(source, pinned) > bricks.budget():
            drawn, pinned = FramePlan([], plan.floor_level, 0), set(plan.keys()) & resident
        cache.begin_frame(pinned)
        return drawn

    def summary(self) -> str:
        """The last frame in a line (the inspector's, Processor.frame_summary; paged_report)."""
        return paged_report.summary(self.last_frame)

    def leaf_table(self, frame: Frame, source, geometry: BrickGeometry, plan: FramePlan, atlas: BrickAtlas):
        """The frame's leaf table (vgraph.bricks.leaf_pages.LeafPages) and its texture: the page
        table of the plan and the atlas's bricks, resolved into a directory and pages; the last
        frame's while neither the plan nor the atlas's bricks changed (a still camera: no table to
        build)."""
        key = (id(source), frame.volume.value_range, plan.key_sequence(), atlas.key, atlas.stats["uploads"],
               atlas.stats["evictions"], id(atlas.gl.get("texture")))

        def build():
            keys, origins = atlas.resident()
            resolved = leaf_pages.build(geometry, plan.keys(), keys, texel_offsets(source, keys, origins),
                                        self.lows(source, geometry, frame), atlas.capacity)
            self.page_table.upload(frame.ctx, resolved.table)
            return resolved
        resolved = self.kept.table.get(key, build, lambda _: on_context(self.page_table.gl, "texture", frame.ctx))
        return resolved, self.page_table.gl["texture"]

    def fitted(self, plan: FramePlan, source, slots: int) -> FramePlan:
        """``plan``, or the finest coarser one whose bricks fit the atlas's ``slots`` (a slot has the
        shape of the largest brick, so bricks that fit the budget in bytes may not fit in slots);
        said once per level, as BrickSampling says a level the budget raised."""
        fitted = plan
        while len(fitted) > slots and fitted.floor_level < len(source.levels) - 1:
            fitted = fitted.at_floor(fitted.floor_level + 1, source)
        if fitted is not plan and fitted.floor_level != self.warned_level:
            processor = self.processor
            processor.parts[BrickSampling].warn(
                f"{processor.type_name} '{processor.id}': the brick atlas ({slots} slots of gl_budget "
                f"{processor.gl_budget:g} MB) cannot hold the frame's {len(plan.bricks)} bricks; rendering at "
                f"level {fitted.floor_level} or coarser ({len(fitted.bricks)} bricks)")
        self.warned_level = fitted.floor_level if fitted is not plan else None
        return fitted

    def ensure_atlas(self, ctx, source, fmt) -> BrickAtlas:
        processor = self.processor
        try:
            return self.atlas.ensure(ctx, source, fmt, int(processor.gl_budget * MB))
        except ValueError as error:
            raise VGraphError(f"{processor.id}.gl_budget: {processor.type_name} '{processor.id}' cannot make "
                              f"its brick atlas: {error}; choose a gl_budget between one brick and what "
                              f"one 3D texture holds, or use method 'passes'") from None

    def lows(self, source, geometry, frame: Frame):
        """level -> the cells' smallest normalised intensities, the value of an EMPTY cell."""
        def low(level: int) -> np.ndarray:
            values = normalised_ranges(source, level, frame.volume.value_range)[0]
            cells = tuple(geometry.grids[level][::-1])
            if values.shape != cells:  # cells that are not the level's bricks (cells.py): the level's least
                values = np.full(cells, float(np.min(values)))
            return values
        return low

    def binding_of(self, frame: Frame, geometry: BrickGeometry, source, resolved, leaf) -> Binding:
        """The pass's atlas, leaf table (``resolved``, its texture ``leaf``) and their uniforms
        (bricks/paged_sampling.glsl)."""
        processor, atlas = self.processor, self.atlas
        fmt = processor.parts[BrickSampling].cache.format
        uniforms = {**self.pyramid_uniforms(geometry, source, fmt),
                    "page_cells": tuple(int(n) for n in resolved.page_cells)}
        defines = {"PAGE_LEVELS": len(source.levels), "PAGE_DIRECTORY": resolved.level > 0}
        if frame.lit:
            gradients = processor.parts[Gradients]
            gradients.check()
            derivatives = processor.parts[BrickSampling].derivatives()
            defines.update(gradients.defines(derivatives))
            voxel, spacing = level_voxel(geometry, 0)
            uniforms.update(gradients.uniforms(float(fmt.scale), voxel, spacing, derivatives))
        return Binding(defines, textures={"volume": atlas.texture, "page_table": leaf},
                       samplers={"volume": linear_sampler(frame.ctx)}, uniforms=uniforms)

    def pyramid_uniforms(self, geometry: BrickGeometry, source, fmt) -> dict:
        """The uniforms of the pyramid, the atlas's shape and the bricks' format (paged_sampling.glsl):
        the last frame's while these are the same (a new camera changes none of them)."""
        atlas = self.atlas
        # (the geometry by identity: one per source)
        key = (geometry, tuple(atlas.size), tuple(atlas.slot_shape), float(fmt.scale), float(fmt.offset))
        return self.kept.uniforms.get(key, lambda: pyramid_uniforms(geometry, source, atlas.size, atlas.slot_shape, fmt))

    def draw(self, frame: Frame, target, own: Binding) -> None:
        """The one pass: the RayCaster's shader with the parts of PAGED_PARTS; the processor's
        ``own`` binding last (its compositing define); the depth output where ``target`` has its
        image (the processor's depth is read)."""
        processor = self.processor
        with_depth = target.count > 1
        processor.draw(frame, SHADER, target, parts=PAGED_PARTS,
                       own=own.merge(Binding(defines={"DEPTH_OUTPUT": with_depth})),
                       missed=ray_main_missed(processor.background, with_depth))


# The one pass: the GLSL and bindings of these parts, in this order, ahead of the RayCaster's shader
# (RayRequests first: its GLSL is an #extension line).
# Not Gradients: its GLSL comes with PagedSampling's (after raw_sample) and its binding is
# PagedSampling's (the bricks' format and level 0's step; precomputed drawn as central).
# Mask and CutAway weigh the samples as in the RayCaster (its shader's sample_weight.glsl),
# GradientClassification the gradient opacity (after PagedSampling: it reads intensity()).
PAGED_PARTS = (RayRequests, EntryExit, CameraRays, PagedSampling, Sampling, TransferFunctionLut, FrontToBack, IsoSurface,
               Light, Background, Mask, CutAway, GradientClassification)
