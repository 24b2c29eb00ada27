"""Benchmark: the segmentation processors (VolumeMorphology, ConnectedComponents, GradientMagnitude,
VolumeMath, VolumeMask) against the scipy.ndimage / scikit-image / numpy call each one equals, on
the 256^3 bonsai (spacing 1, so world sizes are voxel sizes) and its mask at the leaves' level.

Usage:  python bench/bench_volume_segmentation.py [--rounds N] [--data FOLDER] [--size N] [--out FILE.md]

Ours runs the processor's process() on fresh Volumes each time (what it works out from the values
is in its time, as in a first run); the reference is the library call on the bare arrays. The two
take turns, one run each per round, after an untimed warm-up (bench/interleave.py); min / median /
max seconds over the rounds go in the table. Numbers from a shared machine are labelled so.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage.measure import label as skimage_label

from filter_timing import bonsai, ours_against_reference, table_header
from vgraph.registry import registry
from vgraph.volume import Volume
from vgraph.volume_segmentation import ball_offsets

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LEAVES = 40  # the bonsai's leaves and trunk from here up (data README)
BALL = ball_offsets(2.0, (1.0, 1.0, 1.0))
STRUCTURE_26 = ndimage.generate_binary_structure(3, 3)


def _gradient(a):
    return np.sqrt(sum(g * g for g in np.gradient(a.astype(np.float32))))


# name -> (processor type, its properties, its inputs from (volume, mask), the reference on (array, mask array))
CASES = {
    "grey dilation, ball r 2": ("VolumeMorphology", {"radius": 2.0}, lambda v, m: {"volume": v},
                                lambda a, m: ndimage.grey_dilation(a, footprint=BALL)),
    "mask closing, ball r 2": ("VolumeMorphology", {"operation": "close", "radius": 2.0}, lambda v, m: {"volume": m},
                               lambda a, m: ndimage.binary_closing(m, structure=BALL)),
    "components, 26": ("ConnectedComponents", {}, lambda v, m: {"volume": m},
                       lambda a, m: ndimage.label(m, structure=STRUCTURE_26)),
    "components, 26 (scikit-image)": ("ConnectedComponents", {}, lambda v, m: {"volume": m},
                                      lambda a, m: skimage_label(m, connectivity=3)),
    "gradient, central": ("GradientMagnitude", {}, lambda v, m: {"volume": v}, lambda a, m: _gradient(a)),
    "gradient, Gaussian sigma 1": ("GradientMagnitude", {"method": "gaussian"}, lambda v, m: {"volume": v},
                                   lambda a, m: ndimage.gaussian_gradient_magnitude(a.astype(np.float32), 1.0)),
    "add two volumes": ("VolumeMath", {}, lambda v, m: {"first": v, "second": m},
                        lambda a, m: np.add(a, m, dtype=np.float32)),
    "mask by a second volume": ("VolumeMath", {"operation": "mask"}, lambda v, m: {"first": v, "second": m},
                                lambda a, m: np.where(m != 0, a, 0)),
    "mask by label 1": ("VolumeMask", {"keep": "1"}, lambda v, m: {"volume": v, "labels": m},
                        lambda a, m: np.where(np.isin(m, [1]), a, 0)),
}


def bench(volume: Volume, rounds: int) -> list[str]:
    mask_data = (volume.data >= LEAVES).astype(np.uint8)
    rows = []
    for name, (type_name, properties, inputs, reference) in CASES.items():
        processor = registry.get(type_name)("bench", **properties)
        fresh = lambda: (Volume(volume.data, spacing=volume.spacing),  # noqa: E731
                         Volume(mask_data, spacing=volume.spacing, holds_labels=True))
        rows.append(ours_against_reference(name, type_name, lambda: processor.process(**inputs(*fresh())),
                                           lambda: reference(volume.data, mask_data), rounds))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--size", type=int, default=256, help="N: the bonsai resampled to N^3 (linear)")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    volume = bonsai(args.data, args.size)
    header = table_header(volume, args.rounds)
    rows = bench(volume, args.rounds)
    if args.out:
        args.out.write_text("\n".join(header + rows) + "\n")


if __name__ == "__main__":
    main()
