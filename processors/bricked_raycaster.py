"""BrickedRayCaster (issue #14, part 4): ray casting of a volume brick by brick, for volumes larger
than memory (a BrickedVolume's pyramid on disk) or than one GL texture.

Conventions (docs/explanations/bricked-ray-casting.md explains each with the numbers):
- Built from the shared ray-casting components (vgraph.gl.raycasting.raycaster_base): the volume
  is sampled by BrickSampling (vgraph.bricks.sampling: the pyramid, the brick cache under
  ``ram_budget`` and ``gl_budget``, the frame's plan with its levels of detail (by footprint,
  ``lod_bias``, and for dvr by an error bound under the TF, ``max_error``), the per-brick
  passes and the resolve pass, ``last_frame``), which the RayCaster also draws through when one
  texture cannot hold its volume. Opacity correction and ``early_termination`` are FrontToBack's
  (below 1, dvr: each brick reads the accumulation, two passes a brick), the shading normals
  Gradients' (forward, backward, central or sobel, each reading at most one voxel away: the halo).
- Its own part: the compositing mode (dvr, mip, iso; the define COMPOSITING_* of the brick and
  resolve shaders), ``empty_space_skipping`` inside a brick and ``method``: ``passes`` draws
  through BrickSampling, ``single_pass`` through PagedSampling (vgraph.bricks.paged_sampling,
  issue #33): the same plan, the bricks in an atlas read through a page table in one pass of the
  RayCaster's shader, early termination across bricks; under a load limit its rays ask for the
  missing bricks they reach (RayRequests, vgraph.bricks.ray_requests), which are read after the
  frame. ``auto`` (the default) takes per frame the one vgraph.bricks.methods chooses: the single
  pass for dvr, iso and mip, where it measured faster, passes for the leaves split.
- Masks and cut-aways (vgraph.masking; docs/guide/clipping.md) as the RayCaster's: the optional
  inport ``mask`` and ``mask_labels``, ``mask_mode``, ``mask_boundary``, ``mask_smoothing``,
  ``cutaway*`` (the Mask and CutAway components) weigh each sample in every mode and method.
- ``gradient_opacity`` (dvr; vgraph.gl.raycasting.gradient_classification, docs/guide/
  gradient-classification.md): the gradient from central differences at the sample inside the
  brick (no gradient volume), scaled by the volume's largest voxel gradient (a store's from one pass
  over its level 0, once per store); ``transfer_function_2d`` too, the bricks and blocks
  skipped by its largest opacity per value (``max_error`` < 1 with it is refused by name).
- The frame context (vgraph.frame_context; not properties) gives BrickSampling the ``load_limit``
  (coarse first in the GUI) and the ``leaf`` (the leaves split's run of bricks,
  vgraph.distributed.leaves), and PagedSampling ``interactive`` (a drag's frame samples at the step
  of the finest level it draws, vgraph.bricks.coarse_step).
"""

from __future__ import annotations

from vgraph import BoolProperty, FloatProperty, Inport, OptionProperty, Outport
from vgraph.bricks.cache import BrickCache
from vgraph.bricks.methods import METHODS, chosen_method
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.ray_requests import RayRequests
from vgraph.bricks.sampling import COMPOSITING, BrickSampling
from vgraph.frame_context import FrameContext
from vgraph.gl.raycasting.components import (Background, CameraRays, EntryExit, FrontToBack, IsoSurface, Sampling,
                                             TransferFunctionLut, palette_shading, palette_transfer_function)
from vgraph.gl.raycasting.gradient_classification import GradientClassification
from vgraph.gl.raycasting.light import Gradients, Light
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, RaycasterBase
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.image import Image
from vgraph.shown_content import voxels_by_compositing
from vgraph.volume import Volume

SHADED_MODES = ("dvr", "iso")
DERIVATIVES = ("central", "forward", "backward", "sobel")  # each reads at most one voxel away


class BrickedRayCaster(RaycasterBase):
    """Ray casting brick by brick, front to back, with levels of detail and memory budgets."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]
    # depth on demand, as every ray caster's: only a frame whose depth is read writes it (on llvmpipe
    # the second image costs a bonsai iso frame at 256^2 about 3 ms of ~24)
    outports = [Outport("image", Image), Outport("depth", Image, on_demand=True)]
    components = (EntryExit(), CameraRays(), Sampling(), TransferFunctionLut(),
                  FrontToBack(mode="compositing", corrected=("dvr",), early_termination=1.0), IsoSurface(),
                  BrickSampling(mode="compositing"), Gradients(DERIVATIVES),
                  Light(mode="compositing", shaded_modes=SHADED_MODES), Background(), PagedSampling(),
                  RayRequests(), Mask(), CutAway(),
                  GradientClassification(modes=("dvr",), from_samples=True))  # gradient opacity, dvr
    # BrickSampling's (vgraph.bricks.sampling); interactive: PagedSampling's step (vgraph.bricks.coarse_step)
    uses_context = ("load_limit", "leaf", "interactive")

    compositing = OptionProperty("dvr", choices=list(COMPOSITING), doc="dvr, mip, iso (surface at iso_level)")
    transfer_function = palette_transfer_function()  # auto, shaded: as the RayCaster
    shading = palette_shading()
    early_termination = FloatProperty(1.0, min=0.01, max=1.0,  # FrontToBack's, with what it costs here
                                      doc="dvr: stop a ray once its opacity reaches this (as the RayCaster's); "
                                          "below 1 each brick reads the accumulation: two passes a brick")
    method = OptionProperty("auto", choices=list(METHODS),
                            doc="passes: a fullscreen pass per brick, blended; single_pass: one pass whose "
                                "rays walk a page table of the bricks in an atlas (gl_budget MB), with early "
                                "termination across bricks (issue #33); auto: single_pass for dvr, iso and mip "
                                "(faster there), passes for the leaves split")
    empty_space_skipping = BoolProperty(True, doc="inside a brick, skip blocks of 8^3 voxels that cannot "
                                                  "contribute (same image, faster); empty bricks are always skipped")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = {True: RenderTargets(2), False: RenderTargets(1)}  # by: depth output wanted
        self.drawn_method = "passes"  # the method of the last frame (``method`` auto chooses per frame)

    @property
    def bricks(self) -> BrickSampling:
        return self.parts[BrickSampling]

    @property
    def cache(self) -> BrickCache:
        """The bricks in memory and on the GL, with their statistics (BrickSampling's)."""
        return self.bricks.cache

    @property
    def last_frame(self) -> dict:
        """What the last frame drew (BrickSampling.draw_frame, or PagedSampling's with
        ``method`` single_pass): bricks, levels, whether complete."""
        return self.parts[PagedSampling].last_frame if self.drawn_method == "single_pass" else self.bricks.last_frame

    def frame_summary(self) -> str:
        return self.parts[PagedSampling].summary() if self.drawn_method == "single_pass" else self.bricks.summary()

    def brick_source(self, volume: Volume):
        """The volume's pyramid of bricks as this processor draws it (BrickSampling.brick_source)."""
        return self.bricks.brick_source(volume)

    def shown_content(self) -> list:
        """The voxels its transfer function (or, for iso, its iso level) shows (vgraph.blank_causes)."""
        volume = self.inputs.get("volume")
        return [voxels_by_compositing("volume", volume, self)] if volume is not None else []

    def process(self, volume: Volume, entry: Image, exit: Image, context: FrameContext,
                mask: Volume | None = None) -> dict:
        volume.require_samples(f"BrickedRayCaster '{self.id}'")
        self.parts[Mask].use(mask, volume)
        frame = self.frame(volume, entry, exit)
        own = Binding(defines={f"COMPOSITING_{self.compositing.upper()}": True})
        with_depth = self.wants("depth")
        targets = self._targets[with_depth]
        self._targets[not with_depth].release()  # a scene keeps the images of one kind only
        outputs = dict(zip(("image", "depth"), targets.ensure(frame.ctx, frame.size)))
        self.drawn_method = chosen_method(self, self.brick_source(volume), context.leaf,
                                          volume.source or "the volume")
        if self.drawn_method == "single_pass":
            self.parts[PagedSampling].draw_frame(frame, context, targets, own)
        else:
            self.bricks.draw_frame(frame, context, targets, own)
        return outputs
