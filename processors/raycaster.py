"""RayCaster (Inácio 2009 ch. 4.2-4.3): GPU ray casting between the EntryExitPoints images.

Conventions (docs/explanations/ray-casting.md explains each property with pictures):
- The optical model is the CPU reference's (vgraph.numerics.reference_raycast): samples every
  min(spacing) / sampling_rate world units from the entry point, trilinear reconstruction, the TF's
  4096-entry LUT with linear filtering, opacity correction 1 - (1 - a)^(1 / sampling_rate),
  front-to-back compositing with early termination, MIP classified once, Blinn-Phong shading with a
  headlight and central differences (``derivatives = precomputed``: the reference's
  ``Shading(gradients="precomputed")``, voxel gradients computed once per volume and interpolated,
  one fetch a shaded sample; vgraph.gl.raycasting.gradient_volume). The GL image matches the
  reference within the tolerances in docs/explanations/ray-casting.md.
- Built from the shared ray-casting components (vgraph.gl.raycasting.components); its own parts
  are the compositing mode, the interpolation and the derivatives for shading. The fragment shader
  is composed from shaders/raycasting/*.glsl with the defines of the components and of
  shader_defines(); each frame uses the program of its define set from the cache.
- Outputs: `image` RGBA (composited over `background`); `depth` RGBA32F with r = window-space depth
  in [0, 1] of the depth sample (GL depth-buffer convention, 1 where there is none), g = its
  distance in world units from the ray's start on the near plane, b = the number of samples the ray
  evaluated (a debug counter; skipped empty space is not counted), a = 1 where there is a depth
  sample. Which sample gives the depth depends on the compositing mode (the shader parts say).
  The depth output is on demand: drawn only when a target or a connected processor reads it.
- The camera must equal the EntryExitPoints camera (link them): it gives depth and view direction.
- ``light_volume`` (optional): a LightVolume's transmittance T; in dvr and iso each sample's colour
  is multiplied by 1 - shadow_strength * (1 - T) (vgraph.gl.raycasting.light_volume;
  docs/guide/shadows.md). Unconnected, nothing is compiled or bound for it.
- Masks and cut-aways (vgraph.masking; docs/guide/clipping.md): the optional inport `mask`, a
  label or binary volume on its own grid, keeps (or hides) the samples in ``mask_labels``, with a
  hard or smoothed boundary; ``cutaway`` subtracts a box or sphere. Each sample's opacity (dvr,
  first_hit) or intensity (mip, xray) is multiplied by its weight; iso takes no hit at a sample of
  weight below 1/2 (the surface is cut there), also for volumes drawn brick by brick. With no mask and no cut-away the image is the same bit for bit.
- A volume wider than the GL's 3D-texture limit, or a BrickedVolume (an OME-Zarr store) larger
  than its memory budget, is drawn from bricks instead of VolumeSampling, by the method the
  BrickedRayCaster's ``method`` auto chooses (vgraph.bricks.methods): through the PagedSampling
  component in one pass (dvr, iso, mip) or the BrickSampling component, a pass per brick
  (vgraph.bricks.paged_sampling, vgraph.bricks.sampling; docs/explanations/bricked-ray-casting.md),
  as the BrickedRayCaster draws: its properties ``brick_size``, ``lod_bias``, ``max_error``,
  ``ram_budget`` and ``gl_budget`` are this processor's and apply only then. dvr, mip and iso only; ``precomputed``
  derivatives become ``central`` there (a gradient volume of a volume that large is what bricking
  avoids; inside the box both give the same gradient up to 16-bit steps), and so does the
  gradient opacity's gradient and the 2D TF's (the light volume is refused by name); ``volume_precision``
  and ``interpolation`` do not apply (the bricks keep their own texture format, sampled
  trilinearly), nor ``ray_bounds``. The frame context's ``load_limit`` (the GUI's: coarse first;
  vgraph.frame_context) and ``interactive`` (a drag's single-pass frame samples at its coarse
  level's step, vgraph.bricks.coarse_step) go to them, and ``last_frame`` says what such a frame drew.
"""

from __future__ import annotations

from vgraph import Inport, OptionProperty, Outport, VGraphError
from vgraph.bricks.methods import chosen_method
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.ray_requests import RayRequests
from vgraph.bricks.sampling import COMPOSITING as BRICKED_MODES, BrickSampling
from vgraph.frame_context import FrameContext
from vgraph.gl.raycasting.components import (Background, CameraRays, EmptySpace, EntryExit, FrontToBack,
                                             IsoSurface, Sampling, TransferFunctionLut, VolumeSampling,
                                             palette_shading, palette_transfer_function, ray_main_missed)
from vgraph.gl.raycasting.empty_space import occupied_blocks, radii_if_worthwhile
from vgraph.gl.raycasting.gradient_classification import GradientClassification
from vgraph.gl.raycasting.light import Gradients, Light
from vgraph.gl.raycasting.light_volume import LightShadows
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, RaycasterBase
from vgraph.gl.raycasting.shown_volume import ShowsVolume
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.raycasting.textures import needs_bricks
from vgraph.image import Image
from vgraph.volume import Volume

SHADER = "raycasting/raycaster.frag.glsl"
COMPOSITING = ("dvr", "mip", "iso", "first_hit", "xray")
SHADED_MODES = ("dvr", "iso")
SKIPPING = {"dvr": "opacity", "first_hit": "opacity", "iso": "level", "mip": "maximum"}
BRICK_PARTS = (BrickSampling, PagedSampling, RayRequests)  # a frame draws through these or the others
DERIVATIVES = ("none", "forward", "backward", "central", "sobel", "precomputed")


def skip_values(raycaster: "RayCaster", frame):
    """What empty-space skipping needs for the compositing mode (components.EmptySpace)."""
    kind = SKIPPING.get(raycaster.compositing)
    if kind == "maximum":
        return kind, lambda low, high: high
    if kind == "opacity":
        by_value = raycaster.parts[GradientClassification].opacity_by_value(frame.ctx)
        if by_value is not None:  # a 2D TF classifies instead
            return (kind, raycaster.transfer_function_2d), lambda low, high: radii_if_worthwhile(
                occupied_blocks(low, high, by_value))
        lut = raycaster.parts[TransferFunctionLut].lut
        lut.update(frame.ctx, raycaster.transfer_function, frame.volume)  # its alpha, for this volume
        return (kind, raycaster.transfer_function), lambda low, high: radii_if_worthwhile(
            occupied_blocks(low, high, lut.alpha))
    if kind == "level":
        level = raycaster.iso_level
        return (kind, level), lambda low, high: radii_if_worthwhile(high >= level)
    return None


class RayCaster(ShowsVolume, RaycasterBase):
    """Ray casting of a volume between entry and exit points: DVR, MIP, iso-surface and more."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image), Outport("depth", Image, on_demand=True)]
    components = (EntryExit(), CameraRays(), VolumeSampling(), Sampling(), TransferFunctionLut(),
                  FrontToBack(mode="compositing", corrected=("dvr",)), IsoSurface(),
                  GradientClassification(),  # gradient opacity, 2D TFs (dvr, first_hit)
                  Gradients(DERIVATIVES, doc="finite differences of the shading normals; precomputed: "
                                             "central differences at the voxels, computed once per volume "
                                             "(8 bytes a voxel), one fetch a shaded sample (central when "
                                             "drawn brick by brick)"),
                  Light(mode="compositing", shaded_modes=SHADED_MODES), EmptySpace(skip=skip_values),
                  Background(), BrickSampling(mode="compositing", when="only for a volume drawn brick by brick"),
                  PagedSampling(), RayRequests(),  # PagedSampling's properties are BrickSampling's
                  LightShadows(mode="compositing", shadowed_modes=SHADED_MODES),
                  Mask(), CutAway())
    uses_context = ("load_limit", "interactive")  # for the frames drawn brick by brick (module docstring)

    compositing = OptionProperty("dvr", choices=list(COMPOSITING),
                                 doc="dvr, mip, iso (surface at iso_level), first_hit (positions), "
                                     "xray (average intensity)")
    interpolation = OptionProperty("trilinear", choices=["nearest", "trilinear"])
    transfer_function = palette_transfer_function()  # auto, shaded: as vgraph run FILE
    shading = palette_shading()

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = {True: RenderTargets(2), False: RenderTargets(1)}  # by: depth output wanted
        self._drew_bricks = None  # the bricked method of the last frame (vgraph.bricks.methods), None: none

    @property
    def last_frame(self) -> dict:
        """BrickSampling's or PagedSampling's ``last_frame`` when the last frame was drawn from bricks
        (the render process asks whether it was complete), else empty."""
        return self._bricked_part().last_frame if self._drew_bricks else {}

    def frame_summary(self) -> str:
        """A frame drawn from bricks in a line (BrickSampling's or PagedSampling's summary); else nothing."""
        return self._bricked_part().summary() if self._drew_bricks else ""

    def _bricked_part(self):
        return self.parts[PagedSampling if self._drew_bricks == "single_pass" else BrickSampling]

    def shader_defines(self) -> dict[str, bool]:
        """The RayCaster's own defines (docs/explanations/ray-casting.md lists them with the components')."""
        return {f"COMPOSITING_{self.compositing.upper()}": True,
                "INTERPOLATION_NEAREST": self.interpolation == "nearest"}

    def shows_iso_surface(self) -> bool:
        """iso shows the voxels reaching its iso level, the other modes those its TF shows (ShowsVolume)."""
        return self.compositing == "iso"

    # --- evaluation -----------------------------------------------------------------------------
    def process(self, volume: Volume, entry: Image, exit: Image, context: FrameContext,
                light_volume: Volume | None = None, mask: Volume | None = None) -> dict:
        volume.require_samples(f"RayCaster '{self.id}'")
        self.parts[Gradients].check()
        self.parts[LightShadows].attach(volume, light_volume)
        self._drew_bricks = None
        bricks = needs_bricks(volume, self.gl)
        self.parts[Mask].use(mask, volume)
        # the bricks have no gradient volume: gradient opacity from central differences at the sample
        self.parts[GradientClassification].from_samples = bricks
        if bricks:
            self._check_bricked_mode(volume, light_volume)
        # A frame samples one texture (every part but the bricks') or the bricks (module docstring).
        one_texture = [part for part in self.parts if part not in BRICK_PARTS]
        frame = self.frame(volume, entry, exit, parts=[BrickSampling] if bricks else one_texture)
        with_depth = self.wants("depth")
        targets = self._targets[with_depth]
        self._targets[not with_depth].release()  # a scene keeps the images of one kind only
        outputs = dict(zip(("image", "depth"), targets.ensure(frame.ctx, entry.size)))
        if bricks:
            own = Binding({f"COMPOSITING_{self.compositing.upper()}": True})
            method = chosen_method(self, self.parts[BrickSampling].brick_source(volume), None,
                                   volume.source or "the volume")
            self.parts[PagedSampling if method == "single_pass" else BrickSampling].draw_frame(frame, context,
                                                                                                targets, own)
            self._drew_bricks = method
            return outputs
        own = Binding({**self.shader_defines(), "DEPTH_OUTPUT": with_depth})
        self.draw(frame, SHADER, targets, parts=one_texture, own=own,
                  missed=ray_main_missed(self.background, with_depth))
        return outputs

    def _check_bricked_mode(self, volume: Volume, light_volume: Volume | None) -> None:
        if light_volume is not None:
            raise VGraphError(f"{self.id}.light_volume: {volume.source or 'the volume'} is drawn brick by "
                              f"brick ({' x '.join(map(str, volume.dims))} voxels do not fit one GL texture "
                              f"or the memory budget), which draws no shadows; disconnect light_volume")
        if self.compositing not in BRICKED_MODES:
            raise VGraphError(f"{self.id}.compositing: {volume.source or 'the volume'} is drawn brick by "
                              f"brick ({' x '.join(map(str, volume.dims))} voxels do not fit one GL texture "
                              f"or the memory budget), which offers {', '.join(BRICKED_MODES)}, not "
                              f"{self.compositing}")
