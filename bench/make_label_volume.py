"""Make networks/data/engine_labels.nrrd, the label volume of networks/labels_engine.json: the engine
block CT (shared/data/ct_engine, 256 x 256 x 128 uint8) classified into two materials by its
histogram (docs: shared/data/README.md gives ~90 for the outer surface, ~200 for dense parts):

    0 background     value < 80
    1 casing         80 <= value < 175   (the aluminium block, 128-150 in the histogram)
    2 dense parts    value >= 175        (the denser inserts)

A 3 x 3 x 3 median filter of the labels removes single-voxel speckle of the scan's noise. Written
as gzip NRRD (uint8, spacing and origin of the CT), about 0.2 MB.

    python bench/make_label_volume.py [--source PATH] [--out PATH]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import ndimage

from vgraph.io import read_volume, write_volume
from vgraph.volume import Volume

REPO = Path(__file__).resolve().parents[1]
SOURCE = REPO.parent / "shared" / "data" / "ct_engine" / "engine.nii.gz"
OUT = REPO / "networks" / "data" / "engine_labels.nrrd"
THRESHOLDS = (80, 175)  # label k for values in [THRESHOLDS[k-1], THRESHOLDS[k])


def classify(values: np.ndarray) -> np.ndarray:
    """Labels 0, 1, 2 by the thresholds, speckle removed by a 3^3 median."""
    labels = np.digitize(values, THRESHOLDS).astype(np.uint8)
    return ndimage.median_filter(labels, size=3, mode="nearest")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=SOURCE)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    ct = read_volume(args.source)
    labels = Volume(classify(ct.data), spacing=ct.spacing, origin=ct.origin)
    write_volume(labels, args.out)
    counts = np.bincount(labels.data.ravel(), minlength=3)
    print(f"{args.out}: {' x '.join(map(str, labels.dims))} voxels, labels 0/1/2: {counts.tolist()}, "
          f"{args.out.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
