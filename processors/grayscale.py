"""Grayscale (Cabral 2010, ch. 4.4.2): luminance mixed with the original colour."""

from vgraph import FloatProperty, Inport, Outport, Processor
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.shaders import programs
from vgraph.image import Image


class Grayscale(Processor):
    """Luminance 0.30 R + 0.59 G + 0.11 B, mixed with the original colour by saturation."""

    category = "Image"
    inports = [Inport("image", Image)]
    outports = [Outport("image", Image)]
    saturation = FloatProperty(0.0, min=0.0, max=1.0, doc="0 gives grey, 1 the original colours")

    def process(self, image: Image) -> Image:
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "grayscale.frag.glsl",
                                   processor=self.id)
        result = Image.empty(self.gl, image.size)
        fullscreen_pass(self.gl, program, result, textures={"image": image},
                        uniforms={"saturation": self.saturation})
        return result
