"""The picture of docs/guide/gradient-classification.md: the CT head with the 1D TF, with gradient opacity, with a 2D TF, and the 2D TF's primitives over the value x gradient histogram.

    .venv/bin/python bench/make_gradient_classification_images.py [--out docs/images] [--size 256]

Every rendering is networks/raycast_head.json (VTK headsq, quarter resolution) with the RayCaster's
properties changed as the captions say; the histogram is
vgraph.gl.raycasting.gradient_classification.value_gradient_histogram of the same volume (log
counts, value to the right, gradient fraction upwards), with each primitive's outline in its colour."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import PIL.Image
import PIL.ImageDraw

from vgraph.fileformat import load_network
from vgraph.gl.raycasting.gradient_classification import value_gradient_histogram
from vgraph.gradient_opacity import GradientOpacity
from vgraph.transfer_function_2d import Gaussian, Rectangle, TransferFunction2D, Triangle

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_rendering_images import REPO, panel, strip, strip_arguments  # noqa: E402

# Kniss's arches in this head: air-skin from value 0 to about 0.2, soft tissue-bone from 0.2 to 0.6;
# a triangle standing on each boundary's value picks that boundary alone.
HEAD_2D = TransferFunction2D(primitives=[
    Triangle(vertices=((0.12, 0.0), (0.04, 0.45), (0.2, 0.45)), color=(0.95, 0.65, 0.5, 0.06)),
    Triangle(vertices=((0.42, 0.02), (0.28, 0.7), (0.58, 0.7)), color=(1.0, 0.97, 0.9, 0.7))])
EDGES = GradientOpacity(points=[(0.0, 0.0), (0.08, 0.0), (0.2, 1.0), (1.0, 1.0)])


def histogram_panel(volume, transfer_function: TransferFunction2D, size: int) -> np.ndarray:
    counts = np.log1p(value_gradient_histogram(volume, 128))[::-1]  # gradient upwards
    grey = ((counts / counts.max()) ** 0.6 * 230.0).astype(np.uint8)  # the sparse high gradients too
    image = PIL.Image.fromarray(grey).resize((size, size), PIL.Image.NEAREST).convert("RGB")
    draw = PIL.ImageDraw.Draw(image)

    def at(value, gradient):
        return value * (size - 1), (1.0 - gradient) * (size - 1)
    for primitive in transfer_function.primitives:
        colour = tuple(int(255 * c) for c in primitive.color[:3])
        if isinstance(primitive, Triangle):
            draw.polygon([at(*v) for v in primitive.vertices], outline=colour, width=2)
        elif isinstance(primitive, Rectangle):
            (v0, v1), (g0, g1) = primitive.value, primitive.gradient
            draw.rectangle([at(v0, g1), at(v1, g0)], outline=colour, width=2)
        elif isinstance(primitive, Gaussian):
            (cv, cg), (wv, wg) = primitive.centre, primitive.width
            draw.ellipse([at(cv - wv, cg + wg), at(cv + wv, cg - wg)], outline=colour, width=2)
    return np.asarray(image, dtype=np.float64) / 255.0


def main() -> None:
    out, size = strip_arguments(__doc__.splitlines()[0])
    net = load_network(REPO / "networks" / "raycast_head.json")
    strip([("1D TF (the network's)", panel(net, size)),
           ("+ gradient opacity", panel(net, size, rc__gradient_opacity=EDGES)),
           ("2D TF (no gradient opacity)", panel(net, size, rc__gradient_opacity=None,
                                                 rc__transfer_function_2d=HEAD_2D)),
           ("its primitives, histogram", histogram_panel(net["rc"].inputs["volume"], HEAD_2D, size))],
          out / "gradient_classification.png")


if __name__ == "__main__":
    main()
