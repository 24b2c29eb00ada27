"""Seconds per frame of the RayCaster on llvmpipe for the four scenes of shared/PLATFORM.md's
peer table: a 256^3 float32 signed-distance volume rendered at 512 x 512, step 1 voxel.

    .venv/bin/python bench/raycaster_speed.py [--resolution 256] [--size 512] [--repeat 3]

Prints one row per scene: best and median seconds of --repeat timed frames (after one untimed
frame that compiles and uploads), with and without empty-space skipping, and the mean number of
samples evaluated per covered pixel (from the depth output's sample counter). A frame is the
RayCaster's pass and the read-back of its image. When ../shared/data is there, the same table
follows for the CT bonsai (256^3 uint8, mostly air). Timings on shared machines vary up to 2x
between runs: compare within one run."""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from vgraph import Network
from vgraph.camera import Camera
from vgraph.implicit import sample
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

BONSAI = Path(__file__).resolve().parents[2] / "shared" / "data" / "ct_bonsai" / "bonsai.nii.gz"

# The surface f = 0 sits at normalised intensity 0.5; the interior is brighter.
SURFACE_TF = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.49, 0.9, 0.6, 0.3, 0.0),
                                      (0.51, 1.0, 0.8, 0.5, 0.6), (0.53, 1.0, 1.0, 1.0, 0.0),
                                      (1.0, 1.0, 1.0, 1.0, 0.0)])
FOG_TF = TransferFunction(points=[(0.0, 0.5, 0.6, 1.0, 0.004), (1.0, 1.0, 0.9, 0.8, 0.012)])
BONSAI_TF = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.15, 0.3, 0.6, 0.2, 0.0),
                                     (0.3, 0.4, 0.8, 0.3, 0.3), (0.75, 0.8, 0.6, 0.4, 0.5),
                                     (1.0, 1.0, 1.0, 1.0, 0.9)])
SCENES = {
    "composite, mostly empty TF": dict(compositing="dvr", transfer_function=SURFACE_TF),
    "composite + shading": dict(compositing="dvr", transfer_function=SURFACE_TF,
                                shading="blinn_phong"),
    "MIP": dict(compositing="mip", transfer_function=SURFACE_TF),
    "dense fog TF (no empty space)": dict(compositing="dvr", transfer_function=FOG_TF),
}


def network(volume: Volume, camera: Camera) -> Network:
    # Unshaded unless a case says so, as docs/reports/performance.md's tables were measured (the RayCaster
    # now starts shaded).
    return ray_caster_network(volume, camera, "RayCaster", id="rc", sampling_rate=1.0, shading="none")


def time_frames(net: Network, size, repeat: int) -> list[float]:
    net.evaluate("rc.image", size=size)  # compile, upload, build blocks
    seconds = []
    for _ in range(repeat):
        net.processors["rc"].invalidate()
        start = time.perf_counter()
        net.evaluate("rc.image", size=size)  # reads the image back: the frame is finished
        seconds.append(time.perf_counter() - start)
    return seconds


def table(volume: Volume, scenes: dict, size, repeat: int) -> None:
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.45, -0.35, -1.0))
    net = network(volume, camera)
    print(f"{'scene':32s} {'skipping':>16s} {'no skipping':>16s} {'samples/pixel':>14s}")
    for name, properties in scenes.items():
        net.set("rc.shading", "none")
        for key, value in properties.items():
            net.set(f"rc.{key}", value)
        row = []
        for skipping in (True, False):
            net.set("rc.empty_space_skipping", skipping)
            seconds = time_frames(net, size, repeat)
            row.append(f"{min(seconds):7.3f} / {statistics.median(seconds):6.3f}")
            if skipping:
                depth = net.evaluate("rc.depth", size=size)
                covered = net.evaluate("eep.entry", size=size)[..., 3] > 0
                per_pixel = float(np.mean(depth[..., 2][covered]))
        print(f"{name:32s} {row[0]:>16s} {row[1]:>16s} {per_pixel:14.1f}")


def load_bonsai() -> Volume:
    import nibabel
    data = np.asarray(nibabel.load(BONSAI).dataobj)  # (x, y, z) -> [z, y, x]
    return Volume(np.ascontiguousarray(data.transpose(2, 1, 0)), source=str(BONSAI))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--function", default="torus")
    args = parser.parse_args()
    size = (args.size, args.size)
    volume = sample(args.function, args.resolution, "float32")
    print(f"{args.function} {args.resolution}^3 float32, {args.size}^2, sampling rate 1, "
          f"best / median of {args.repeat} (seconds per frame)")
    table(volume, SCENES, size, args.repeat)
    if BONSAI.is_file():
        print(f"\nct_bonsai 256^3 uint8, {args.size}^2, sampling rate 1")
        table(load_bonsai(), {"composite": dict(compositing="dvr", transfer_function=BONSAI_TF),
                              "composite + shading": dict(compositing="dvr", shading="blinn_phong",
                                                          transfer_function=BONSAI_TF),
                              "MIP": dict(compositing="mip", transfer_function=BONSAI_TF)},
              size, args.repeat)


if __name__ == "__main__":
    main()
