"""ImageCompositor: two images into one, ``front`` over ``back`` (Porter & Duff 1984), or added.

Conventions: images are premultiplied RGBA (the ray casters' and the GeometryRenderer's colour
over their background), so "over" is ``front + (1 - front.a) * back``, the ray casters' own
front-to-back rule. A ray caster meant to lie over something must have a transparent background
(0, 0, 0, 0); its opaque default would cover the back image. Both images must have one size.
"""

from vgraph import Inport, OptionProperty, Outport, Processor, VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image

MODES = ("over", "add")


class ImageCompositor(Processor):
    """Composites a front image over a back image (premultiplied alpha), or adds them."""

    category = "Image"
    inports = [Inport("front", Image), Inport("back", Image)]
    outports = [Outport("image", Image)]
    mode = OptionProperty("over", choices=list(MODES),
                          doc="over: front + (1 - front alpha) back; add: their sum, clamped to [0, 1]")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._target = RenderTargets(1)

    def process(self, front: Image, back: Image) -> Image:
        if front.size != back.size:
            raise VGraphError(f"{self.id}: front ({front.size[0]}x{front.size[1]}) and back "
                              f"({back.size[0]}x{back.size[1]}) images must have one size")
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "image_compositor.frag.glsl",
                                   {f"MODE_{self.mode.upper()}": True}, processor=self.id)
        (result,) = self._target.ensure(self.gl, front.size)
        fullscreen_pass(self.gl, program, result, textures={"front": front, "back": back})
        return result
