"""Make docs/images/measuring_profile.png: where networks/measure_engine.json's line runs (the
engine CT's axial slice through the line, z = 10, in world coordinates, the line in red) beside the
LineProfile's own plot of it (its ``plot`` outport, as the network's canvas shows it).

    python bench/make_measuring_images.py [--out PATH]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import vgraph
from vgraph.imagefile import write_png

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "measuring_profile.png"
SIZE = (560, 360)


def slice_with_line(network) -> np.ndarray:
    """The slice through the line (the profile's z), drawn with matplotlib at SIZE[1] pixels high."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    volume = network.output("engine.volume")
    start, end = network.get("profile.start"), network.get("profile.end")
    k = int(round(volume.world_to_voxel(start)[2]))
    low, high = volume.world_box()  # an axis-aligned grid: index axes are the world axes
    figure = Figure(figsize=(SIZE[1] / 100, SIZE[1] / 100), dpi=100)
    canvas = FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    axes.imshow(volume.data[k], cmap="gray", origin="lower", extent=(low[0], high[0], low[1], high[1]))
    axes.plot([start[0], end[0]], [start[1], end[1]], color="red", linewidth=2)
    axes.annotate("start", start[:2], color="red", xytext=(4, -12), textcoords="offset points")
    axes.set_title(f"engine CT, z = {volume.voxel_to_world((0, 0, k))[2]:g}", fontsize="medium")
    axes.set_xlabel("x [world units]")
    axes.set_ylabel("y [world units]")
    figure.tight_layout()
    canvas.draw()
    return np.asarray(canvas.buffer_rgba(), dtype=np.float32) / 255.0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    network = vgraph.load(REPO / "networks" / "measure_engine.json")
    network.update("profile.plot", "engine.volume", size=SIZE)
    plot = network.output("profile.plot").to_numpy()
    write_png(args.out, np.concatenate([slice_with_line(network), plot], axis=1))
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
