"""ImageThreshold: a binary image from a threshold on luminance or one channel.

Per pixel: v = the chosen value of the stored (premultiplied) RGBA, luminance 0.30 R + 0.59 G +
0.11 B as Grayscale and EdgeDetect take it, or red, green, blue or alpha; the output is ``above``
where v >= threshold, else ``below`` (each colour premultiplied by its alpha). A depth image's
red channel (window depth) thresholds to a mask of what lies nearer than a depth. shaders/image/
image_threshold.frag.glsl; tests/test_image_processors.py compares it with numpy.
"""

from vgraph import ColorProperty, FloatProperty, Inport, OptionProperty, Outport, Processor
from vgraph.gl.image_filters import premultiplied
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image

CHANNELS = ("luminance", "red", "green", "blue", "alpha")


class ImageThreshold(Processor):
    """Binary image: the `above` colour where luminance (or a channel) >= threshold, else `below`."""

    category = "Image"
    inports = [Inport("image", Image)]
    outports = [Outport("image", Image)]
    channel = OptionProperty("luminance", choices=list(CHANNELS),
                             doc="the value compared: luminance 0.30 R + 0.59 G + 0.11 B (premultiplied), or a channel")
    threshold = FloatProperty(0.5, min=-1e6, max=1e6, doc="pixels whose value is at least this are 'above'")
    above = ColorProperty((1.0, 1.0, 1.0, 1.0), doc="colour of the pixels at or over the threshold")
    below = ColorProperty((0.0, 0.0, 0.0, 1.0), doc="colour of the pixels under the threshold")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._target = RenderTargets(1)

    def process(self, image: Image) -> Image:
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "image/image_threshold.frag.glsl",
                                   {f"CHANNEL_{self.channel.upper()}": True}, processor=self.id)
        (result,) = self._target.ensure(self.gl, image.size)
        fullscreen_pass(self.gl, program, result, textures={"image": image},
                        uniforms={"threshold": self.threshold, "above": premultiplied(self.above),
                                  "below": premultiplied(self.below)})
        return result
