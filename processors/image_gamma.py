"""ImageGamma: tone mapping and a gamma curve on an image's colour; alpha is kept.

Per pixel, on the straight colour c = rgb / a of the premultiplied image (rgb itself where a = 0):
x = exposure * max(c, 0); the tone mapping t(x) is x (``none``), x / (1 + x) (``reinhard``:
Reinhard et al. 2002, the global operator applied to each channel) or 1 - exp(-x)
(``exposure``); the output colour is a * t(x)^(1 / gamma), alpha a unchanged. A depth image is a
separate Image in vgraph and passes by untouched. shaders/image/image_gamma.frag.glsl;
tests/test_image_processors.py compares it with the same formula in numpy.
"""

from vgraph import FloatProperty, Inport, OptionProperty, Outport, Processor
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image

TONE_MAPPINGS = ("none", "reinhard", "exposure")


class ImageGamma(Processor):
    """Tone mapping (none, Reinhard, exposure) and gamma on the colour; alpha unchanged."""

    category = "Image"
    inports = [Inport("image", Image)]
    outports = [Outport("image", Image)]
    gamma = FloatProperty(1.0, min=0.05, max=20.0,
                          doc="the colour becomes c^(1 / gamma): above 1 brightens the dark tones (2.2: a display's)")
    tone_mapping = OptionProperty("none", choices=list(TONE_MAPPINGS),
                                  doc="none: x; reinhard: x / (1 + x); exposure: 1 - exp(-x), x = exposure * colour")
    exposure = FloatProperty(1.0, min=0.0, max=1000.0, doc="multiplies the colour before the tone mapping")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._target = RenderTargets(1)

    def process(self, image: Image) -> Image:
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "image/image_gamma.frag.glsl",
                                   {f"TONE_{self.tone_mapping.upper()}": True}, processor=self.id)
        (result,) = self._target.ensure(self.gl, image.size)
        fullscreen_pass(self.gl, program, result, textures={"image": image},
                        uniforms={"gamma": self.gamma, "exposure": self.exposure})
        return result
