"""Benchmark (issue #33, item 2): bricks read until a frame under the GUI's load limit is complete,
with ray-guided requests (the BrickedRayCaster's single pass) and with the plan's read-ahead (its
pass per brick), on the same volume, camera and limit.

Usage:  python bench/bench_ray_requests.py [--volume FILE] [--size 256] [--brick 32] [--limit 64]

Per case both variants start cold (an empty brick cache) and draw frames under
LoadLimit(bricks=--limit) until last_frame["complete"]; printed: frames, bricks read in all (the
coarse frames' bricks included), the plan's level-0 bricks, and the complete frame's largest
difference from the in-core RayCaster (in 8-bit steps). Both variants plan the same bricks
(lod_bias -16: level 0); the single pass reads what its rays reached, the read-ahead every planned
brick. Numbers go to docs/explanations/bricked-ray-casting.md ("Ray-guided requests").
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from vgraph.bricks.cache import LoadLimit
from vgraph.camera import Camera
from vgraph.frame_context import FrameContext
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
WINDOW = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.4, 0.9, 0.0),
                                  (0.6, 1.0, 0.7, 0.2, 0.3), (1.0, 1, 1, 1, 0.6)])
OPAQUE = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.25, 0.2, 0.4, 0.9, 0.0),
                                  (0.35, 1.0, 0.7, 0.2, 1.0), (1.0, 1, 1, 1, 1.0)])
CASES = [("dvr translucent (WINDOW), termination 0.99", {"compositing": "dvr", "transfer_function": WINDOW}),
         ("dvr opaque surface, termination 0.99", {"compositing": "dvr", "transfer_function": OPAQUE}),
         ("mip", {"compositing": "mip", "transfer_function": WINDOW})]


def refine(network, size, limit: LoadLimit, frames: int = 200):
    """Frames until complete: (frames, bricks read, the complete image at sampling rate 1, seconds).
    A new frame each time: the sampling rate alternates between 1 and 1 + 1e-7 (a nudge moves a
    few mip pixels of the bonsai by steps), and the image compared is one drawn at 1."""
    read, began = 0, time.perf_counter()
    for number in range(frames):
        network.set("rc.sampling_rate", 1.0 + 1e-7 * (number % 2))
        image = np.asarray(network.evaluate("rc.image", size=size, context=FrameContext(load_limit=limit)))
        frame = network["rc"].last_frame
        read += frame["bricks_read"]
        if frame["complete"] and number % 2 == 0:
            return number + 1, read, image, time.perf_counter() - began
    raise RuntimeError(f"not complete after {frames} frames")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", default=str(DATA / "ct_bonsai" / "bonsai.nii.gz"))
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--brick", type=int, default=32)
    parser.add_argument("--limit", type=int, default=64, help="bricks a frame may read")
    args = parser.parse_args()
    volume = read_volume(args.volume)
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    size = (args.size, args.size)
    print(f"{args.volume}: {volume.dims}, {size[0]} x {size[1]}, bricks of {args.brick}, "
          f"LoadLimit(bricks={args.limit})")
    for name, properties in CASES:
        properties = {"shading": "none", "early_termination": 0.99, **properties}
        want = np.asarray(ray_caster_network(volume, camera, "RayCaster", **properties).evaluate("rc.image", size=size))
        print(f"{name}:")
        for label, method in (("plan read-ahead (passes)", "passes"), ("ray requests (single_pass)", "single_pass")):
            network = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=args.brick, lod_bias=-16.0,
                                         method=method, **properties)
            frames, read, image, seconds = refine(network, size, LoadLimit(bricks=args.limit))
            planned = sum(1 for key in network["rc"].cache.ram if key[0] == 0)
            steps = float(np.abs(image - want).max()) * 255.0
            print(f"  {label:>27}: {frames:3d} frames, {read:4d} bricks read ({planned} of level 0), "
                  f"{seconds:6.1f} s; complete frame within {steps:.2f} steps of 1/255 of the RayCaster", flush=True)


if __name__ == "__main__":
    main()
