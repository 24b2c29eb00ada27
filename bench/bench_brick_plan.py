"""Benchmark (issue #33): the CPU cost of a BrickedRayCaster frame's plan (which bricks, at which
level, in which order: vgraph.bricks.selection.plan_frame) and of the whole frame at a small image,
where the GL's share is small, against the in-core RayCaster's frame.

Usage:  python bench/bench_brick_plan.py [--volume FILE | --implicit FUNCTION:N] [--bricks 64 32]
                                         [--size 32] [--rounds 7]

Everything resident at level 0 (lod_bias -16), dvr with bench_paged_bricks's window TF, both methods.
Each frame is re-planned (the sampling rate is nudged so the processor evaluates again); the
variants take turns frame by frame (bench/interleave.py). Per variant: ``plan``, the CPU time of
the calling thread inside plan_frame per frame, and ``frame``, the calling thread's CPU time of
the whole frame (Python, numpy and the GL calls it makes; llvmpipe's rasterising threads are not
counted), min / median / max ms. Thread CPU time, not the wall clock: steady on a machine that
other jobs share. Numbers go to docs/explanations/bricked-ray-casting.md ("The CPU's share of a
frame"); run it against an older tree with PYTHONPATH=<tree>/src to compare.
"""

from __future__ import annotations

import argparse
import time

import vgraph.bricks.brick_planning as planning_module
from vgraph.camera import Camera
from vgraph.implicit import sample
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network

from bench_paged_bricks import DATA, WINDOW
from interleave import interleaved, spread

PLAN_SECONDS: list = [0.0]  # thread CPU seconds spent in plan_frame since the last reset


def timed_plan_frame(plan_frame):
    """``plan_frame`` adding its thread CPU time to PLAN_SECONDS (BrickPlanning.plan calls it
    through its module, for both methods)."""
    def timed(*args, **kwargs):
        began = time.thread_time()
        try:
            return plan_frame(*args, **kwargs)
        finally:
            PLAN_SECONDS[0] += time.thread_time() - began
    return timed


def frame_of(network, size, plans: list):
    """A frame(argument) -> thread CPU seconds for interleaved(); the frame's plan seconds go to ``plans``."""
    count = [0]

    def frame(_argument) -> float:
        count[0] += 1
        network.set("rc.sampling_rate", 1.0 + 1e-6 * count[0])
        PLAN_SECONDS[0] = 0.0
        began = time.thread_time()
        network.evaluate("rc.image", size=size)
        seconds = time.thread_time() - began
        plans.append(PLAN_SECONDS[0])
        return seconds
    return frame


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", default=str(DATA / "ct_bonsai" / "bonsai.nii.gz"))
    parser.add_argument("--implicit", help="FUNCTION:N, a vgraph.implicit function sampled N^3 (uint8)")
    parser.add_argument("--size", type=int, default=32)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--bricks", type=int, nargs="+", default=[64, 32])
    args = parser.parse_args()
    if args.implicit:
        function, count = args.implicit.split(":")
        volume, args.volume = sample(function, int(count), "uint8"), f"implicit {args.implicit}"
    else:
        volume = read_volume(args.volume)
    planning_module.plan_frame = timed_plan_frame(planning_module.plan_frame)
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    size = (args.size, args.size)
    properties = {"shading": "none", "compositing": "dvr", "transfer_function": WINDOW}
    variants, plans, networks = {}, {}, {}
    plans["RayCaster"] = []
    variants["RayCaster"] = frame_of(ray_caster_network(volume, camera, "RayCaster", **properties), size,
                                     plans["RayCaster"])
    for brick in args.bricks:
        for method in ("passes", "single_pass"):
            label = f"{method} {brick}^3"
            network = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=brick, lod_bias=-16.0,
                                         method=method, **properties)
            plans[label], networks[label] = [], network
            variants[label] = frame_of(network, size, plans[label])
    seconds, _ = interleaved(variants, [None] * args.rounds, None)
    print(f"{args.volume}: {volume.dims}, {size[0]} x {size[1]}, {args.rounds} rounds, thread CPU ms "
          f"(min / median / max)")
    for label, values in seconds.items():
        line = f"  {label:>16}: frame {spread([v * 1e3 for v in values], 1)}"
        if label != "RayCaster":
            timed_plans = plans[label][1:]  # the warm-up frame's plan is not timed
            line += f"   plan {spread([v * 1e3 for v in timed_plans], 1)}"
            line += f"   ({networks[label]['rc'].last_frame['bricks']} bricks)"
        print(line, flush=True)


if __name__ == "__main__":
    main()
