"""Make docs/images/clipping_mask_cutaway.png: masks and cut-aways of the RayCaster (vgraph.masking)
on networks/mask_engine.json, four panels: the engine CT without a mask; its casing hidden by the
label volume (the network as shipped: mask_labels 1, mask_mode hide); no mask and a box cut away;
no mask and a sphere cut away (concave regions, which clip planes cannot remove).

    python bench/make_mask_figure.py [--out PATH]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import vgraph
from panel_row import write_panel_row

REPO = Path(__file__).resolve().parents[1]
NETWORK = REPO / "networks" / "mask_engine.json"
OUT = REPO / "docs" / "images" / "clipping_mask_cutaway.png"
SIZE = (320, 260)
BOX = {"cutaway": "box", "cutaway_center": (70.0, -70.0, 40.0), "cutaway_size": (150.0, 150.0, 110.0)}
SPHERE = {"cutaway": "sphere", "cutaway_center": (40.0, -40.0, 40.0), "cutaway_size": (170.0, 170.0, 170.0)}


def panels(network) -> list:
    shown = []
    network.disconnect("labels.volume", "rc.mask")
    shown.append(network.evaluate("rc.image", size=SIZE))
    network.connect("labels.volume", "rc.mask")
    shown.append(network.evaluate("rc.image", size=SIZE))
    network.disconnect("labels.volume", "rc.mask")
    for region in (BOX, SPHERE):
        for name, value in region.items():
            network.set(f"rc.{name}", value)
        shown.append(network.evaluate("rc.image", size=SIZE))
    return shown


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    write_panel_row(args.out, panels(vgraph.load(NETWORK)))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
