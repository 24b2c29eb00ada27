"""SweepPlaneRenderer (RZSweep) against the RayCaster: frame time on n^3 volumes and error against
the exact reference (docs/explanations/sweep-plane.md records the numbers).

    .venv/bin/python bench/bench_sweep_plane.py [--sizes 64 128] [--image 256] [--repeat 3]
        [--error-size 32] [--error-image 96]

Volumes: a Gaussian blob with a ripple (smooth), n^3 voxels over [-1, 1]^3. Both renderers draw
the same volume, TF (no shading), perspective camera and image size; each draws one untimed
warm-up frame (the sweep's numba compile or cache load, the RayCaster's shader compile), then
--repeat frames in turn with the same camera. The RayCaster runs on this machine's GL (llvmpipe
here: a CPU rasteriser, so both are CPU renderers) at sampling rate 1 and 4, with its
EntryExitPoints. The sweep's time is the whole processor (classification, sweep, image upload).
Error: PSNR (RGB) of each against the reference ray caster at 16 samples per min(spacing), on an
--error-size^3 volume at --error-image^2 (the reference is numpy: slow at larger sizes).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from vgraph.camera import Camera
from vgraph.network import Network
from vgraph.numerics import reference_raycast
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

TF = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.0), (0.3, 0.2, 0.6, 0.9, 0.05),
                              (0.7, 0.9, 0.7, 0.2, 0.3), (1.0, 1.0, 0.3, 0.1, 0.6)])
CAMERA = Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(-0.45, -0.35, -1.0))


def blob(n: int) -> Volume:
    g = np.linspace(-1.0, 1.0, n)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    field = np.exp(-(x * x + 1.5 * y * y + z * z) * 2.5) + 0.15 * np.sin(3 * x) * y
    return Volume(field.astype(np.float32), spacing=(2 / (n - 1),) * 3, origin=(-1.0, -1.0, -1.0))


def networks(volume: Volume) -> dict:
    sweep = Network()
    sweep.add(GivenVolume(id="src", volume=volume))
    sweep.add("SweepPlaneRenderer", id="rc", camera=CAMERA, transfer_function=TF)
    sweep.connect("src.volume", "rc.volume")
    return {"SweepPlaneRenderer": sweep,
            **{f"RayCaster rate {rate}": ray_caster_network(volume, CAMERA, transfer_function=TF, shading="none",
                                                            sampling_rate=rate) for rate in (1.0, 4.0)}}


def frame_seconds(network: Network, size, repeat: int) -> list[float]:
    network.evaluate("rc.image", size=size)  # warm-up
    owner = network.processors["eep" if "eep" in network.processors else "rc"]  # the RayCaster's is linked
    times = []
    for round_ in range(repeat):
        owner.camera = CAMERA.rotate(0.5 * (round_ + 1), 0.0)  # a new frame, not the cached one
        start = time.perf_counter()
        network.evaluate("rc.image", size=size)
        times.append(time.perf_counter() - start)
    return times


def psnr(a, b) -> float:
    return float(10.0 * np.log10(1.0 / np.mean((a[..., :3] - b[..., :3]) ** 2)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    parser.add_argument("--image", type=int, default=256)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--error-size", type=int, default=32)
    parser.add_argument("--error-image", type=int, default=96)
    args = parser.parse_args()
    size = (args.image, args.image)
    print(f"| volume | renderer | frame s (min / median / max), {args.image}^2 |")
    print("|---|---|---|")
    for n in args.sizes:
        for name, network in networks(blob(n)).items():
            times = frame_seconds(network, size, args.repeat)
            print(f"| {n}^3 | {name} | {min(times):.2f} / {statistics.median(times):.2f} / {max(times):.2f} |")
    volume, image = blob(args.error_size), (args.error_image, args.error_image)
    exact = reference_raycast.render(volume, CAMERA, TF, image, sampling_rate=16.0)
    print(f"\n| renderer | PSNR dB against the reference at rate 16 ({args.error_size}^3, {args.error_image}^2) |")
    print("|---|---|")
    for name, network in networks(volume).items():
        print(f"| {name} | {psnr(network.evaluate('rc.image', size=image), exact):.1f} |")


if __name__ == "__main__":
    main()
