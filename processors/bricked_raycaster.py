"""BrickedRayCaster (issue #14, part 4): ray casting of a volume brick by brick, for volumes larger
than memory (a BrickedVolume's pyramid on disk) or than one GL texture.

Conventions (docs/explanations/bricked-ray-casting.md explains each with the numbers):
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
- Inside a brick, blocks of 8^3 voxels that cannot contribute are jumped over
  (``empty_space_skipping``; the brick's block ranges go up with it, cache.block_ranges_of).
- The volume's pyramid: ``volume.bricks`` (BrickedVolume), else an ArrayPyramid of the in-memory
  volume with ``brick_size`` bricks (built once per volume and brick size). An extreme box (1e14
  or 1e-12 across, far from the origin) is drawn in its normalised frame as the RayCaster draws
  one: the pyramid is the framed copy's (a BrickedVolume regridded, nothing read).
- Per frame the bricks are chosen (selection.plan_frame): in view, not empty under the TF (or
  below the iso level), at the level their projected voxel size asks (``lod_bias``), raised until
  the frame's bricks fit min(ram_budget, gl_budget); a raised level is warned about.
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
from pydantic import AfterValidator, Field, StrictInt

import numpy as np

from vgraph import BoolProperty, FloatProperty, Inport, IntProperty, OptionProperty, Outport, VGraphError
from vgraph.bricks.cache import MB, BrickCache, LoadLimit
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.selection import BrickGeometry, FramePlan, LeafPass, coarse_first, plan_frame, visible_bricks
from vgraph.bricks.targets import Accumulation, brick_uniforms, level_voxel
from vgraph.errors import VGraphWarning
from vgraph.frame_context import FrameContext
from vgraph.gl_context import release_quietly
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.components import (Background, CameraRays, EntryExit, IsoSurface, Sampling,
                                             TransferFunctionLut, palette_shading, palette_transfer_function)
from vgraph.gl.raycasting.light import Light
from vgraph.gl.raycasting.raycaster_base import Binding, Pass, RaycasterBase
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.raycasting.textures import linear_sampler
from vgraph.gl.shaders import programs
from vgraph.image import Image
from vgraph.shown_content import voxels_by_compositing
from vgraph.volume import Volume

BRICK_SHADER = "bricks/brick.frag.glsl"
RESOLVE_SHADER = "bricks/resolve.frag.glsl"
COPY_SHADER = "bricks/copy.frag.glsl"
COMPOSITING = ("dvr", "mip", "iso")
SHADED_MODES = ("dvr", "iso")
DERIVATIVES = ("central", "forward", "backward", "sobel")  # each reads at most one voxel away
DERIVATIVE_SPACINGS = {"forward": 1.0, "backward": 1.0, "central": 2.0, "sobel": 32.0}
log = logging.getLogger(__name__)


def _power_of_two(value: int) -> int:
    if value & (value - 1):
        raise ValueError(f"must be a power of two (8, 16, 32, ...), got {value}")
    return value


class BrickSizeProperty(IntProperty):
    """Voxels per brick edge: a power of two from 8 (a smaller brick is mostly halo)."""

    def _value_type(self):
        return Annotated[StrictInt, Field(ge=self.min, le=self.max), AfterValidator(_power_of_two)]


class BrickedRayCaster(RaycasterBase):
    """Ray casting brick by brick, front to back, with levels of detail and memory budgets."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image), Outport("depth", Image)]
    components = (EntryExit(), CameraRays(), Sampling(), TransferFunctionLut(), IsoSurface(),
                  Light(mode="compositing", shaded_modes=SHADED_MODES), Background())
    uses_context = ("load_limit", "leaf")  # module docstring

    compositing = OptionProperty("dvr", choices=list(COMPOSITING), doc="dvr, mip, iso (surface at iso_level)")
    transfer_function = palette_transfer_function()  # auto, shaded: as the RayCaster
    shading = palette_shading()
    derivatives = OptionProperty("central", choices=list(DERIVATIVES), doc="finite differences of the shading normals")
    brick_size = BrickSizeProperty(64, min=8, max=1024,
                                   doc="voxels per brick edge for in-memory volumes (a BrickedVolume keeps its own)")
    early_termination = FloatProperty(1.0, min=0.01, max=1.0,
                                      doc="dvr: stop a ray once its opacity reaches this (as the RayCaster's); "
                                          "below 1 each brick reads the accumulation: two passes a brick")
    empty_space_skipping = BoolProperty(True, doc="inside a brick, skip blocks of 8^3 voxels that cannot "
                                                  "contribute (same image, faster); empty bricks are always skipped")
    lod_bias = FloatProperty(0.0, min=-16.0, max=16.0,
                             doc="levels coarser (+) or finer (-) than voxels of about a pixel")
    ram_budget = FloatProperty(1024.0, min=0.01, max=1e7, doc="MB of bricks kept in memory")
    gl_budget = FloatProperty(512.0, min=0.01, max=1e7, doc="MB of brick textures kept on the GL")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = RenderTargets(2)
        self._accumulation = Accumulation()
        self.cache = BrickCache(self.ram_budget, self.gl_budget)
        # Brick textures and accumulation targets go with the processor (moderngl does not
        # release GL objects on garbage collection).
        weakref.finalize(self, release_quietly, self.cache.gl)
        weakref.finalize(self, release_quietly, self._accumulation.gl)
        weakref.finalize(self, release_quietly, self.cache.block_textures)
        self._pyramid = None  # (weakref to the volume, brick size, ArrayPyramid)
        self._alpha_count = {}  # "texture": LUT entries with opacity, cumulated; "key": its alpha
        self.last_frame: dict = {}
        self._warned_level = 0  # the budget's level last warned about (0: none)

    def shown_content(self) -> list:
        """The voxels its transfer function (or, for iso, its iso level) shows (vgraph.blank_causes)."""
        volume = self.inputs.get("volume")
        return [voxels_by_compositing("volume", volume, self)] if volume is not None else []

    # --- shader ---------------------------------------------------------------------------------
    def reads_accumulation(self) -> bool:
        """dvr with early termination: each brick continues the sum of the bricks in front."""
        return self.compositing == "dvr" and self.early_termination < 1.0

    def shader_defines(self) -> dict[str, bool]:
        mode = self.compositing
        terminating = self.reads_accumulation()
        defines = {f"COMPOSITING_{mode.upper()}": True,
                   "OPACITY_CORRECTION": mode == "dvr" and self.sampling_rate != 1.0,
                   "READ_ACCUMULATION": terminating, "EARLY_TERMINATION": terminating,
                   "SKIP_EMPTY_BLOCKS": self.empty_space_skipping}
        if self.shaded():
            defines[f"GRADIENT_{self.derivatives.upper()}"] = True
        return defines

    # --- the pyramid ----------------------------------------------------------------------------
    def brick_source(self, volume: Volume):
        """The volume's BrickSource: its own (BrickedVolume), else an ArrayPyramid kept per volume."""
        own = getattr(volume, "bricks", None)
        if own is not None:
            return own
        cached = self._pyramid
        if cached is None or cached[0]() is not volume or cached[1] != self.brick_size:
            pyramid = ArrayPyramid.from_volume(volume, (self.brick_size,) * 3)
            self._pyramid = cached = (weakref.ref(volume), self.brick_size, pyramid)
        return cached[2]

    def visible(self, source, frame):
        """visible(level) -> bool per brick for this frame's mode (selection.visible_bricks)."""
        mode = self.compositing
        alpha = None
        if mode == "dvr":
            lut = self.parts[TransferFunctionLut].lut
            lut.update(frame.ctx, self.transfer_function, frame.volume)
            alpha = lut.alpha
        value_range = frame.volume.value_range
        return lambda level: visible_bricks(source, level, mode, alpha, self.iso_level, value_range)

    # --- evaluation -----------------------------------------------------------------------------
    def process(self, volume: Volume, entry: Image, exit: Image, context: FrameContext) -> dict:
        volume.require_samples(f"BrickedRayCaster '{self.id}'")
        started = time.perf_counter()
        frame = self.frame(volume, entry, exit)
        source = self.brick_source(frame.volume)  # in the frame of the camera (an extreme box's)
        self.cache.use_source(source, frame.volume.value_range)
        self.cache.set_budgets(self.ram_budget, self.gl_budget)
        geometry = BrickGeometry(source)
        plan = self.plan(source, geometry, frame)
        read_before, seconds_before = self.cache.stats["bricks_read"], self.cache.stats["read_seconds"]
        drawn = self.limited(source, plan, frame.ctx, context.load_limit)
        accumulation = self._accumulation.ensure(frame.ctx, frame.size)
        if context.leaf is None:
            self.draw_bricks(frame, geometry, drawn.bricks, accumulation)
        else:
            drawn = self.leaf_pass(frame, geometry, plan, accumulation, context.leaf)
        image, depth = self._targets.ensure(frame.ctx, frame.size)
        self.resolve(frame, accumulation)
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
                           "bricks_read": self.cache.stats["bricks_read"] - read_before,
                           "seconds": time.perf_counter() - started}
        return {"image": image, "depth": depth}

    def leaf_pass(self, frame, geometry, plan, accumulation, leaf: LeafPass):
        """The leaves split's part of the frame (selection.LeafPass): draw its bricks and read the
        accumulation back into ``leaf``, or write the composited accumulation for the resolve pass."""
        leaf.plan = plan
        if leaf.accumulated is not None:
            accumulation.clear()
            for texture, array in zip(accumulation.textures, leaf.accumulated):
                texture.write(np.ascontiguousarray(array, dtype=np.float32).tobytes())
            return FramePlan([], plan.floor_level, 0)
        self.draw_bricks(frame, geometry, leaf.bricks, accumulation)
        height, width = frame.size[1], frame.size[0]
        leaf.partial = tuple(np.frombuffer(texture.read(), dtype=np.float32).reshape(height, width, 4)
                             for texture in accumulation.textures)
        return FramePlan(list(leaf.bricks), plan.floor_level, 0)

    def limited(self, source, plan, ctx, load_limit: LoadLimit | None):
        """The plan to draw, pinned in the caches: ``plan``, or a coarser one under ``load_limit``."""
        if load_limit is None:
            drawn = plan
            self.cache.begin_frame(plan.keys())
        else:
            resident = self.cache.resident(ctx)
            budget = int(min(self.ram_budget, self.gl_budget) * MB)
            drawn = coarse_first(source, plan, resident, load_limit, self.cache.seconds_per_byte(), budget)
            # The plan's resident bricks stay pinned too: drawing a coarser frame must not evict
            # what earlier frames read ahead, or refining would never end (coarse_first checked
            # that both fit the budget).
            self.cache.begin_frame(set(drawn.keys()) | (set(plan.keys()) & resident))
        return drawn

    def plan(self, source, geometry, frame):
        budget = int(min(self.ram_budget, self.gl_budget) * MB)
        view_projection = frame.camera.view_projection(frame.size[0] / frame.size[1])
        try:
            plan = plan_frame(source, frame.camera, frame.size, view_projection,
                              self.visible(source, frame), self.lod_bias, budget)
        except ValueError as error:
            raise VGraphError(f"{self.id}.ram_budget / {self.id}.gl_budget: {error}; raise the "
                              f"budgets or use smaller bricks") from None
        if plan.floor_level > 0 and plan.floor_level != self._warned_level:  # once per change, not per frame
            message = (f"BrickedRayCaster '{self.id}': the budget ({min(self.ram_budget, self.gl_budget):g} MB) "
                       f"cannot hold the frame's finer bricks; rendering at level {plan.floor_level} "
                       f"or coarser ({len(plan.bricks)} bricks, {plan.bytes / MB:.2f} MB)")
            log.warning(message)
            warnings.warn(message, VGraphWarning, stacklevel=2)
        self._warned_level = plan.floor_level
        return plan

    def base_binding(self, frame) -> Binding:
        """The components' bindings, the same for every brick of the frame."""
        binding = Binding(defines=self.shader_defines())
        for component in (EntryExit, CameraRays, Sampling, TransferFunctionLut, IsoSurface, Light):
            binding = binding.merge(self.parts[component].bind(frame))
        return binding

    def draw_bricks(self, frame, geometry, bricks, accumulation) -> None:
        """One pass per brick, front to back, into the accumulation (module docstring)."""
        ctx = frame.ctx
        binding = self.base_binding(frame)
        program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, BRICK_SHADER, binding.defines, processor=self.id)
        self.passes.append(Pass(BRICK_SHADER, binding.defines))
        scale, offset = self.cache.format.scale, self.cache.format.offset
        uniforms = {**binding.uniforms, "intensity_scale": float(scale), "intensity_offset": float(offset),
                    "opacity_exponent": 1.0 / self.sampling_rate}  # (the RayCaster's FrontToBack sets it)
        if self.compositing == "dvr":
            uniforms["early_termination"] = self.early_termination
        reading = self.reads_accumulation()
        target = accumulation.scratch if reading else accumulation
        textures = dict(binding.textures)
        if self.compositing == "dvr" and self.empty_space_skipping:
            textures["alpha_count"] = self._alpha_count_texture(ctx)
        if reading:
            textures.update(front_sum=accumulation.textures[0], front_first=accumulation.textures[1])
        # The scissor is state of a framebuffer (moderngl: ctx.scissor is the bound one's): set
        # on the targets' own, so no other target keeps a brick's rectangle.
        framebuffers = (accumulation.framebuffer, accumulation.scratch.framebuffer)
        for framebuffer in framebuffers:
            framebuffer.scissor = None
        accumulation.clear()
        if reading:
            copy = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, COPY_SHADER, {}, processor=self.id)
        else:
            self._set_blending(ctx)
        try:
            for number, (key, rect) in enumerate(bricks):
                self.report_progress(number, len(bricks), "drawing bricks")  # reading those not in memory
                target.framebuffer.scissor = rect
                # The frame's uniforms once: a program keeps its uniform values between passes.
                fullscreen_pass(ctx, program, target, {**textures, "volume": self.cache.texture(ctx, key),
                                                       "blocks": self.cache.blocks(ctx, key)},
                                {**(uniforms if number == 0 else {}), **brick_uniforms(geometry, key),
                                 **self._gradient_uniforms(geometry, key)},
                                samplers={"volume": linear_sampler(ctx)})
                if reading:
                    self._copy_back(ctx, copy, accumulation, rect, first=number == 0)
        finally:
            for framebuffer in framebuffers:
                framebuffer.scissor = None
            ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
            ctx.blend_func = moderngl.DEFAULT_BLENDING

    def _alpha_count_texture(self, ctx):
        """4097 x 1 R32F: entry i = the LUT entries below i with opacity > 0 (brick_blocks.glsl)."""
        alpha = self.parts[TransferFunctionLut].lut.alpha
        texture = self._alpha_count.get("texture")
        if texture is None or texture.ctx is not ctx:
            release_quietly(self._alpha_count)
            texture = self._alpha_count["texture"] = ctx.texture((len(alpha) + 1, 1), 1, dtype="f4")
            self._alpha_count["key"] = None
        if self._alpha_count.get("key") is None or not np.array_equal(self._alpha_count["key"], alpha):
            counts = np.concatenate([[0.0], np.cumsum(alpha > 0.0)]).astype(np.float32)
            texture.write(counts.tobytes())
            self._alpha_count["key"] = alpha.copy()
        return texture

    def _copy_back(self, ctx, program, accumulation, rect, first: bool) -> None:
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

    def _set_blending(self, ctx) -> None:
        if self.compositing == "mip":
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
        else:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.ONE_MINUS_DST_ALPHA, moderngl.ONE  # "under"

    def _gradient_uniforms(self, geometry, key) -> dict:
        if not self.shaded():
            return {}
        voxel, spacing = level_voxel(geometry, key[0])
        spacings = DERIVATIVE_SPACINGS[self.derivatives]
        return {"voxel_step": vec(voxel),
                "gradient_scale": vec(self.cache.format.scale / (spacings * spacing))}

    def resolve(self, frame, accumulation) -> None:
        """The accumulation -> image and depth (bricks/resolve.frag.glsl)."""
        parts = (EntryExit, CameraRays, Sampling, TransferFunctionLut, Background)
        binding = Binding(defines={f"COMPOSITING_{self.compositing.upper()}": True})
        for component in parts:
            binding = binding.merge(self.parts[component].bind(frame))
        program = programs.program(frame.ctx, FULLSCREEN_VERTEX_SHADER, RESOLVE_SHADER, binding.defines,
                                   processor=self.id)
        self.passes.append(Pass(RESOLVE_SHADER, binding.defines))
        textures = {**binding.textures, "accumulated_sum": accumulation.textures[0],
                    "accumulated_first": accumulation.textures[1]}
        fullscreen_pass(frame.ctx, program, self._targets, textures, binding.uniforms, samplers=binding.samplers,
                        optional={"opacity_exponent", "step_length"})
