"""Benchmark: what gradient opacity and a 2D transfer function cost the RayCaster per frame.

Usage:  python bench/bench_gradient_classification.py [--size 256] [--repeats 5]

networks/raycast_head.json (the CT head, shaded) renders the same view with its 1D TF, with a
gradient-opacity curve of 1 everywhere (the same picture: the cost alone), with a preset curve, with
a 2D TF, and with both (these show other voxels, so early termination and skipping differ); the fastest of ``repeats`` frames is kept (each
frame re-evaluates: the sampling rate is nudged). The gradient volume is built by the first frame
that needs it and not counted. Numbers go to docs/guide/gradient-classification.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from vgraph.fileformat import load_network
from vgraph.gradient_opacity import PRESETS as CURVES, GradientOpacity
from vgraph.transfer_function_2d import PRESETS as TABLES

REPO = Path(__file__).resolve().parents[1]
CASES = [("1D TF", {}),
         # The same picture: what the gradient fetch and the curve's look-up cost by themselves.
         ("+ gradient opacity 1 everywhere", {"gradient_opacity": GradientOpacity(points=[(0.0, 1.0), (1.0, 1.0)])}),
         ("+ gradient opacity (boundaries)", {"gradient_opacity": CURVES["boundaries"]}),
         ("2D TF", {"transfer_function_2d": TABLES["two-materials"]}),
         ("2D TF + gradient opacity", {"transfer_function_2d": TABLES["two-materials"],
                                       "gradient_opacity": CURVES["boundaries"]})]


def fastest_frame(network, size: int, repeats: int) -> float:
    network.evaluate("rc.image", size=(size, size))  # compiles, builds the gradient volume
    best = float("inf")
    for k in range(repeats):
        network.set("rc.sampling_rate", 1.0 + 1e-6 * (k + 1))  # a new frame, the same picture
        start = time.perf_counter()
        network.evaluate("rc.image", size=(size, size))
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(f"| {args.size}^2, CT head (quarter) shaded | fastest frame (ms) | vs the 1D TF |")
    print("|---|---|---|")
    base = None
    for name, properties in CASES:
        network = load_network(REPO / "networks" / "raycast_head.json")
        for key, value in properties.items():
            network.set(f"rc.{key}", value)
        seconds = fastest_frame(network, args.size, args.repeats)
        base = base or seconds
        print(f"| {name} | {1000 * seconds:.1f} | {seconds / base:.2f} x |")


if __name__ == "__main__":
    main()
