"""Make docs/images/markups_head.png: markups over networks/raycast_head.json's CT head (perspective,
the camera fitting the data): a ruler between two picked points of the skin (Network.pick), an angle
at a third, and a closed curve in an axial plane around the head (faint where the head lies in front:
the depth test).

    python bench/make_markups_image.py [--out PATH]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import vgraph
from vgraph.imagefile import write_png

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "markups_head.png"
SIZE = (480, 480)


def head_with_markups():
    network = vgraph.load(REPO / "networks" / "raycast_head.json")
    network.add("Markups", id="mk", units="mm", line_width=2)
    network.link("eep.camera", "mk.camera")
    for source, target in (("rc.image", "mk.image"), ("rc.depth", "mk.depth"), ("source.volume", "mk.volume")):
        network.connect(source, target)
    network.disconnect("rc.image", "canvas.image")
    network.connect("mk.image", "canvas.image")
    network.set("canvas.size", SIZE)
    return network


def picked(network, x, y):
    result = network.pick("canvas", x, y)
    if not result.hit:
        raise SystemExit(f"pixel ({x}, {y}) of the head's view hits nothing")
    return [float(v) for v in result.point]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    network = head_with_markups()
    network.update("mk.image", size=SIZE)
    left, right, apex = picked(network, 170, 250), picked(network, 320, 250), picked(network, 240, 170)
    low, high = network.output("source.volume").world_box()
    middle = (np.asarray(low) + np.asarray(high)) / 2
    network.set("mk.markups", [
        {"name": "width", "kind": "ruler", "points": [left, right]},
        {"name": "apex", "kind": "angle", "points": [left, apex, right]},
        {"name": "slice", "kind": "closed_curve",
         "points": [list(middle + (dx, dy, 20.0)) for dx, dy in ((-50, -50), (50, -50), (50, 50), (-50, 50))]}])
    pixels = network.evaluate("mk.image", size=SIZE)
    write_png(args.out, pixels)
    print(f"wrote {args.out}")
    print(network.evaluate("mk.table"))


if __name__ == "__main__":
    main()
