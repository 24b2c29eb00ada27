"""Histogram: an image of a volume's histogram, linear or logarithmic, with the transfer function's
opacity curve drawn over it, for reports.

The counts are Volume.histogram's: ``bins`` equal bins of the finite voxels over the volume's value
range (normalised intensity 0 .. 1, the axis transfer functions are placed on; a store's come from
its summary level). The image (drawn on the CPU by vgraph.volume_statistics.histogram_pixels,
at the requested render size) spans that range left to right; a bar's height is its count, or
log(1 + count), over the tallest's. The TF (link it to the ray caster's; a TF in data units or
percentiles is placed on this volume as the ray caster places it) is its opacity from 0 at the
bottom to 1 at the top, drawn in its own colour. With ``labels`` the two ends of the value range
are written in the bottom corners (Pillow's bundled font, 6 % of the shorter side high, at a margin
of 2 %), ``label_color`` composited "over" the plot; a TextOverlay adds a caption.
"""

import numpy as np
from PIL import Image as PILImage
from PIL import ImageDraw, ImageFont

from vgraph import (BoolProperty, ColorProperty, Inport, IntProperty, Outport, Processor,
                    TransferFunctionProperty)
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.image_filters import premultiplied
from vgraph.image import Image
from vgraph.transfer_function import PRESETS
from vgraph.volume import Volume
from vgraph.volume_statistics import histogram_pixels


class Histogram(Processor):
    """An image of the volume's histogram (linear or log) with the transfer function over it."""

    category = "Statistics"
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image)]
    renders_at_size = True  # drawn at the requested size (the Canvas's)
    bins = IntProperty(128, min=2, max=4096, doc="equal bins over the volume's value range")
    log = BoolProperty(False, doc="bar heights log(1 + count): the small counts next to a large background show")
    transfer_function = TransferFunctionProperty(PRESETS["grayscale"],
                                                 doc="drawn over the bars (its opacity); link it to the ray caster's")
    show_transfer_function = BoolProperty(True, doc="draw the transfer function's opacity curve")
    bar_color = ColorProperty((0.45, 0.47, 0.55, 1.0), doc="colour of the bars")
    background = ColorProperty((1.0, 1.0, 1.0, 1.0), doc="colour behind the bars")
    labels = BoolProperty(False, doc="write the value range's ends in the bottom corners")
    label_color = ColorProperty((0.0, 0.0, 0.0, 1.0), doc="colour of the labels")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.counts: np.ndarray | None = None  # the bins of the last frame
        self._range: tuple[float, float] = (0.0, 1.0)  # and the values they span
        self._target = RenderTargets(1)

    def process(self, volume: Volume) -> Image:
        volume = volume.require_samples(self.id)
        self.counts = None
        counts, _ = volume.histogram(self.bins)
        tf = self.transfer_function.for_volume(volume) if self.show_transfer_function else None
        width, height = self.render_size
        pixels = histogram_pixels(counts, (width, height), log=self.log, bar_color=self.bar_color,
                                  background=self.background, tf=tf, line_width=max(1, round(height / 150)))
        if self.labels:
            pixels = over(range_labels(volume.value_range, width, height), self.label_color, pixels)
        self.counts, self._range = counts, volume.value_range
        (result,) = self._target.ensure(self.gl, (width, height))
        result.texture.write(np.ascontiguousarray(pixels[::-1]).tobytes())  # GL's rows start at the bottom
        return result

    def frame_summary(self) -> str:
        if self.counts is None:
            return ""
        low, high = self._range
        return (f"{len(self.counts)} bins over {low:g} to {high:g}; the tallest holds {int(self.counts.max()):,} "
                f"of {int(self.counts.sum()):,} voxels")


def range_labels(value_range, width: int, height: int) -> np.ndarray:
    """Coverage (height, width) in [0, 1] of the value range's ends written in the bottom corners."""
    short = min(width, height)
    margin = max(2, round(0.02 * short))
    font = ImageFont.load_default(size=max(10, round(0.06 * short)))
    mask = PILImage.new("L", (width, height), 0)
    draw = ImageDraw.Draw(mask)
    low, high = value_range
    draw.text((margin, height - margin), f"{low:g}", fill=255, font=font, anchor="ld")
    draw.text((width - margin, height - margin), f"{high:g}", fill=255, font=font, anchor="rd")
    return np.asarray(mask, dtype=np.float32) / 255.0


def over(coverage: np.ndarray, color, pixels: np.ndarray) -> np.ndarray:
    """``color`` (straight RGBA) with ``coverage`` "over" premultiplied ``pixels``."""
    front = np.asarray(premultiplied(color), np.float32) * coverage[..., None]
    return front + (1.0 - front[..., 3:]) * pixels
