"""DepthDarkening (Luft, Colditz and Deussen 2006): the unsharp-masked depth as a depth cue.

The depth D is the red channel of a depth image (a ray caster's ``depth`` outport: window depth in
[0, 1], 1 where the ray found nothing, so the background counts as far), normalised by the
image's own range: Dn = (D - min D) / (max D - min D), min and max over all pixels (read back once
per frame). Its unsharp mask dD = G_sigma * Dn - Dn (scipy.ndimage.gaussian_filter, mode
'nearest', truncate 4; vgraph.gl.image_filters) is negative where a pixel lies behind its
surroundings; the colour darkens there: rgb' = max(rgb + strength * min(dD, 0), 0), alpha kept.
Only darkening, as Voreen and Inviwo offer it; a depth image of one depth leaves the image as is.
Behind an object's silhouette the background darkens too (the paper's halo): visible over a light
or transparent background, not over black.
"""

import numpy as np

from vgraph import FloatProperty, Inport, Outport, Processor, VGraphError
from vgraph.gl.image_filters import gaussian_blur
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image


class DepthDarkening(Processor):
    """Darkens an image where its depth lies behind the surroundings (Luft et al. 2006)."""

    category = "Image"
    inports = [Inport("image", Image), Inport("depth", Image, "a ray caster's depth output (red: window depth)")]
    outports = [Outport("image", Image)]
    sigma = FloatProperty(8.0, min=0.0, max=64.0, doc="standard deviation in pixels of the depth's blur")
    strength = FloatProperty(1.0, min=0.0, max=100.0,
                             doc="lambda: darkening per unit of normalised depth difference")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._blur = RenderTargets(2)  # the depth's rows blurred, then both axes
        self._target = RenderTargets(1)

    def process(self, image: Image, depth: Image) -> Image:
        if image.size != depth.size:
            raise VGraphError(f"{self.id}: image ({image.size[0]}x{image.size[1]}) and depth "
                              f"({depth.size[0]}x{depth.size[1]}) must have one size")
        depth_min, depth_max = self._depth_bounds(depth)
        across, blurred = self._blur.ensure(self.gl, depth.size)
        gaussian_blur(self.gl, depth, across, blurred, self.sigma, self.id)
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "image/depth_darkening.frag.glsl",
                                   processor=self.id)
        (result,) = self._target.ensure(self.gl, image.size)
        # One depth throughout: nothing lies behind anything (any positive range gives delta 0).
        depth_range = depth_max - depth_min if depth_max > depth_min else 1.0
        fullscreen_pass(self.gl, program, result, textures={"image": image, "depth": depth, "blurred_depth": blurred},
                        uniforms={"depth_min": depth_min, "depth_range": depth_range, "strength": self.strength})
        return result

    def _depth_bounds(self, depth: Image) -> tuple[float, float]:
        values = depth.to_numpy()[..., 0]
        if not np.isfinite(values).all():
            raise VGraphError(f"{self.id}.depth: the depth image holds values that are not finite numbers")
        return float(values.min()), float(values.max())
