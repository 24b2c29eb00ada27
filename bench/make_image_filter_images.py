"""Make docs/images/image_filters.png: the image filters on the ray-cast CT head of
networks/depth_cues_head.json (over white), side by side: the ray caster's image, ImageBlur
(sigma 3), EdgeDetect (contours of the luminance over the image), DepthDarkening and the
network's picture (DepthDarkening, then EdgeDetect's contours of the depth over it).

    python bench/make_image_filter_images.py [--out PATH]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import vgraph
from panel_row import panel_row_main

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "image_filters.png"
SIZE = (256, 256)


def panels() -> list[np.ndarray]:
    network = vgraph.load(REPO / "networks" / "depth_cues_head.json")
    network.add("ImageBlur", id="blur", sigma=3.0)
    network.add("EdgeDetect", id="edges", scale=0.5)
    network.connect("rc.image", "blur.image")
    network.connect("rc.image", "edges.image")
    ports = ("rc.image", "blur.image", "edges.image", "darken.image", "contours.image")
    network.update(*ports, size=SIZE)
    return [network.output(port).to_numpy() for port in ports]


def main(argv=None) -> int:
    return panel_row_main(__doc__, OUT, panels, argv)


if __name__ == "__main__":
    raise SystemExit(main())
