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
  Each brick owns a half-open box of that lattice (vgraph.bricks.selection), so every sample is
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
- Shading normals: the Gradients component's finite differences with each brick level's voxel
  (Gradients.uniforms); ``precomputed`` derivatives are drawn as ``central`` (a gradient volume of
  a volume that large is what bricking avoids; inside the box both give the same gradient up to
  16-bit steps).
- The volume's pyramid: ``volume.bricks`` (BrickedVolume), else an ArrayPyramid of the in-memory
  volume with ``brick_size`` bricks (built once per volume and brick size). An extreme box (1e14
  or 1e-12 across, far from the origin) is drawn in its normalised frame as the RayCaster draws
  one: the pyramid is the framed copy's (a BrickedVolume regridded, nothing read).
- Per frame the bricks are chosen (selection.plan_frame): in view, not empty under the TF (or
  below the iso level), at the level their projected voxel size asks (``lod_bias``), for dvr
  refined where their error bound under the TF (vgraph.bricks.lod_error) would take the frame's
  over ``max_error`` (1, the default: no refining), raised until the frame's bricks fit
  min(ram_budget, gl_budget); a raised level is warned about. ``last_frame["error_bound"]``: the
  most any pixel of the frame can differ from the level-0 frame (dvr; None for mip and iso).
- A dvr brick of a coarse level samples its own lattice: every level_stride-th sample of level
  0's (BrickGeometry.strides), each standing for the level-0 samples up to the next
  (bricks/brick_span.glsl), so a coarse level is cheaper and seams between levels stay exact.
- The frame context (vgraph.frame_context; not properties) gives two things:
  ``load_limit`` (only the GUI's render process gives one, scripts and ``vgraph run`` none, so they
  always draw the planned frame): a frame whose missing bricks cannot be read within it is drawn
  coarser (selection.coarse_first) and the planned bricks are read ahead within the limit;
  ``last_frame["complete"]`` says whether the planned frame was drawn. ``leaf`` (only the leaves
  split's tasks give one, vgraph.distributed.leaves): draw a run of the plan's bricks and keep the
  accumulation before the resolve pass, or resolve an accumulation composited from such runs
  (selection.LeafPass); None draws the frame as always.
"""

from __future__ import annotations

import logging
import time
import warnings
import weakref
from typing import Annotated

import moderngl
import numpy as np
from pydantic import AfterValidator, Field, StrictInt

from vgraph.bricks.cache import MB, BrickCache, LoadLimit
from vgraph.bricks.lod_error import LodErrors, TransferFunctionSpread
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.selection import BrickGeometry, FramePlan, LeafPass, coarse_first, plan_frame, visible_bricks
from vgraph.bricks.targets import Accumulation, brick_uniforms, level_voxel
from vgraph.errors import VGraphError, VGraphWarning
from vgraph.frame_context import FrameContext
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.components import (Background, CameraRays, EntryExit, FrontToBack, IsoSurface, Sampling,
                                             TransferFunctionLut)
from vgraph.gl.raycasting.gradient_classification import GradientClassification
from vgraph.gl.raycasting.light import Gradients, Light
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame
from vgraph.gl.raycasting.textures import linear_sampler
from vgraph.gl.shaders import programs
from vgraph.gl_context import release_quietly
from vgraph.properties import FloatProperty, IntProperty
from vgraph.volume import Volume

BRICK_SHADER = "bricks/brick.frag.glsl"
RESOLVE_SHADER = "bricks/resolve.frag.glsl"
COPY_SHADER = "bricks/copy.frag.glsl"
COMPOSITING = ("dvr", "mip", "iso")  # the modes drawn brick by brick
# The derivatives of the shading normals brick by brick (module docstring): precomputed -> central.
BRICK_DERIVATIVES = {"precomputed": "central"}
log = logging.getLogger(__name__)


def level_span(levels: list[int]) -> str:
    """The levels a frame drew, for its summary line: "2", "0-3", or "-" for none."""
    return "-" if not levels else str(levels[0]) if len(levels) == 1 else f"{levels[0]}-{levels[-1]}"


def _power_of_two(value: int) -> int:
    if value & (value - 1):
        raise ValueError(f"must be a power of two (8, 16, 32, ...), got {value}")
    return value


class BrickSizeProperty(IntProperty):
    """Voxels per brick edge: a power of two from 8 (a smaller brick is mostly halo)."""

    def _value_type(self):
        return Annotated[StrictInt, Field(ge=self.min, le=self.max), AfterValidator(_power_of_two)]


class BrickSampling(Component):
    """The volume's bricks, their cache under memory budgets and the frame drawn brick by brick
    (module docstring). ``mode``: the processor's option naming the compositing mode (dvr, mip,
    iso); ``when``: added to the properties' docs where they apply only to some frames (the
    RayCaster's). The processor declares ``empty_space_skipping`` (its own or EmptySpace's)."""

    glsl = ("bricks/brick_sampling.glsl", "bricks/brick_span.glsl", "bricks/brick_blocks.glsl",
            "bricks/front_state.glsl")

    def __init__(self, mode: str = "compositing", when: str = ""):
        self.mode, self.when = mode, when

    def declare(self):
        when = f"; {self.when}" if self.when else ""
        return {"brick_size": BrickSizeProperty(64, min=8, max=1024, doc="voxels per brick edge for in-memory "
                                                f"volumes (a BrickedVolume keeps its own){when}"),
                "lod_bias": FloatProperty(0.0, min=-16.0, max=16.0,
                                          doc=f"levels coarser (+) or finer (-) than voxels of about a pixel{when}"),
                "finest_level": IntProperty(0, min=0, max=32,
                                            doc="no brick finer than this level (0: the data's own); with "
                                                f"lod_bias -16 every brick is drawn at it{when}"),
                "ram_budget": FloatProperty(1024.0, min=0.01, max=1e7, doc=f"MB of bricks kept in memory{when}"),
                "gl_budget": FloatProperty(512.0, min=0.01, max=1e7, doc=f"MB of brick textures kept on the GL{when}"),
                "max_error": FloatProperty(1.0, min=0.0, max=1.0,
                                           doc="dvr: the most any pixel may move from the level-0 frame by "
                                               "bricks drawn coarser (a bound under the transfer function; "
                                               "last_frame['error_bound']); 1: levels by footprint alone"
                                               f"{when}")}

    def start(self) -> None:
        processor = self.processor
        self.accumulation = Accumulation()
        self.cache = BrickCache(processor.ram_budget, processor.gl_budget)
        # Brick textures and accumulation targets go with the processor (moderngl does not
        # release GL objects on garbage collection).
        weakref.finalize(processor, release_quietly, self.cache.gl)
        weakref.finalize(processor, release_quietly, self.accumulation.gl)
        weakref.finalize(processor, release_quietly, self.cache.block_textures)
        self.alpha_count: dict = {}  # "texture": LUT entries with opacity, cumulated; "key": its alpha
        weakref.finalize(processor, release_quietly, self.alpha_count)
        self.pyramid = None  # (weakref to the volume, brick size, ArrayPyramid)
        self.last_frame: dict = {}
        self.warned_level = 0  # the budget's level last warned about (0: none)
        self.spread = (None, None)  # (the resolved TF and lighting, its TransferFunctionSpread)
        self.warned_mode = None  # the compositing mode last warned about max_error not applying to

    @property
    def compositing(self) -> str:
        return getattr(self.processor, self.mode)

    def reads_accumulation(self) -> bool:
        """dvr with early termination: each brick continues the sum of the bricks in front."""
        return self.compositing == "dvr" and self.processor.early_termination < 1.0

    def derivatives(self) -> str:
        return BRICK_DERIVATIVES.get(self.processor.derivatives, self.processor.derivatives)

    # --- the pyramid and the frame's plan --------------------------------------------------------
    def brick_source(self, volume: Volume):
        """The volume's BrickSource: its own (BrickedVolume), else an ArrayPyramid kept per volume."""
        own = getattr(volume, "bricks", None)
        if own is not None:
            return own
        size = self.processor.brick_size
        cached = self.pyramid
        if cached is None or cached[0]() is not volume or cached[1] != size:
            self.pyramid = cached = (weakref.ref(volume), size, ArrayPyramid.from_volume(volume, (size,) * 3))
        return cached[2]

    def visible(self, source, frame: Frame):
        """visible(level) -> bool per brick for this frame's mode (selection.visible_bricks)."""
        mode, processor = self.compositing, self.processor
        alpha = skipping_alpha(processor, frame) if mode == "dvr" else None
        value_range = frame.volume.value_range
        return lambda level: visible_bricks(source, level, mode, alpha, processor.iso_level, value_range)

    def budget(self) -> int:
        return int(min(self.processor.ram_budget, self.processor.gl_budget) * MB)

    def lod_errors(self, source, geometry, frame: Frame) -> LodErrors | None:
        """The frame's error bounds per brick and level (vgraph.bricks.lod_error); None for mip and
        iso, whose levels go by footprint alone (said once when max_error asks for more)."""
        processor = self.processor
        if self.compositing != "dvr":
            if processor.max_error < 1.0 and self.warned_mode != self.compositing:
                self.warn(f"{processor.type_name} '{processor.id}': max_error bounds dvr frames only; "
                          f"{self.compositing} chooses levels by footprint (lod_bias)")
            self.warned_mode = self.compositing
            return None
        self.warned_mode = None
        if processor.transfer_function_2d is not None and processor.max_error < 1.0:
            raise VGraphError(f"{processor.id}.max_error: the error bounds of a level go by the 1D "
                              f"transfer function, not transfer_function_2d; set {processor.id}.max_error "
                              f"to 1 (levels by footprint) or {processor.id}.transfer_function_2d to null")
        lighting = (processor.ambient, processor.diffuse, processor.specular) if frame.lit else None
        key = (processor.transfer_function.for_volume(frame.volume), lighting)
        if self.spread[0] != key:
            self.spread = (key, TransferFunctionSpread(key[0].lut(), lighting))
        stops = processor.early_termination if self.reads_accumulation() else 1.0
        return LodErrors(source, geometry, self.spread[1], processor.sampling_rate,
                         processor.parts[FrontToBack].opacity_exponent(frame), stops, frame.volume.value_range)

    def warn(self, message: str) -> None:
        log.warning(message)
        warnings.warn(message, VGraphWarning, stacklevel=4)

    def plan(self, source, frame: Frame, errors: LodErrors | None) -> FramePlan:
        processor = self.processor
        view_projection = frame.camera.view_projection(frame.size[0] / frame.size[1])
        try:
            plan = plan_frame(source, frame.camera, frame.size, view_projection, self.visible(source, frame),
                              processor.lod_bias, self.budget(), errors, processor.max_error,
                              processor.finest_level)
        except ValueError as error:
            raise VGraphError(f"{processor.id}.ram_budget / {processor.id}.gl_budget: {error}; raise the "
                              f"budgets or use smaller bricks") from None
        asked = min(processor.finest_level, len(source.levels) - 1)
        if plan.floor_level > asked and plan.floor_level != self.warned_level:  # once per change, not per frame
            budget = min(processor.ram_budget, processor.gl_budget)
            message = (f"{processor.type_name} '{processor.id}': the budget ({budget:g} MB) "
                       f"cannot hold the frame's finer bricks; rendering at level {plan.floor_level} "
                       f"or coarser ({len(plan.bricks)} bricks, {plan.bytes / MB:.2f} MB)")
            bound = errors.frame_bound(plan.bricks, frame.size) if errors is not None else None
            if bound is not None and bound > processor.max_error:
                message += f"; its error bound {bound:.3g} is over max_error {processor.max_error:g}"
            self.warn(message)
        self.warned_level = plan.floor_level
        return plan

    def limited(self, source, plan: FramePlan, ctx, load_limit: LoadLimit | None) -> FramePlan:
        """The plan to draw, pinned in the caches: ``plan``, or a coarser one under ``load_limit``."""
        if load_limit is None:
            self.cache.begin_frame(plan.keys())
            return plan
        resident = self.cache.resident(ctx)
        drawn = coarse_first(source, plan, resident, load_limit, self.cache.seconds_per_byte(), self.budget())
        # The plan's resident bricks stay pinned too: drawing a coarser frame must not evict what
        # earlier frames read ahead, or refining would never end (coarse_first checked that both
        # fit the budget).
        self.cache.begin_frame(set(drawn.keys()) | (set(plan.keys()) & resident))
        return drawn

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
        """The uniforms of one brick: where it lies and its level's finite differences."""
        uniforms = brick_uniforms(geometry, key)
        if frame.lit:
            voxel, spacing = level_voxel(geometry, key[0])
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


def skipping_alpha(processor, frame: Frame) -> np.ndarray:
    """The opacity per value (the LUT's entries over the normalised intensity) that dvr's brick
    and block skipping goes by: the 1D TF's LUT alpha, or with a 2D TF its largest alpha over the
    gradient axis (GradientClassification.opacity_by_value) on the LUT's entries, each the larger
    of the two table entries around it, so that it bounds the table's bilinear lookup."""
    lut = processor.parts[TransferFunctionLut].lut
    lut.update(frame.ctx, processor.transfer_function, frame.volume)
    by_value = processor.parts[GradientClassification].opacity_by_value(frame.ctx)
    if by_value is None:
        return lut.alpha
    at = np.linspace(0.0, 1.0, len(lut.alpha)) * (len(by_value) - 1)
    return np.maximum(by_value[np.floor(at).astype(np.int64)], by_value[np.ceil(at).astype(np.int64)])


# Each brick's pass: the GLSL of these parts, in this order (gradients.glsl reads the brick's
# raw_sample), ahead of BRICK_SHADER; Gradients' binding is BrickSampling's (per brick level).
# Mask and CutAway weigh the samples (raycasting/sample_weight.glsl), GradientClassification the
# gradient opacity (after BrickSampling: it reads intensity()); the processor has all three.
BRICK_PARTS = (EntryExit, CameraRays, Sampling, TransferFunctionLut, FrontToBack, IsoSurface, BrickSampling,
               Gradients, Light, Mask, CutAway, GradientClassification)
RESOLVE_PARTS = (EntryExit, CameraRays, Sampling, TransferFunctionLut, Background)
