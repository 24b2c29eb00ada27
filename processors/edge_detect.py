"""EdgeDetect: the Sobel gradient magnitude of an image, alone or drawn as contours over it.

The magnitude equals hypot(scipy.ndimage.sobel(v, 0), scipy.ndimage.sobel(v, 1)) of the chosen
channel v (border mode 'nearest'), times ``scale``: a unit step gives 4, so the default scale 0.25
maps it to 1. ``overlay`` draws ``edge_color`` with coverage clamp(magnitude * scale, 0, 1) over the
input (premultiplied "over", as ImageCompositor), e.g. contours over a volume rendering; without it
the output is the magnitude as an opaque grey image, unclamped. The edges are of ``edges_of``
where it is connected (a ray caster's depth, channel red: contours where the depth jumps, drawn
over its colour image), else of the image itself; both must have one size.
"""

from vgraph import BoolProperty, ColorProperty, FloatProperty, Inport, OptionProperty, Outport, Processor, VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image

CHANNELS = ("luminance", "alpha", "red")


class EdgeDetect(Processor):
    """Sobel edges of an image's luminance, alpha or red channel, alone or over the image."""

    category = "Image"
    inports = [Inport("image", Image),
               Inport("edges_of", Image, "the image the edges are taken of (unconnected: the image itself)",
                      optional=True)]
    outports = [Outport("image", Image)]
    channel = OptionProperty("luminance", choices=list(CHANNELS),
                             doc="what the edges are of: luminance 0.30 R + 0.59 G + 0.11 B (premultiplied), "
                                 "alpha (silhouettes), red (a ray caster's depth image: window depth)")
    scale = FloatProperty(0.25, min=0.0, max=1000.0, doc="multiplies the Sobel magnitude (a unit step gives 4)")
    overlay = BoolProperty(True, doc="draw the edges over the image; off: the magnitude alone, as grey")
    edge_color = ColorProperty((0.0, 0.0, 0.0, 1.0), doc="colour of the contours drawn over the image")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._target = RenderTargets(1)

    def process(self, image: Image, edges_of: Image | None = None) -> Image:
        if edges_of is not None and edges_of.size != image.size:
            raise VGraphError(f"{self.id}: image ({image.size[0]}x{image.size[1]}) and edges_of "
                              f"({edges_of.size[0]}x{edges_of.size[1]}) must have one size")
        defines = {f"CHANNEL_{self.channel.upper()}": True, "EDGES_ONLY": not self.overlay}
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "image/edge_detect.frag.glsl", defines,
                                   processor=self.id)
        (result,) = self._target.ensure(self.gl, image.size)
        fullscreen_pass(self.gl, program, result, textures={"image": image, "edges_of": edges_of or image},
                        uniforms={"scale": self.scale, "edge_color": tuple(self.edge_color)})
        return result
