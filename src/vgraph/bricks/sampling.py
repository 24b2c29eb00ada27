"""BrickSampling: the ray casters' component that samples a volume brick by brick, for volumes
larger than memory (a BrickedVolume's pyramid on disk) or than one GL texture. The BrickedRayCaster
is built on it, and the RayCaster draws through its own copy when one texture cannot hold the
volume (vgraph.gl.raycasting.textures.needs_bricks). The contract of components:
vgraph.gl.raycasting.raycaster_base.

Conventions (docs/explanations/bricked-ray-casting.md explains each with the numbers):
- How it draws: VolumeSampling binds one texture for the processor's one fullscreen pass;
  BrickSampling draws the frame itself when the processor's process() calls ``draw_frame(frame,
  context, target, own)``: one pass of BRICK_SHADER per brick, then the resolve pass. Each pass is
  the processor's (``binding()``, ``program()``, ``draw()`` of RaycasterBase), so its GLSL and
  bindings come from the components in BRICK_PARTS and RESOLVE_PARTS, and the processor's ``own``
  binding (its compositing define) goes into both. The shaders keep only their own includes.
- Rays come from the EntryExitPoints images, as for the RayCaster, and the samples lie on the
  RayCaster's lattice: sample i at entry + i * step, step = min(spacing) / sampling_rate of level 0.
  Each brick owns a half-open box of that lattice (vgraph.bricks.brick_geometry), so every sample is
  taken in exactly one brick, from the brick's texture with a halo of 2 voxels
  (vgraph.bricks.cache): trilinear values and central / Sobel gradients equal the whole volume's.
- Bricks are drawn front to back, one fullscreen pass each (scissored to the brick's screen
  rectangle), into RGBA32F accumulation targets: dvr and iso blend "under" (C += (1 - A) C_brick),
  mip keeps the largest maximum with a depth test; a last pass classifies (mip), puts the
  background under and writes the RayCaster's `image` and `depth` outputs (depth's sample counter
  is 0). Blending cannot stop rays early (a pass cannot read the target it blends into); with
  ``early_termination`` < 1 (dvr) each brick instead reads the accumulation, continues the
  RayCaster's sum and stops where it does, drawing into a scratch pair copied back per brick.
- Inside a brick, blocks of 8^3 voxels that cannot contribute are jumped over (the processor's
  ``empty_space_skipping``; the brick's block ranges go up with it, cache.block_ranges_of).
- Shading normals: the Gradients component's finite differences one voxel of level 0 apart at every
  level, as the single pass's (a coarse brick's halo of 2 of its voxels covers them; nearer the
  level-0 image than one voxel of the level: tests/test_paged_coarse_gradients.py),
  Gradients.uniforms; ``precomputed`` derivatives are drawn as ``central`` (a gradient volume of a
  volume that large is what bricking avoids; inside the box both give the same gradient up to
  16-bit steps).
- The frame's bricks, their levels and budgets are BrickPlanning's (vgraph.bricks.brick_planning,
  the base of this component: its properties, pyramid, cache and plan).
- A dvr brick of a coarse level samples its own lattice: every level_stride-th sample of level
  0's (BrickGeometry.strides), each standing for the level-0 samples up to the next
  (bricks/brick_span.glsl), so a coarse level is cheaper and seams between levels stay exact.
- The frame context (vgraph.frame_context; not properties) gives two things: ``load_limit``
  (BrickPlanning.limited: a coarser frame while bricks are missing, the planned ones read ahead
  within the limit; ``last_frame["complete"]`` says whether the planned frame was drawn) and
  ``leaf`` (only the leaves split's tasks give one, vgraph.distributed.leaves): draw a run of the
  plan's bricks and keep the accumulation before the resolve pass, or resolve an accumulation
  composited from such runs (selection.LeafPass); None draws the frame as always.
"""

from __future__ import annotations

import time
import weakref

import moderngl
import numpy as np

from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.brick_planning import BrickPlanning, skipping_alpha
from vgraph.bricks.cache import MB
from vgraph.bricks.selection import FramePlan, LeafPass
from vgraph.bricks.targets import Accumulation, brick_uniforms, level_voxel
from vgraph.frame_context import FrameContext
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.components import (Background, CameraRays, EntryExit, FrontToBack, IsoSurface, Sampling,
                                             TransferFunctionLut)
from vgraph.gl.raycasting.gradient_classification import GradientClassification
from vgraph.gl.raycasting.light import Gradients, Light
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, Frame
from vgraph.gl.raycasting.textures import linear_sampler
from vgraph.gl.shaders import programs
from vgraph.gl_context import release_quietly

BRICK_SHADER = "bricks/brick.frag.glsl"
RESOLVE_SHADER = "bricks/resolve.frag.glsl"
COPY_SHADER = "bricks/copy.frag.glsl"
COMPOSITING = ("dvr", "mip", "iso")  # the modes drawn brick by brick
# The derivatives of the shading normals brick by brick (module docstring): precomputed -> central.
BRICK_DERIVATIVES = {"precomputed": "central"}


def level_span(levels: list[int]) -> str:
    """The levels a frame drew, for its summary line: "2", "0-3", or "-" for none."""
    return "-" if not levels else str(levels[0]) if len(levels) == 1 else f"{levels[0]}-{levels[-1]}"


class BrickSampling(BrickPlanning):
    """The frame drawn brick by brick (module docstring) of the bricks BrickPlanning, its base,
    plans. The processor declares ``empty_space_skipping`` (its own or EmptySpace's)."""

    glsl = ("bricks/brick_sampling.glsl", "bricks/brick_span.glsl", "bricks/brick_blocks.glsl",
            "bricks/front_state.glsl")

    def start(self) -> None:
        super().start()
        processor = self.processor
        self.accumulation = Accumulation()
        # Accumulation targets go with the processor (moderngl does not release GL objects on
        # garbage collection).
        weakref.finalize(processor, release_quietly, self.accumulation.gl)
        self.alpha_count: dict = {}  # "texture": LUT entries with opacity, cumulated; "key": its alpha
        weakref.finalize(processor, release_quietly, self.alpha_count)
        self.last_frame: dict = {}

    def derivatives(self) -> str:
        return BRICK_DERIVATIVES.get(self.processor.derivatives, self.processor.derivatives)

    # --- the frame ------------------------------------------------------------------------------
    def draw_frame(self, frame: Frame, context: FrameContext, target, own: Binding) -> None:
        """Draw the frame into ``target`` (the processor's image and depth): the bricks the plan (or
        the context) asks for, then the resolve pass; ``own``: the processor's binding (its
        compositing define). Sets ``last_frame``."""
        started = time.perf_counter()
        source = self.brick_source(frame.volume)  # in the frame of the camera (an extreme box's)
        self.cache.use_source(source, frame.volume.value_range)
        self.cache.set_budgets(self.processor.ram_budget, self.processor.gl_budget)
        geometry = BrickGeometry.of(source)
        errors = self.lod_errors(source, geometry, frame)
        plan = self.plan(source, frame, errors)
        read_before, seconds_before = self.cache.stats["bricks_read"], self.cache.stats["read_seconds"]
        drawn = self.limited(source, plan, frame.ctx, context.load_limit)
        accumulation = self.accumulation.ensure(frame.ctx, frame.size)
        if context.leaf is None:
            self.draw_bricks(frame, geometry, drawn.bricks, accumulation, own)
        else:
            drawn = self.leaf_pass(frame, geometry, plan, accumulation, context.leaf, own)
        self.resolve(frame, accumulation, target, own)
        complete = drawn is plan or context.leaf is not None  # (a leaf draws its part of the planned frame)
        if not complete:  # the planned bricks, front first, for the next frame (the GUI asks again)
            self.cache.begin_frame(plan.keys())
            resident = self.cache.resident(frame.ctx)
            self.cache.read_ahead([key for key in plan.keys() if key not in resident], context.load_limit,
                                  self.cache.stats["bricks_read"] - read_before,
                                  self.cache.stats["read_seconds"] - seconds_before)
        self.last_frame = {"bricks": len(drawn.bricks), "floor_level": drawn.floor_level, "bytes": drawn.bytes,
                           "levels": sorted({key[0] for key, _ in drawn.bricks}), "complete": complete,
                           "planned_floor_level": plan.floor_level,
                           # the most a pixel can differ from the level-0 frame (dvr; lod_error)
                           "error_bound": None if errors is None else errors.frame_bound(
                               plan.bricks if context.leaf is not None else drawn.bricks, frame.size),
                           "bricks_read": self.cache.stats["bricks_read"] - read_before,
                           "seconds": time.perf_counter() - started}

    def summary(self) -> str:
        """The last frame in a line (the inspector's, Processor.frame_summary): its levels and
        bricks, its error bound against the level-0 frame (dvr) and whether it is still refining."""
        frame = self.last_frame
        if not frame:
            return ""
        line = f"bricks: level {level_span(frame['levels'])}, {frame['bricks']} bricks ({frame['bytes'] / MB:.1f} MB)"
        if frame.get("error_bound") is not None:
            line += (f"; error bound {frame['error_bound']:.3g} against the level-0 frame "
                     f"(max_error {self.processor.max_error:g})")
        return line + ("" if frame["complete"] else "; refining")

    def leaf_pass(self, frame, geometry, plan, accumulation, leaf: LeafPass, own: Binding) -> FramePlan:
        """The leaves split's part of the frame (selection.LeafPass): draw its bricks and read the
        accumulation back into ``leaf``, or write the composited accumulation for the resolve pass."""
        leaf.plan = plan
        if leaf.accumulated is not None:
            accumulation.clear()
            for texture, array in zip(accumulation.textures, leaf.accumulated):
                texture.write(np.ascontiguousarray(array, dtype=np.float32).tobytes())
            return FramePlan([], plan.floor_level, 0)
        self.draw_bricks(frame, geometry, leaf.bricks, accumulation, own)
        height, width = frame.size[1], frame.size[0]
        leaf.partial = tuple(np.frombuffer(texture.read(), dtype=np.float32).reshape(height, width, 4)
                             for texture in accumulation.textures)
        return FramePlan(list(leaf.bricks), plan.floor_level, 0)

    def bind(self, frame: Frame) -> Binding:
        """The brick passes' defines, the intensity mapping of the bricks' textures and, for dvr
        skipping, the LUT's opacity counts (bricks/*.glsl); the bricks' textures go per pass."""
        processor = self.processor
        processor.parts[Gradients].check()
        terminating = self.reads_accumulation()
        skipping = processor.empty_space_skipping
        defines = {"READ_ACCUMULATION": terminating, "EARLY_TERMINATION": terminating,
                   "SKIP_EMPTY_BLOCKS": skipping}
        if frame.lit:
            defines.update(processor.parts[Gradients].defines(self.derivatives()))
        textures = {}
        if self.compositing == "dvr" and skipping:
            textures["alpha_count"] = self.alpha_count_texture(frame.ctx, skipping_alpha(processor, frame))
        fmt = self.cache.format
        return Binding(defines, textures, uniforms={"intensity_scale": float(fmt.scale),
                                                    "intensity_offset": float(fmt.offset)})

    def brick_binding(self, frame: Frame, geometry, key) -> dict:
        """The uniforms of one brick: where it lies and the finite differences (level 0's voxel)."""
        uniforms = brick_uniforms(geometry, key)
        if frame.lit:
            voxel, spacing = level_voxel(geometry, 0)
            uniforms.update(self.processor.parts[Gradients].uniforms(self.cache.format.scale, voxel, spacing,
                                                                      self.derivatives()))
        return uniforms

    def draw_bricks(self, frame, geometry, bricks, accumulation, own: Binding) -> None:
        """One pass per brick, front to back, into the accumulation (module docstring)."""
        processor, ctx = self.processor, frame.ctx
        binding = processor.binding(frame, [part for part in BRICK_PARTS if part is not Gradients], own)
        program = processor.program(frame, BRICK_SHADER, binding.defines, BRICK_PARTS)
        reading = self.reads_accumulation()
        target = accumulation.scratch if reading else accumulation
        textures = dict(binding.textures)
        if reading:
            textures.update(front_sum=accumulation.textures[0], front_first=accumulation.textures[1])
        # The scissor is state of a framebuffer (moderngl: ctx.scissor is the bound one's): set
        # on the targets' own, so no other target keeps a brick's rectangle.
        framebuffers = (accumulation.framebuffer, accumulation.scratch.framebuffer)
        for framebuffer in framebuffers:
            framebuffer.scissor = None
        accumulation.clear()
        if reading:
            copy = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, COPY_SHADER, {}, processor=processor.id)
        else:
            self.set_blending(ctx)
        try:
            for number, (key, rect) in enumerate(bricks):
                processor.report_progress(number, len(bricks), "drawing bricks")  # reading those not in memory
                target.framebuffer.scissor = rect
                fullscreen_pass(ctx, program, target, {**textures, "volume": self.cache.texture(ctx, key),
                                                       "blocks": self.cache.blocks(ctx, key)},
                                {**binding.uniforms, **self.brick_binding(frame, geometry, key)},
                                samplers={"volume": linear_sampler(ctx)})
                if reading:
                    self.copy_back(ctx, copy, accumulation, rect, first=number == 0)
        finally:
            for framebuffer in framebuffers:
                framebuffer.scissor = None
            ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
            ctx.blend_func = moderngl.DEFAULT_BLENDING

    def alpha_count_texture(self, ctx, alpha: np.ndarray):
        """4097 x 1 R32F: entry i = the entries of ``alpha`` (skipping_alpha) below i with opacity
        > 0 (brick_blocks.glsl)."""
        texture = self.alpha_count.get("texture")
        if texture is None or texture.ctx is not ctx:
            release_quietly(self.alpha_count)
            texture = self.alpha_count["texture"] = ctx.texture((len(alpha) + 1, 1), 1, dtype="f4")
            self.alpha_count["key"] = None
        if self.alpha_count.get("key") is None or not np.array_equal(self.alpha_count["key"], alpha):
            counts = np.concatenate([[0.0], np.cumsum(alpha > 0.0)]).astype(np.float32)
            texture.write(counts.tobytes())
            self.alpha_count["key"] = alpha.copy()
        return texture

    def copy_back(self, ctx, program, accumulation, rect, first: bool) -> None:
        """The brick's rectangle of the scratch pair -> the accumulation (bricks/copy.frag.glsl)."""
        accumulation.framebuffer.scissor = rect
        scratch = accumulation.scratch.textures
        textures = {"scratch_sum": scratch[0], "scratch_first": scratch[1]}
        if first:
            fullscreen_pass(ctx, program, accumulation, textures)
        else:  # the samplers already point at the units of the first pass
            for unit, texture in enumerate(textures.values()):
                texture.use(location=unit)
            fullscreen_pass(ctx, program, accumulation)

    def set_blending(self, ctx) -> None:
        if self.compositing == "mip":
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
        else:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.ONE_MINUS_DST_ALPHA, moderngl.ONE  # "under"

    def resolve(self, frame, accumulation, target, own: Binding) -> None:
        """The accumulation -> image and depth (bricks/resolve.frag.glsl)."""
        textures = {"accumulated_sum": accumulation.textures[0], "accumulated_first": accumulation.textures[1]}
        self.processor.draw(frame, RESOLVE_SHADER, target, parts=RESOLVE_PARTS,
                            own=Binding(defines=own.defines, textures=textures))


# Each brick's pass: the GLSL of these parts, in this order (gradients.glsl reads the brick's
# raw_sample), ahead of BRICK_SHADER; Gradients' binding is BrickSampling's (per brick level).
# Mask and CutAway weigh the samples (raycasting/sample_weight.glsl), GradientClassification the
# gradient opacity (after BrickSampling: it reads intensity()); the processor has all three.
BRICK_PARTS = (EntryExit, CameraRays, Sampling, TransferFunctionLut, FrontToBack, IsoSurface, BrickSampling,
               Gradients, Light, Mask, CutAway, GradientClassification)
RESOLVE_PARTS = (EntryExit, CameraRays, Sampling, TransferFunctionLut, Background)
