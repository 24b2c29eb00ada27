"""ImageBlur: a Gaussian blur of an image, separable (two fullscreen passes, rows then columns).

Equals scipy.ndimage.gaussian_filter(channel, sigma, mode="nearest", truncate=4) on each channel of
the premultiplied RGBA image (vgraph.gl.image_filters); tests/test_image_filters.py holds it to that.
"""

from vgraph import FloatProperty, Inport, Outport, Processor
from vgraph.gl.image_filters import gaussian_blur
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.image import Image


class ImageBlur(Processor):
    """Gaussian blur (separable), sigma in pixels; the image keeps its size."""

    category = "Image"
    inports = [Inport("image", Image)]
    outports = [Outport("image", Image)]
    sigma = FloatProperty(2.0, min=0.0, max=64.0,
                          doc="standard deviation in pixels; the kernel reaches 4 sigma; 0 copies the image")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._across = RenderTargets(1)  # the rows blurred, read by the column pass
        self._target = RenderTargets(1)

    def process(self, image: Image) -> Image:
        (across,) = self._across.ensure(self.gl, image.size)
        (result,) = self._target.ensure(self.gl, image.size)
        gaussian_blur(self.gl, image, across, result, self.sigma, self.id)
        return result
