"""Canvas: the sink the CLI writes and the GUI shows."""

import numpy as np
import PIL.Image

from vgraph import Inport, Processor, VectorProperty
from vgraph.image import Image


class Canvas(Processor):
    """Shows an image at its size: renderers upstream draw at it, other images are resampled."""

    category = "Output"
    inports = [Inport("image", Image)]
    size = VectorProperty((512, 512), min=1, max=16384, integer=True,
                          doc="width and height in pixels of the image shown; renderers upstream draw at it")
    renders_at_size = True  # the scheduler sets render_size: this size, or the size asked for (--size)

    def __init__(self, *args, **kwargs):
        self.shown: Image | None = None  # what network.output(id) returns
        super().__init__(*args, **kwargs)

    def process(self, image: Image) -> None:
        """Keep the image (``network.output(id)``); one of another size than ``render_size`` (an
        image file, an image processor that keeps its input's size) is resampled to it first."""
        self.shown = None
        self.shown = image if image.size == tuple(self.render_size) else \
            Image.from_numpy(self.gl, resample(image.to_numpy(), self.render_size))


def resample(pixels: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``pixels`` (H, W, C float32) at ``size`` (width, height): each channel (alpha too; colours
    are not premultiplied) with PIL's bilinear filter, which is a triangle filter widened when
    shrinking so that every source pixel contributes (no aliasing, no overshoot: values stay
    within the range of their neighbours)."""
    channels = [PIL.Image.fromarray(np.ascontiguousarray(pixels[..., c], dtype=np.float32))
                .resize(tuple(size), PIL.Image.Resampling.BILINEAR) for c in range(pixels.shape[-1])]
    return np.stack([np.asarray(channel, dtype=np.float32) for channel in channels], axis=-1)
