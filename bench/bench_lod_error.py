"""Benchmark: error against frame time for the BrickedRayCaster's levels of detail, with and without
the error budget (max_error), on a smooth and a stiff (narrow) transfer function.

Usage:  python bench/bench_lod_error.py [--volume FILE] [--size 192] [--brick 32] [--repeats 3]

Transfer functions: smooth (a ramp over 0.3..1), stiff (a spike 0.02 wide at 0.45) and faint
(opacity 0.002..0.004, one colour: the regime where the bound lets levels coarsen). Rows per
transfer function: every level 0..n drawn everywhere (the footprint's choice replaced by
that level: a bench-only patch of selection.desired_levels), then the footprint asking for the
coarsest level (lod_bias 15) under max_error 1 (no budget), 0.5, 0.1 and 0.02. Each row gives the
frame time (median of ``repeats`` frames; the rows' frames are interleaved, one frame of each row
per round, each frame re-planned by nudging lod_bias by -1e-6 and back), the PSNR and the largest error of any
channel against the level-0 frame, and the frame's reported bound (last_frame["error_bound"]).
Unshaded dvr, no early termination, sampling rate 1. Numbers go to docs/reports/accuracy.md.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import vgraph.bricks.selection as selection
from vgraph.camera import Camera
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SMOOTH = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.4, 0.9, 0.0),
                                  (0.6, 1.0, 0.7, 0.2, 0.3), (1.0, 1, 1, 1, 0.6)])
STIFF = TransferFunction(points=[(0.0, 1.0, 0.8, 0.3, 0.0), (0.44, 1.0, 0.8, 0.3, 0.0), (0.45, 1.0, 0.8, 0.3, 0.8),
                                 (0.46, 1.0, 0.8, 0.3, 0.0), (1.0, 1.0, 0.8, 0.3, 0.0)])
# A faint, gentle TF (opacity 0.002 to 0.004 per sample, one colour): where the bound lets levels coarsen.
FAINT = TransferFunction(points=[(0.0, 0.9, 0.8, 0.6, 0.0), (0.2, 0.9, 0.8, 0.6, 0.002), (1.0, 0.9, 0.8, 0.6, 0.004)])
BUDGETS = (1.0, 0.5, 0.1, 0.02)
_desired_levels = selection.desired_levels
FORCED: dict = {}  # network id -> the level every brick asks for


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0.0 else 10.0 * np.log10(1.0 / mse)


def rows(volume, camera, tf, brick: int, levels: int):
    """(label, network, forced level or None) of every row of one transfer function."""
    common = dict(compositing="dvr", transfer_function=tf, shading="none", early_termination=1.0, brick_size=brick)
    out = [(f"level {level}", ray_caster_network(volume, camera, "BrickedRayCaster", lod_bias=0.0, **common), level)
           for level in range(levels)]
    out += [(f"lod_bias 15, max_error {budget:g}",
             ray_caster_network(volume, camera, "BrickedRayCaster", lod_bias=15.0, max_error=budget, **common), None)
            for budget in BUDGETS]
    return out


def frame(network, forced, size, odd: bool):
    """One re-planned frame: (image, seconds, last_frame)."""
    FORCED["level"] = forced
    rc = network["rc"]
    bias = 0.0 if forced is not None else 15.0
    network.set("rc.lod_bias", bias - 1e-6 * odd)
    began = time.perf_counter()
    image = np.asarray(network.evaluate("rc.image", size=size))
    return image, time.perf_counter() - began, dict(rc.last_frame)


def forced_levels(geometry, camera, size, level, lod_bias):
    wanted = _desired_levels(geometry, camera, size, level, lod_bias)
    return wanted if FORCED.get("level") is None else np.full_like(wanted, FORCED["level"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", default=str(DATA / "ct_bonsai" / "bonsai.nii.gz"))
    parser.add_argument("--size", type=int, default=192)
    parser.add_argument("--brick", type=int, default=32)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    selection.desired_levels = forced_levels
    volume = read_volume(args.volume)
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    size = (args.size, args.size)
    print(f"{args.volume}: {volume.dims}, {size[0]} x {size[1]} pixels, {args.brick}^3 bricks, unshaded dvr, "
          f"sampling rate 1, no early termination; error against the level-0 frame; median of {args.repeats}")
    for name, tf in (("smooth", SMOOTH), ("stiff", STIFF), ("faint", FAINT)):
        probe = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=args.brick)
        levels = len(probe["rc"].brick_source(volume).levels)
        table = rows(volume, camera, tf, args.brick, levels)
        times = {label: [] for label, *_ in table}
        results = {}
        for round_ in range(args.repeats + 1):  # round 0 warms (reads the bricks, compiles)
            for label, network, forced in table:
                image, seconds, last = frame(network, forced, size, bool(round_ % 2))
                if round_:
                    times[label].append(seconds)
                results[label] = image, last
        reference = results["level 0"][0]
        base = statistics.median(times["level 0"])
        print(f"\n{name} TF\n| row | frame ms | x level 0 | PSNR dB | max error | bound | levels | bricks |\n"
              f"|---|---|---|---|---|---|---|---|")
        for label, *_ in table:
            image, last = results[label]
            ms = statistics.median(times[label]) * 1e3
            error = float(np.abs(image - reference).max())
            print(f"| {label} | {ms:.0f} | {base * 1e3 / ms:.2f} | {psnr(image, reference):.1f} | {error:.3g} | "
                  f"{last['error_bound']:.3g} | {last['levels']} | {last['bricks']} |", flush=True)


if __name__ == "__main__":
    main()
