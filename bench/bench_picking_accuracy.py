"""Accuracy of picking an iso-surface against an analytic sphere, torus and two planes (issue 36),
as markdown tables for docs/reports/accuracy.md ("Picking an iso-surface", "Measuring on a torus
and between two planes"):

    .venv/bin/python bench/bench_picking_accuracy.py [--shape sphere|torus|planes] [--voxels 2 1 0.5] [--margin 3]

--shape torus and --shape planes: picking_shapes.py says what is measured; the errors are in
voxels (the angle in degrees) and the times are the median of one pick over the shape's picks.

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

import picking_shapes
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


def median_pick_milliseconds(networks_and_pixels) -> float:
    """The median time of one pick over (network, pixel) pairs, each network's first pick (the
    depth drawn, the volume prefiltered) done before timing."""
    times, warmed = [], set()
    for network, (x, y) in networks_and_pixels:
        if id(network) not in warmed:
            network.pick("canvas", x, y)
            warmed.add(id(network))
        start = time.perf_counter()
        network.pick("canvas", x, y)
        times.append(time.perf_counter() - start)
    return float(np.median(times)) * 1e3


def shape_milliseconds(shape: str, voxel: float) -> dict[str, float]:
    """ms per pick without refinement (the ray caster in dvr mode) and with it (iso), by shape."""
    found = {}
    for label, compositing in (("GL depth", "dvr"), ("tricubic", "iso")):
        if shape == "torus":
            network = picking_shapes.torus_views(voxel, "linear")["overview"]
            pairs = [(network, pixel) for pixel in picking_shapes.overview_pixels()]
        else:
            network = picking_shapes.planes_view(voxel, "linear")
            middle, arm = picking_shapes.MIDDLE, picking_shapes.ARM_PIXELS
            pairs = [(network, (middle + dx, middle + dy)) for dx in (-arm, 0, arm) for dy in (-4, 0, 4)]
        network.set("rc.compositing", compositing)
        found[label] = median_pick_milliseconds(pairs)
    return found


def shape_table(shape: str, voxels) -> None:
    methods = picking_shapes.METHODS
    if shape == "torus":
        columns = [("surface", "surface error", "{:.4f}"), ("chords", "chord error", "{:.4f}"),
                   ("tube", "tube diameter error", "{:+.4f}"), ("outer", "outer diameter error", "{:+.4f}")]
        errors_of = picking_shapes.torus_errors
    else:
        columns = [("plane", "plane error", "{:.4f}"), ("vertex", "vertex off the ridge", "{:.4f}"),
                   ("angle", "angle error [deg]", "{:+.3f}")]
        errors_of = picking_shapes.planes_errors
    header = ["voxel"]
    for _, title, _ in columns:
        header += [f"{title} nearest", "linear", "tricubic"]
    print("| " + " | ".join(header + ["ms per pick: GL depth", "tricubic"]) + " |")
    print("|" + "---|" * (len(header) + 2))
    for voxel in voxels:
        found = errors_of(voxel)
        cells = [form.format(found[m][key]) for key, _, form in columns for m in methods]
        times = shape_milliseconds(shape, voxel)
        cells += [f"{times['GL depth']:.2f}", f"{times['tricubic']:.2f}"]
        print(f"| {voxel:g} | " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shape", choices=["sphere", "torus", "planes"], default="sphere")
    parser.add_argument("--voxels", type=float, nargs="+", default=[2.0, 1.0, 0.5])
    parser.add_argument("--margin", type=float, default=picking_sphere.MARGIN,
                        help="voxels of grid beyond the shape (the spline's mirrored border is that far)")
    args = parser.parse_args()
    picking_sphere.MARGIN = picking_shapes.MARGIN = args.margin
    if args.shape != "sphere":
        shape_table(args.shape, args.voxels)
        return
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
