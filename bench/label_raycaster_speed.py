"""Seconds per frame of the LabelRayCaster on networks/labels_engine.json (the engine CT as two
material labels, 256 x 256 x 128) at 512 x 512: composite and first_hit, with and without
empty-space skipping.

    .venv/bin/python bench/label_raycaster_speed.py [--size 512] [--repeat 3]

One untimed frame per setting first (compiles the program, builds the skip blocks); a timed frame
is the pass and the read-back of the image, forced by a change of the sampling rate by 1e-6 (which
leaves the picture as it is). Prints best and median seconds. Shared machines vary up to 2x between
runs: compare within one run."""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from vgraph.fileformat import load_network

NETWORK = Path(__file__).resolve().parents[1] / "networks" / "labels_engine.json"


def frame_seconds(network, size: int, repeat: int) -> list[float]:
    network.evaluate("labels.image", size=(size, size))
    seconds = []
    for i in range(repeat):
        network.set("labels.sampling_rate", 1.0 + 1e-6 * (i + 1))
        start = time.perf_counter()
        network.evaluate("labels.image", size=(size, size))
        seconds.append(time.perf_counter() - start)
    return seconds


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    network = load_network(NETWORK)
    print(f"{'compositing':12} {'skipping':9} {'best s':>7} {'median s':>9}")
    for mode in ("composite", "first_hit"):
        for skipping in (True, False):
            network.set("labels.compositing", mode)
            network.set("labels.empty_space_skipping", skipping)
            seconds = frame_seconds(network, args.size, args.repeat)
            print(f"{mode:12} {str(skipping):9} {min(seconds):7.3f} {statistics.median(seconds):9.3f}")


if __name__ == "__main__":
    main()
