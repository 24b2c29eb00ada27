"""Background: a solid colour, a vertical gradient or a checkerboard, under an image.

The pattern (shaders/image/background_pattern.glsl), row 0 at the top of the image:
- ``solid``: ``first`` everywhere;
- ``gradient``: ``first`` at the top, ``second`` at the bottom, linear in the row:
  mix(first, second, (row + 0.5) / height) (premultiplied colours mixed);
- ``checkerboard``: squares of ``cell`` pixels starting at the top-left pixel, ``first`` there:
  first where (column // cell + row // cell) is even, else second.
The image, when connected, is composited "over" the pattern (premultiplied Porter-Duff, as
ImageCompositor); its size is the output's. Unconnected, the output is the pattern alone at the
requested render size (the Canvas's). A ray caster's depth image is separate and stays as it was.
"""

from vgraph import ColorProperty, Inport, IntProperty, OptionProperty, Outport, Processor
from vgraph.gl.image_filters import premultiplied
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image

PATTERNS = ("solid", "gradient", "checkerboard")


class Background(Processor):
    """Solid, vertical gradient or checkerboard background, the image composited over it."""

    category = "Image"
    inports = [Inport("image", Image, "composited over the background (unconnected: the background alone)",
                      optional=True)]
    outports = [Outport("image", Image)]
    renders_at_size = True  # without an image the background is drawn at the requested size
    pattern = OptionProperty("gradient", choices=list(PATTERNS),
                             doc="solid: first colour; gradient: first at the top to second at the bottom; "
                                 "checkerboard: squares of both, first at the top left")
    first = ColorProperty((0.28, 0.3, 0.35, 1.0), doc="the solid colour, the gradient's top, the checkerboard's first")
    second = ColorProperty((0.05, 0.05, 0.07, 1.0), doc="the gradient's bottom, the checkerboard's second")
    cell = IntProperty(16, min=1, max=4096, doc="side of a checkerboard square in pixels")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._target = RenderTargets(1)

    def process(self, image: Image | None = None) -> Image:
        size = image.size if image is not None else tuple(self.render_size)
        defines = {f"PATTERN_{self.pattern.upper()}": True, "HAS_IMAGE": image is not None}
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "image/background.frag.glsl", defines,
                                   processor=self.id)
        (result,) = self._target.ensure(self.gl, size)
        fullscreen_pass(self.gl, program, result, textures={"image": image} if image is not None else {},
                        uniforms={"first": premultiplied(self.first), "second": premultiplied(self.second),
                                  "cell": self.cell, "height": size[1]})
        return result
