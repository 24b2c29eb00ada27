"""Benchmark: the volume filters (VolumeCrop, VolumeResample, VolumeSmooth, VolumeThreshold)
against the scipy.ndimage / scikit-image call each one equals, on the 256^3 bonsai.

Usage:  python bench/bench_volume_filters.py [--rounds N] [--data FOLDER] [--out FILE.md]

Ours runs the processor's process() on a fresh Volume each time (so the value range and histogram
it works out are in its time, as in a first run); the reference is the library call on the bare
array, with the same sizes in voxels. The two take turns, one run each per round, after an untimed
warm-up (bench/interleave.py); min / median / max seconds over the rounds go in the table.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage.filters import threshold_otsu

from interleave import interleaved, spread
from vgraph.io import read_volume
from vgraph.registry import registry
from vgraph.volume import Volume

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LOW, HIGH = 40, 80  # the bonsai's leaves and trunk (data README)

# name -> (processor type, its properties, the reference on the [z, y, x] uint8 array)
CASES = {
    "crop 128^3 (world box)": ("VolumeCrop", {"crop_box": (64, 64, 64, 191, 191, 191)},
                               lambda a: a[64:192, 64:192, 64:192].copy()),
    "resample to 128^3, linear": ("VolumeResample", {"spacing": (2.0, 2.0, 2.0)},
                                  lambda a: ndimage.zoom(a.astype(np.float32), 0.5, order=1, mode="nearest",
                                                         grid_mode=True)),
    "resample to 128^3, cubic": ("VolumeResample", {"spacing": (2.0, 2.0, 2.0), "interpolation": "cubic"},
                                 lambda a: ndimage.zoom(a.astype(np.float32), 0.5, order=3, mode="mirror",
                                                        grid_mode=True)),
    "Gaussian, sigma 2": ("VolumeSmooth", {"sigma": (2.0, 2.0, 2.0)},
                          lambda a: ndimage.gaussian_filter(a.astype(np.float32), 2.0)),
    "median, 3^3 voxels": ("VolumeSmooth", {"filter": "median", "size": (3.0, 3.0, 3.0)},
                           lambda a: ndimage.median_filter(a, 3)),
    "threshold to a mask": ("VolumeThreshold", {"lower": LOW / 255, "upper": HIGH / 255},
                            lambda a: ((a >= LOW) & (a <= HIGH)).astype(np.uint8)),
    "Otsu to a mask": ("VolumeThreshold", {"method": "otsu"},
                       lambda a: (a >= threshold_otsu(a)).astype(np.uint8)),
}


def timed(run) -> float:
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def bench(volume: Volume, rounds: int) -> list[str]:
    rows = []
    for name, (type_name, properties, reference) in CASES.items():
        processor = registry.get(type_name)("bench", **properties)
        fresh = lambda: Volume(volume.data, spacing=volume.spacing, origin=volume.origin)  # noqa: E731
        variants = {"ours": lambda _: timed(lambda: processor.process(volume=fresh())),
                    "scipy": lambda _: timed(lambda: reference(volume.data))}
        seconds, _ = interleaved(variants, [None] * rounds, None)
        ratio = np.median(seconds["ours"]) / np.median(seconds["scipy"])
        rows.append(f"| {name} | {type_name} | {spread(seconds['ours'])} | {spread(seconds['scipy'])} | {ratio:.2f} |")
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    volume = read_volume(args.data / "ct_bonsai" / "bonsai.nii.gz")
    header = [f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
              f"{volume.dims} {volume.data.dtype}, {args.rounds} rounds", "",
              "| filter | processor | ours s (min / median / max) | reference s | ours / reference |",
              "|---|---|---|---|---|"]
    print("\n".join(header), flush=True)
    rows = bench(volume, args.rounds)
    if args.out:
        args.out.write_text("\n".join(header + rows) + "\n")


if __name__ == "__main__":
    main()
