"""Histogram: an image of a volume's histogram, linear or logarithmic, with the transfer function's
opacity curve drawn over it, for reports.

The counts are Volume.histogram's: ``bins`` equal bins of the finite voxels over the volume's value
range (normalised intensity 0 .. 1, the axis transfer functions are placed on; a store's come from
its summary level). The image (drawn on the CPU by vgraph.volume_statistics.histogram_pixels,
at the requested render size) spans that range left to right; a bar's height is its count, or
log(1 + count), over the tallest's. The TF (link it to the ray caster's; a TF in data units or
percentiles is placed on this volume as the ray caster places it) is its opacity from 0 at the
bottom to 1 at the top, drawn in its own colour. No axes or labels are drawn: a TextOverlay adds
a caption.
"""

import numpy as np

from vgraph import (BoolProperty, ColorProperty, Inport, IntProperty, Outport, Processor,
                    TransferFunctionProperty)
from vgraph.gl.raycasting.targets import RenderTargets
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
