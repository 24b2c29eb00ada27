"""CurvatureVolumeRaycaster (Cabral 2010 sec. 5.5): direct volume rendering coloured by curvature.

Conventions (docs/explanations/curvature.md explains each property):
- Opacity comes from the scalar transfer function of each sample's normalised intensity (only its
  alpha is used; times ``gradient_opacity``, or the alpha of ``transfer_function_2d`` instead, as
  the RayCaster's, vgraph.gl.raycasting.gradient_classification, for sample volumes only),
  corrected for the sampling rate as in the RayCaster; colour from the normalised
  curvature of the level set through the sample (the CurvatureRaycaster's measures,
  normalisations and colour maps), `undefined_color` where the curvature is undefined, optionally
  Blinn-Phong shaded. Front-to-back compositing with early termination (the RayCaster's dvr).
- One inport `volume` of the kind the derivative mode needs (samples for forward, central,
  filtered; B-spline coefficients for tricubic, tricubic_fast), as the CurvatureRaycaster.
- Linear normalisation needs kmin, kmax: a first pass (RANGE_PASS) marches the same rays and keeps
  per pixel the range of the measure over the samples that contribute (opacity > 0, curvature
  defined, before early termination), reduced on the GPU (RangeReduction); the second pass
  composites. So linear normalisation costs about twice exponential.
- Outputs: `image` RGBA32F composited over `background`; `depth` as the RayCaster's (the first
  sample with opacity > 0).
- The optional inport `mask` and the cut-away region weigh each sample's opacity as in the
  RayCaster's dvr (vgraph.masking; the range pass too, so only kept samples set kmin, kmax).
"""

from __future__ import annotations

from vgraph import Inport, OptionProperty, Outport, TransferFunctionProperty, VGraphError
from vgraph.gl.curvature import (CURVATURES, CurvatureColoring, CurvatureField, RangeReduction, measure_defines,
                                 measure_uniforms)
from vgraph.gl.raycasting.components import (Background, CameraRays, EmptySpace, EntryExit, FrontToBack, Sampling,
                                             TransferFunctionLut, VolumeSampling)
from vgraph.gl.raycasting.empty_space import occupied_blocks, radii_if_worthwhile
from vgraph.gl.raycasting.gradient_classification import GradientClassification
from vgraph.gl.raycasting.light import Light
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, RaycasterBase
from vgraph.gl.raycasting.shown_volume import ShowsVolume
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.image import Image
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

SHADER = "curvature/curvature_volume_raycaster.frag.glsl"


def skip_values(raycaster, frame):
    """Blocks where the TF (or the 2D TF, at some gradient) has opacity (components.EmptySpace;
    "opacity": empty blocks contribute nothing, so ray bounds apply too)."""
    by_value = raycaster.parts[GradientClassification].opacity_by_value(frame.ctx)
    if by_value is not None:
        return (("opacity", raycaster.transfer_function_2d),
                lambda low, high: radii_if_worthwhile(occupied_blocks(low, high, by_value)))
    lut = raycaster.parts[TransferFunctionLut].lut
    return (("opacity", raycaster.transfer_function),
            lambda low, high: radii_if_worthwhile(occupied_blocks(low, high, lut.alpha)))


RANGE_PARTS = (EntryExit(), CameraRays(), VolumeSampling(), Sampling(), FrontToBack(), TransferFunctionLut(),
               GradientClassification(mode=None),  # gradient opacity, the 2D TF's alpha; samples only
               CurvatureField(), CurvatureColoring(), EmptySpace(skip=skip_values), Background(), Mask(),
               CutAway())

# Two translucent shells, at the surface of every FunctionSelector volume (0.5) and inside it;
# only the opacity is used.
DEFAULT_TRANSFER_FUNCTION = TransferFunction(points=[
    (0.0, 1.0, 1.0, 1.0, 0.0), (0.47, 1.0, 1.0, 1.0, 0.0), (0.5, 1.0, 1.0, 1.0, 0.25),
    (0.53, 1.0, 1.0, 1.0, 0.0), (0.54, 1.0, 1.0, 1.0, 0.0), (0.56, 1.0, 1.0, 1.0, 0.6),
    (0.58, 1.0, 1.0, 1.0, 0.0), (1.0, 1.0, 1.0, 1.0, 0.0)])


class CurvatureVolumeRaycaster(ShowsVolume, RaycasterBase):
    """Direct volume rendering: opacity from the transfer function, colour from curvature."""

    category = "Volume rendering"
    # Curvatures (1/length), positions and the attenuation are world lengths: extreme boxes are
    # refused by name rather than drawn in their normalised frame (components docstring).
    frames_extreme_boxes = False
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image), Outport("depth", Image)]
    components = RANGE_PARTS + (Light(),)

    transfer_function = TransferFunctionProperty(
        DEFAULT_TRANSFER_FUNCTION, doc="opacity over normalised intensity (its colours are unused)")
    curvature = OptionProperty("mean", choices=list(CURVATURES), doc="the measure that gives the colour")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = RenderTargets(2)  # image (or the range in the first pass), depth
        self._reduction = RangeReduction()

    def process(self, volume: Volume, entry: Image, exit: Image, mask: Volume | None = None) -> dict:
        self.parts[Mask].use(mask, volume)
        if self.parts[GradientClassification].is_on() and self.derivatives.startswith("tricubic"):
            raise VGraphError(f"{self.id}.derivatives: gradient_opacity and transfer_function_2d read "
                              f"the gradients of voxel samples, and {self.derivatives} takes B-spline "
                              f"coefficients; use forward, central or filtered (without the "
                              f"CubicSplineProcessor), or set both to null")
        frame = self.frame(volume, entry, exit)
        image, depth = self._targets.ensure(frame.ctx, entry.size)
        own = Binding(defines={"RANGE_PASS": False})
        if self.normalization == "linear":
            # The range of the measure over the contributing samples first (module docstring).
            self.draw(frame, SHADER, self._targets, RANGE_PARTS, Binding(defines={"RANGE_PASS": True}))
            own.textures["curvature_range"] = self._reduction.run(
                frame.ctx, image, measure_defines(self.curvature), self.id, measure_uniforms(volume),
                pairs=True)
        self.draw(frame, SHADER, self._targets, own=own)
        return {"image": image, "depth": depth}
