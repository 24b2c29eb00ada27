"""Benchmark: the BrickedRayCaster against the RayCaster on the same in-memory volume.

Usage:  python bench/bench_bricks.py [--volume FILE] [--size 256] [--repeats 4] [--bricks 32 64]

For each compositing mode (and dvr with early termination 0.99) both processors render the same
view at the finest level; the fastest of ``repeats`` frames is kept (each frame re-plans: the
sampling rate is nudged so the processor evaluates again). PSNR compares the bricked image with
the RayCaster's (dvr without early termination unless both terminate). Numbers go to
docs/explanations/bricked-ray-casting.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from vgraph.camera import Camera
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
WINDOW = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.4, 0.9, 0.0),
                                  (0.6, 1.0, 0.7, 0.2, 0.3), (1.0, 1, 1, 1, 0.6)])
CASES = [("dvr", {"transfer_function": WINDOW, "early_termination": 1.0}),
         ("dvr, termination 0.99", {"transfer_function": WINDOW, "early_termination": 0.99}),
         ("mip", {}), ("iso", {"iso_level": 0.3})]


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0.0 else 10.0 * np.log10(1.0 / mse)


def timed(network, size, repeats: int):
    """(image, fastest frame in seconds)."""
    network.evaluate("rc.image", size=size)
    times = []
    for k in range(repeats):
        network.set("rc.sampling_rate", 1.0 + 1e-6 * (k + 1))
        began = time.perf_counter()
        image = np.asarray(network.evaluate("rc.image", size=size))
        times.append(time.perf_counter() - began)
    return image, min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", default=str(DATA / "ct_bonsai" / "bonsai.nii.gz"))
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeats", type=int, default=4)
    parser.add_argument("--bricks", type=int, nargs="+", default=[32, 64])
    args = parser.parse_args()
    volume = read_volume(args.volume)
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    size = (args.size, args.size)
    print(f"{args.volume}: {volume.dims}, {size[0]} x {size[1]}")
    for name, properties in CASES:
        mode = name.split(",")[0]
        want, fast = timed(ray_caster_network(volume, camera, "RayCaster", compositing=mode,
                                              **{"shading": "none", **properties}),  # as the bricked one
                           size, args.repeats)
        row = [f"{name}: RayCaster {fast * 1e3:.0f} ms"]
        for brick in args.bricks:
            network = ray_caster_network(volume, camera, "BrickedRayCaster", compositing=mode, brick_size=brick,
                                         lod_bias=-16.0, **properties)
            image, seconds = timed(network, size, args.repeats)
            row.append(f"{brick}^3 bricks: {seconds * 1e3:.0f} ms ({network['rc'].last_frame['bricks']} drawn), "
                       f"PSNR {psnr(image, want):.1f} dB")
        print(" | ".join(row), flush=True)


if __name__ == "__main__":
    main()
