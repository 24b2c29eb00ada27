"""Benchmark: what a GL finish after each processor costs (``scheduler.evaluate(finish_each=True)``,
which the GUI and ``vgraph run --profile`` use so that each processor's time holds its GL work).

Usage:  python bench/bench_finish_each.py [--frames N] [--sizes 128 512] [--networks NAME ...]

For each network and frame size the camera is turned a little before every frame (so the ray
caster draws again, as in a drag) and the frame is evaluated and read back, alternately without
and with the finishes (a busy machine slows both alike). Prints the median frame time of each and
the share of the frame the per-processor times account for (finish_each's records against the
frame read back; without finishes the records miss the GL work that the readback waits for).
"""

from __future__ import annotations

import argparse
import statistics
import time

import vgraph
from vgraph.scheduler import evaluate

NETWORKS = ("raycast_head", "curvature_torus")


def camera_property(network) -> str:
    return next(f"{p.id}.camera" for p in network.processors.values() if "camera" in p.properties)


def frame(network, size, finish_each: bool) -> tuple[float, float]:
    """(wall seconds of one frame read back, sum of its per-processor records)."""
    start = time.perf_counter()
    report = evaluate(network, ["canvas"], size=size, finish_each=finish_each)
    network.output("canvas").to_numpy()
    return time.perf_counter() - start, sum(record.seconds for record in report.evaluated)


def measure(name: str, size: int, frames: int) -> dict:
    network = vgraph.load(f"networks/{name}.json")
    address = camera_property(network)
    camera = network.get(address)
    walls = {False: [], True: []}
    shares = {False: [], True: []}
    for number in range(frames + 2):
        for finish_each in (False, True):
            network.set(address, camera.rotate(0.01 * (2 * number + finish_each + 1), 0.0))
            wall, records = frame(network, (size, size), finish_each)
            if number >= 2:  # the first frames compile shaders and upload the volume
                walls[finish_each].append(wall)
                shares[finish_each].append(records / wall)
    return {key: (statistics.median(walls[key]), statistics.median(shares[key])) for key in walls}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=15)
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 512])
    parser.add_argument("--networks", nargs="+", default=list(NETWORKS))
    args = parser.parse_args()
    print("| network | size | frame, no finishes | frame, finish each | records / frame (no finishes) "
          "| records / frame (finish each) |")
    print("|---|---|---|---|---|---|")
    for name in args.networks:
        for size in args.sizes:
            result = measure(name, size, args.frames)
            (plain, plain_share), (finished, finished_share) = result[False], result[True]
            print(f"| {name} | {size}\u00b2 | {plain * 1000:.1f} ms | {finished * 1000:.1f} ms | "
                  f"{plain_share:.0%} | {finished_share:.0%} |")


if __name__ == "__main__":
    main()
