"""The CT bonsai resampled to N^3 uint16 (Retondaro 2008 resampled it to make "ctBonsai+"), written
slice by slice to a NumPy .npy file, so making a 2 GiB volume never holds it in memory.

    .venv/bin/python bench/resample_bonsai.py [--size 1024] [--out /tmp/vgraph-bench/bonsai1024.npy]

Trilinear: each output slice blends the two nearest input slices, then is zoomed in x and y
(scipy.ndimage.zoom, order 1); values scaled by 257 (uint8 -> uint16 full scale).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
BONSAI = ROOT.parent / "shared" / "data" / "ct_bonsai" / "bonsai.nii.gz"


def resample(size: int, out: Path, bonsai: Path = BONSAI) -> Path:
    from vgraph.io import read_volume
    source = read_volume(bonsai)  # bench/gpu/measure.py passes its carried copy
    data = source.data.astype(np.float32)
    n_in = data.shape[0]
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_suffix(".partial.npy")
    target = np.lib.format.open_memmap(partial, mode="w+", dtype=np.uint16, shape=(size, size, size))
    zoom = (size / data.shape[1], size / data.shape[2])
    for k in tqdm(range(size), desc=f"resampling to {size}^3", file=sys.stderr):
        z = k * (n_in - 1) / (size - 1)
        low = min(int(z), n_in - 2)
        blend = (1.0 - (z - low)) * data[low] + (z - low) * data[low + 1]
        target[k] = np.clip(np.rint(ndimage.zoom(blend, zoom, order=1) * 257.0), 0, 65535)
    target.flush()
    del target
    partial.replace(out)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    out = args.out or Path("/tmp/vgraph-bench") / f"bonsai{args.size}.npy"
    print(resample(args.size, out))


if __name__ == "__main__":
    main()
