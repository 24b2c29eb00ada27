"""Seconds per frame of the CurvatureRaycaster per derivative mode and normalisation.

    .venv/bin/python bench/curvature_speed.py [--size 512] [--resolution 64] [--repeat 5]

Scene: the FunctionSelector torus (float32, resolution^3), the camera of networks/curvature_torus.json,
CurvatureRaycaster with its defaults (Gaussian curvature, Blinn-Phong shading), then the
CurvatureVolumeRaycaster with its defaults (mean curvature, two shells). Each frame changes
`attenuation` slightly so that the ray caster runs again (EntryExitPoints does not); the time
includes the read-back of the image (as a sink would). Prints markdown tables: best of `repeat`
runs, and the samples per covered pixel."""

from __future__ import annotations

import argparse
import time

from vgraph.camera import Camera
from vgraph.implicit import sample
from vgraph.numerics.bspline import prefilter
from vgraph.testing import ray_caster_network

CAMERA = Camera.looking_at_box((-0.8, -0.8, -0.25), (0.8, 0.8, 0.25), direction=(-0.3, -0.5, -1.0))


def frame_seconds(volume, size, repeat, processor="CurvatureRaycaster",
                  **properties) -> tuple[float, float]:
    # A given volume, not FunctionSelector -> CubicSplineProcessor: the prefilter is not timed.
    net = ray_caster_network(volume, CAMERA, processor, id="cr", **properties)
    net.evaluate("cr.image", size=(size, size))  # compile, upload
    best = float("inf")
    for k in range(repeat):
        net.set("cr.attenuation", 1.0 + 1e-4 * (k % 2 + 1))  # a uniform: the passes run again
        start = time.perf_counter()
        net.evaluate("cr.image", size=(size, size))
        best = min(best, time.perf_counter() - start)
    depth = net.evaluate("cr.depth", size=(size, size))
    covered = depth[..., 2] > 0
    return best, float(depth[covered, 2].mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    samples = sample("torus", args.resolution, "float32")
    coefficients = samples.with_data(prefilter(samples.data), is_spline_coefficients=True,
                                     declared_range=samples.value_range)
    print(f"torus {args.resolution}^3 float32, {args.size} x {args.size}, best of {args.repeat}\n")
    for processor in ("CurvatureRaycaster", "CurvatureVolumeRaycaster"):
        print(f"{processor}\n")
        print("| derivatives | linear s | exponential s | linear, no skipping s | samples per covered pixel |")
        print("|---|---|---|---|---|")
        for mode in ("forward", "central", "filtered", "tricubic", "tricubic_fast"):
            volume = coefficients if mode.startswith("tricubic") else samples
            runs = [frame_seconds(volume, args.size, args.repeat, processor, derivatives=mode, **extra)
                    for extra in ({}, {"normalization": "exponential"}, {"empty_space_skipping": False})]
            print(f"| {mode} | {runs[0][0]:.3f} | {runs[1][0]:.3f} | {runs[2][0]:.3f} | {runs[0][1]:.1f} |")
        print()

if __name__ == "__main__":
    main()
