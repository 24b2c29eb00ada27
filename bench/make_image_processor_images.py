"""Make docs/images/image_processors.png: the issue-35 image and statistics processors on the CT
head of networks/raycast_head.json (orthographic, over a transparent background), side by side:
Background (gradient) under the ray-cast head with ImageGamma (Reinhard, gamma 1.4) and a
TextOverlay caption and 50 mm scale bar; ImageThreshold of the ray caster's luminance at 0.7 (the
bright bone); ImageMix adding 0.4 of that threshold to the picture; the Histogram (log, its value range
labelled) of the head with the ray caster's transfer function over it.

    python bench/make_image_processor_images.py [--out PATH]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import vgraph
from panel_row import panel_row_main

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "image_processors.png"
SIZE = (256, 256)


def network() -> vgraph.Network:
    net = vgraph.load(REPO / "networks" / "raycast_head.json")
    camera = net.processors["eep"].camera.model_copy(update={"projection": "orthographic"})
    net.set("eep.camera", camera)  # linked: the ray caster's follows
    net.set("rc.background", (0.0, 0.0, 0.0, 0.0))
    net.add("ImageGamma", id="gamma", tone_mapping="reinhard", exposure=2.0, gamma=1.4)
    net.add("Background", id="back", pattern="gradient", first=(0.35, 0.4, 0.5, 1.0), second=(0.02, 0.02, 0.05, 1.0))
    net.add("TextOverlay", id="text", text="CT head (headsq)", scale_bar=True, scale_bar_length=50.0, units="mm")
    net.add("ImageThreshold", id="threshold", threshold=0.7, above=(1.0, 0.6, 0.1, 1.0), below=(0.0, 0.0, 0.0, 1.0))
    net.add("ImageMix", id="mix", mode="add", factor=0.4)
    net.add("Histogram", id="histogram", bins=128, log=True, background=(0.1, 0.1, 0.12, 1.0),
            bar_color=(0.45, 0.5, 0.6, 1.0), labels=True, label_color=(1.0, 1.0, 1.0, 1.0))
    for source, target in (("rc.image", "gamma.image"), ("gamma.image", "back.image"), ("back.image", "text.image"),
                           ("source.volume", "text.volume"), ("rc.image", "threshold.image"),
                           ("back.image", "mix.a"), ("threshold.image", "mix.b"),
                           ("source.volume", "histogram.volume")):
        net.connect(source, target)
    net.link("eep.camera", "text.camera")
    net.link("rc.transfer_function", "histogram.transfer_function")
    return net


def panels() -> list[np.ndarray]:
    net = network()
    ports = ("text.image", "threshold.image", "mix.image", "histogram.image")
    net.update(*ports, size=SIZE)
    return [net.output(port).to_numpy() for port in ports]


def main(argv=None) -> int:
    return panel_row_main(__doc__, OUT, panels, argv)


if __name__ == "__main__":
    raise SystemExit(main())
