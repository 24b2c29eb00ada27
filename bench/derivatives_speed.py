"""Shaded frames with derivatives = central against precomputed, interleaved frame by frame in one
process, with unshaded composite as the baseline. Comparing separate bench_vtk runs does not work on
a shared machine: the load changes between them more than the modes differ.

    .venv/bin/python bench/derivatives_speed.py [--volume bonsai|torus] [--size 512] [--frames 10]

Same volume, camera orbit, TF and shading as bench_vtk's composite + shading row. Each mode's first
frame (compile, upload, and for precomputed the gradient volume) is untimed. The script prints
best and median seconds per mode, the per-frame ratio central / precomputed, and the largest 8-bit
difference between the two modes' images.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_vtk import OurRenderer, camera_sequence, load_volume, scenes  # noqa: E402

from vgraph.gl_context import get_context  # noqa: E402
from vgraph.gl.raycasting.gradient_volume import gradient_texture  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", choices=["torus", "bonsai"], default="bonsai")
    parser.add_argument("--resolution", type=int, default=256, help="torus voxels per axis")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--frames", type=int, default=10)
    args = parser.parse_args()
    volume = load_volume(args.volume, args.resolution)
    cameras = camera_sequence(volume, args.frames + 2, 3.0)
    rows = scenes(args.volume)
    start = time.perf_counter()
    gradient_texture(get_context(), volume)
    print(f"gradient volume built in {time.perf_counter() - start:.2f} s")
    renderers = {"composite": OurRenderer(volume, cameras[0], args.size, "central"),
                 "central": OurRenderer(volume, cameras[0], args.size, "central"),
                 "precomputed": OurRenderer(volume, cameras[0], args.size, "precomputed")}
    for name, renderer in renderers.items():
        renderer.configure(rows["composite" if name == "composite" else "composite + shading"])
        renderer.render(cameras[-1])  # untimed
    seconds = {name: [] for name in renderers}
    for frame in range(args.frames):
        for name, renderer in renderers.items():
            seconds[name].append(renderer.render(cameras[1 + frame]))
    for name, values in seconds.items():
        print(f"{name:12s} best {min(values):.3f} s, median {np.median(values):.3f} s")
    ratio = np.array(seconds["central"]) / np.array(seconds["precomputed"])
    print(f"central / precomputed per frame: {ratio.min():.2f} .. {ratio.max():.2f}, "
          f"median {np.median(ratio):.2f}")
    images = []
    for name in ("central", "precomputed"):
        renderers[name].render(cameras[0])
        images.append(renderers[name].image().astype(int))
    print(f"largest 8-bit difference between the two images: {np.abs(images[0] - images[1]).max()}")


if __name__ == "__main__":
    main()
