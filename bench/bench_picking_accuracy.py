"""Accuracy of picking an iso-surface against an analytic sphere (issue 36), as a markdown table
for docs/reports/accuracy.md ("Picking"):

    .venv/bin/python bench/bench_picking_accuracy.py [--voxels 2 1 0.5] [--margin 3]

For each voxel size (world units; the sphere's radius is 10): the largest distance of the picked
point from the exact sphere, in voxels, over the middle pixel and a ring of 24 oblique rays
(picking_sphere.errors); the error of a ruler between the middle pixel's picks from the front and
from the back against the diameter, in voxels; and the time of one pick (median over the ring,
after the first, which also prefilters the volume): "GL depth" is a pick without refinement
(the ray caster in dvr mode: depth read and values), "tricubic" the same pick with the Newton
refinement on the B-spline surface (iso mode). nearest and linear are the GL ray caster's
first hit with its interpolation nearest or trilinear; tricubic is that hit refined.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import picking_sphere
from picking_sphere import RADIUS, diameter, errors, ring_pixels, sphere_network


def pick_milliseconds(voxel: float, compositing: str) -> float:
    network = sphere_network(voxel)
    network.set("rc.compositing", compositing)
    network.pick("canvas", *ring_pixels()[0])  # draws the depth, prefilters the volume
    times = []
    for x, y in ring_pixels():
        start = time.perf_counter()
        network.pick("canvas", x, y)
        times.append(time.perf_counter() - start)
    return float(np.median(times)) * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voxels", type=float, nargs="+", default=[2.0, 1.0, 0.5])
    parser.add_argument("--margin", type=float, default=picking_sphere.MARGIN,
                        help="voxels of grid beyond the sphere (the spline's mirrored border is that far)")
    args = parser.parse_args()
    picking_sphere.MARGIN = args.margin
    print("| voxel | surface error nearest | linear (GL depth) | tricubic | diameter error nearest "
          "| linear | tricubic | ms per pick: GL depth | tricubic |")
    print("|---|---|---|---|---|---|---|---|---|")
    for voxel in args.voxels:
        worst = errors(voxel)
        rulers = {m: (diameter(voxel, m) - 2 * RADIUS) / voxel for m in ("nearest", "linear", "tricubic")}
        cells = [f"{worst[m]:.4f}" for m in ("nearest", "linear", "tricubic")]
        cells += [f"{rulers[m]:+.4f}" for m in ("nearest", "linear", "tricubic")]
        cells += [f"{pick_milliseconds(voxel, 'dvr'):.2f}", f"{pick_milliseconds(voxel, 'iso'):.2f}"]
        print(f"| {voxel:g} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
