"""CurvatureRaycaster (Cabral 2010 sec. 5.3-5.4): an iso-surface coloured by its curvature.

Conventions (docs/explanations/curvature.md explains each property with pictures):
- One inport `volume` takes what the derivative mode needs: voxel SAMPLES for the finite-difference
  modes (forward, central, filtered), B-spline COEFFICIENTS (CubicSplineProcessor output) for
  tricubic and tricubic_fast. The other kind is refused with a message saying what to insert or
  remove (vgraph.gl.curvature.check_volume_kind). EntryExitPoints accepts either kind, so the
  network reads FunctionSelector -> CubicSplineProcessor -> EntryExitPoints -> CurvatureRaycaster.
- The surface is where the reconstruction (trilinear of the samples, or the spline) crosses
  `iso_level` (normalised like every iso level; 0.5 is the surface of every FunctionSelector
  volume), found by marching and refined by regula falsi to float precision
  (shaders/curvature/iso_hit.glsl).
- Curvature (Kindlmann et al. 2003) in 1/world units with the sign of docs/explanations/conventions.md: interior brighter,
  a sphere of radius r has k1 = k2 = +1/r. Undefined where |grad f| is too small to give the
  surface a direction (vgraph.gl.curvature.min_gradient); such hits are flagged, not coloured.
- Built from the shared ray-casting components (vgraph.gl.raycasting.components) and the curvature
  ones (vgraph.gl.curvature). Two GPU passes and a reduction: pass 1
  (curvature_raycaster.frag.glsl) writes the curvature,
  position, depth and (internal) gradient images; for linear normalisation a min/max reduction
  runs on the GPU (RangeReduction); pass 2 (curvature_color.frag.glsl) colours. Nothing is read
  back.
- Outputs (RGBA32F, the entry image's size): `image` colour over `background` (alpha 1 where hit);
  `curvature` (k1, k2, K, flag) with flag 1 = hit and curvature defined, 0.5 = hit but undefined
  (rgb 0), 0 = miss (H = (k1 + k2) / 2); `position` world xyz, alpha 1 where hit; `depth` as the
  RayCaster's (window depth, distance from the near plane, samples evaluated, 1 where hit).
"""

from __future__ import annotations

from vgraph import FloatProperty, Inport, OptionProperty, Outport
from vgraph.gl.curvature import CurvatureColoring, CurvatureField, RangeReduction, measure_defines, measure_uniforms
from vgraph.gl.raycasting.components import (Background, CameraRays, EmptySpace, EntryExit, RawIsoSurface, Sampling,
                                             VolumeSampling)
from vgraph.gl.raycasting.empty_space import level_occupancy, radii_if_worthwhile
from vgraph.gl.raycasting.light import Light
from vgraph.gl.raycasting.raycaster_base import Binding, RaycasterBase
from vgraph.gl.raycasting.shown_volume import ShowsVolume
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.image import Image
from vgraph.volume import Volume

SURFACE_SHADER = "curvature/curvature_raycaster.frag.glsl"
COLOR_SHADER = "curvature/curvature_color.frag.glsl"


def skip_values(raycaster, frame):
    """Blocks the surface may cross (components.EmptySpace)."""
    level = raycaster.iso_level
    return level, lambda low, high: radii_if_worthwhile(level_occupancy(level)(low, high))


SURFACE_PARTS = (EntryExit(), CameraRays(), VolumeSampling(), Sampling(), RawIsoSurface(), CurvatureField(),
                 EmptySpace(skip=skip_values))
COLOR_PARTS = (CurvatureColoring(), Light(), Background())


class CurvatureRaycaster(ShowsVolume, RaycasterBase):
    """Iso-surface ray casting coloured by curvature (k1, k2, Gaussian, mean, ...)."""

    category = "Volume rendering"
    # Curvatures (1/length), positions and the attenuation are world lengths: extreme boxes are
    # refused by name rather than drawn in their normalised frame (components docstring).
    frames_extreme_boxes = False
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image), Outport("curvature", Image), Outport("position", Image),
                Outport("depth", Image)]
    components = SURFACE_PARTS + COLOR_PARTS

    contour_width = FloatProperty(2.0, min=0.0, max=32.0,
                                  doc="pixels of the black zero-curvature contour (0: none)")
    shading = OptionProperty("blinn_phong", choices=["none", "blinn_phong"],
                             doc="lighting of the surface")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._surface = RenderTargets(4)  # curvature, position, depth, gradient
        self._image = RenderTargets(1)
        self._reduction = RangeReduction()

    def shows_iso_surface(self) -> bool:
        """It shows the voxels inside its iso surface (ShowsVolume)."""
        return True

    # --- evaluation -----------------------------------------------------------------------------
    def process(self, volume: Volume, entry: Image, exit: Image) -> dict:
        frame = self.frame(volume, entry, exit)
        curvature, position, depth, gradient = self._surface.ensure(frame.ctx, entry.size)
        self.draw(frame, SURFACE_SHADER, self._surface, SURFACE_PARTS)
        image, = self._image.ensure(frame.ctx, entry.size)
        textures = {"curvature_image": curvature, "gradient_image": gradient, "position_image": position}
        if self.normalization == "linear":
            textures["curvature_range"] = self._reduction.run(
                frame.ctx, curvature, measure_defines(self.curvature), self.id, measure_uniforms(volume))
        camera = frame.camera
        own = Binding(textures=textures,
                      uniforms={"contour_width": self.contour_width, "eye": vec(camera.position),
                                "view_forward": vec(camera.basis()[2]),
                                "perspective": camera.projection == "perspective"})
        self.draw(frame, COLOR_SHADER, image, COLOR_PARTS, own)
        return {"image": image, "curvature": curvature, "position": position, "depth": depth}
