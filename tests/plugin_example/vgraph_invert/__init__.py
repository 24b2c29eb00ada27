"""An example vgraph plug-in: Invert, a processor with a shader of its own."""

from pathlib import Path

from vgraph import BoolProperty, Inport, Outport, Processor
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.shaders import add_shader_dir, programs
from vgraph.image import Image

add_shader_dir(Path(__file__).parent / "shaders")


class Invert(Processor):
    """Inverts the colour channels of an image (1 - value)."""

    category = "Image"
    inports = [Inport("image", Image)]
    outports = [Outport("image", Image)]
    invert_alpha = BoolProperty(False, doc="invert alpha too")

    def process(self, image):
        defines = {"INVERT_ALPHA": self.invert_alpha}
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "invert.frag.glsl", defines,
                                   processor=self.id)
        result = Image.empty(self.gl, image.size)
        fullscreen_pass(self.gl, program, result, textures={"image": image})
        return result
