"""ImageMix: two images of one size combined per pixel by a factor, or by their depths.

Images are premultiplied RGBA; per pixel, with f = ``factor``:
- ``mix``: (1 - f) a + f b (a cross-fade; f 0 gives a, 1 gives b);
- ``add``: a + f b, not clamped (the images are float; ImageCompositor's add clamps);
- ``multiply``: a * ((1 - f) + f b), channel by channel (f 1: a times b, a shadow or a mask);
- ``nearer``: the pixel of the image whose depth is smaller, a on a tie: depth_a and depth_b are
  the two renderers' depth images (red: window depth, 1 where nothing was hit), both needed.
All images must have one size: another size is refused by name, nothing is resampled.
shaders/image/image_mix.frag.glsl; tests/test_image_processors.py compares it with numpy.
"""

from vgraph import FloatProperty, Inport, OptionProperty, Outport, Processor, VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image

MODES = ("mix", "add", "multiply", "nearer")


class ImageMix(Processor):
    """Mixes, adds or multiplies two images by a factor, or keeps the nearer by depth."""

    category = "Image"
    inports = [Inport("a", Image), Inport("b", Image),
               Inport("depth_a", Image, "a's depth (red: window depth); mode nearer only", optional=True),
               Inport("depth_b", Image, "b's depth (red: window depth); mode nearer only", optional=True)]
    outports = [Outport("image", Image)]
    mode = OptionProperty("mix", choices=list(MODES),
                          doc="mix: (1 - f) a + f b; add: a + f b; multiply: a ((1 - f) + f b); "
                              "nearer: per pixel the image of smaller depth")
    factor = FloatProperty(0.5, min=0.0, max=1.0, doc="f: the weight of b (not used by nearer)")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._target = RenderTargets(1)

    def process(self, a: Image, b: Image, depth_a: Image | None = None, depth_b: Image | None = None) -> Image:
        images = {"a": a, "b": b}
        if self.mode == "nearer":
            missing = [name for name, image in (("depth_a", depth_a), ("depth_b", depth_b)) if image is None]
            if missing:
                raise VGraphError(f"{self.id}: mode 'nearer' needs both depth images; connect "
                                  f"{' and '.join(missing)}")
            images |= {"depth_a": depth_a, "depth_b": depth_b}
        self._check_sizes(images)
        program = programs.program(self.gl, FULLSCREEN_VERTEX_SHADER, "image/image_mix.frag.glsl",
                                   {f"MODE_{self.mode.upper()}": True}, processor=self.id)
        (result,) = self._target.ensure(self.gl, a.size)
        fullscreen_pass(self.gl, program, result, textures=images, uniforms={"factor": self.factor})
        return result

    def _check_sizes(self, images: dict[str, Image]) -> None:
        for name, image in images.items():
            if image.size != images["a"].size:
                raise VGraphError(f"{self.id}: a ({images['a'].size[0]}x{images['a'].size[1]}) and {name} "
                                  f"({image.size[0]}x{image.size[1]}) must have one size")
