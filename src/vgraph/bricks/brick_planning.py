"""BrickPlanning: what a frame of bricks draws, the part both ways of drawing one share: the
volume's pyramid, its bricks' cache under the memory budgets, the levels of detail and their error
bounds, and the frame's plan (under a load limit, the coarser plan drawn first). BrickSampling
(vgraph.bricks.sampling: a pass per brick) is built on it, and PagedSampling
(vgraph.bricks.paged_sampling: one pass) plans its frames through the processor's BrickSampling.

Conventions (docs/explanations/bricked-ray-casting.md explains each with the numbers):
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
- ``load_limit`` of the frame context (vgraph.frame_context; only the GUI's render process gives
  one, scripts and ``vgraph run`` none, so they always draw the planned frame): a frame whose
  missing bricks cannot be read within it is drawn coarser (selection.coarse_first, ``limited``).
- dvr's skipping (of bricks here, of blocks inside them when drawn) goes by the opacity per value
  of the transfer function (``skipping_alpha``).
"""

from __future__ import annotations

import logging
import warnings
import weakref
from typing import Annotated

import numpy as np
from pydantic import AfterValidator, Field, StrictInt

from vgraph import derived
from vgraph.bricks.cache import MB, BrickCache, LoadLimit
from vgraph.bricks.lod_error import LodErrors, TransferFunctionSpread
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.selection import FramePlan, coarse_first, plan_frame, visible_bricks
from vgraph.errors import VGraphError, VGraphWarning
from vgraph.gl.raycasting.components import FrontToBack, TransferFunctionLut
from vgraph.gl.raycasting.gradient_classification import GradientClassification
from vgraph.gl.raycasting.raycaster_base import Component, Frame
from vgraph.gl_context import release_quietly
from vgraph.properties import FloatProperty, IntProperty
from vgraph.volume import Volume

log = logging.getLogger(__name__)


def _power_of_two(value: int) -> int:
    if value & (value - 1):
        raise ValueError(f"must be a power of two (8, 16, 32, ...), got {value}")
    return value


class BrickSizeProperty(IntProperty):
    """Voxels per brick edge: a power of two from 8 (a smaller brick is mostly halo)."""

    def _value_type(self):
        return Annotated[StrictInt, Field(ge=self.min, le=self.max), AfterValidator(_power_of_two)]


class BrickPlanning(Component):
    """The volume's bricks, their cache under memory budgets and the frame's plan (module
    docstring): the base of BrickSampling, whose properties these are. ``mode``: the processor's
    option naming the compositing mode (dvr, mip, iso); ``when``: added to the properties' docs
    where they apply only to some frames (the RayCaster's)."""

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
        self.cache = BrickCache(processor.ram_budget, processor.gl_budget)
        # Brick textures go with the processor (moderngl does not release GL objects on garbage
        # collection).
        weakref.finalize(processor, release_quietly, self.cache.gl)
        weakref.finalize(processor, release_quietly, self.cache.block_textures)
        self.pyramid = None  # (weakref to the volume, brick size, ArrayPyramid)
        self.warned_level = 0  # the budget's level last warned about (0: none)
        self.spread = (None, None)  # (the resolved TF and lighting, its TransferFunctionSpread)
        self.warned_mode = None  # the compositing mode last warned about max_error not applying to
        self.pinned_plan = None  # (the cache's pinned set, the KeyArray of the plan it pinned) (pin)

    @property
    def compositing(self) -> str:
        return getattr(self.processor, self.mode)

    def reads_accumulation(self) -> bool:
        """dvr with early termination: each brick continues the sum of the bricks in front."""
        return self.compositing == "dvr" and self.processor.early_termination < 1.0

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
        iso_level = processor.iso_level
        # level -> the bricks, kept per source while the rule is the same (a new camera keeps it)
        rule = (mode, None if alpha is None else alpha.tobytes(), float(iso_level), tuple(value_range))
        kept = derived.value(source, "visible bricks", dict, params=rule)

        def visible(level: int) -> np.ndarray:
            if level not in kept:
                kept[level] = visible_bricks(source, level, mode, alpha, iso_level, value_range)
                kept[level].setflags(write=False)
            return kept[level]
        return visible

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
                       f"or coarser ({len(plan)} bricks, {plan.bytes / MB:.2f} MB)")
            bound = errors.frame_bound(plan.bricks, frame.size) if errors is not None else None
            if bound is not None and bound > processor.max_error:
                message += f"; its error bound {bound:.3g} is over max_error {processor.max_error:g}"
            self.warn(message)
        self.warned_level = plan.floor_level
        return plan

    def pin(self, plan: FramePlan) -> None:
        """Pin the plan's bricks in the cache; nothing to do where the cache's pinned set is still
        the one this pinned for a plan of the same bricks (a frame of thousands makes no set)."""
        cache, last = self.cache, self.pinned_plan
        if last is not None and cache.pinned is last[0] and last[1] == plan.key_set():
            return
        cache.begin_frame(plan.keys())
        self.pinned_plan = (cache.pinned, plan.key_set())

    def limited(self, source, plan: FramePlan, ctx, load_limit: LoadLimit | None) -> FramePlan:
        """The plan to draw, pinned in the caches: ``plan``, or a coarser one under ``load_limit``."""
        if load_limit is None:
            self.pin(plan)
            return plan
        resident = self.cache.resident(ctx)
        drawn = coarse_first(source, plan, resident, load_limit, self.cache.seconds_per_byte(), self.budget())
        # The plan's resident bricks stay pinned too: drawing a coarser frame must not evict what
        # earlier frames read ahead, or refining would never end (coarse_first checked that both
        # fit the budget).
        self.cache.begin_frame(set(drawn.keys()) | (set(plan.keys()) & resident))
        return drawn


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
