"""Benchmark: the volume filters (VolumeCrop, VolumeResample, VolumeSmooth, VolumeThreshold)
against the scipy.ndimage / scikit-image call each one equals, on the 256^3 bonsai.

Usage:  python bench/bench_volume_filters.py [--rounds N] [--data FOLDER] [--size N] [--out FILE.md]
        python bench/bench_volume_filters.py --chunked 512 [--budget MIB] [--brick 64] [--folder DIR]
                                             [--only Gaussian threshold ...]

Ours runs the processor's process() on a fresh Volume each time (so the value range and histogram
it works out are in its time, as in a first run); the reference is the library call on the bare
array, with the same sizes in voxels. The two take turns, one run each per round, after an untimed
warm-up (bench/interleave.py); min / median / max seconds over the rounds go in the table.

--chunked N: the filters on a store larger than its memory budget (vgraph.chunked_filtering), on
an N^3 float32 store generated slab by slab (a smooth field with noise; converted with vgraph
convert, bricks --brick), each filter in a fresh process with the budget --budget: seconds, voxels
per second, and the process's peak resident memory during the filter (VmHWM, reset before it)
above what it held after its imports (what the filter used; the store's size for comparison). Once per
filter: a run takes minutes.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage.filters import threshold_otsu

from chunked_runs import fresh_process_row, measure, table_columns
from filter_timing import bonsai, ours_against_reference, table_header
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


def bench(volume: Volume, rounds: int) -> list[str]:
    rows = []
    for name, (type_name, properties, reference) in CASES.items():
        processor = registry.get(type_name)("bench", **properties)
        fresh = lambda: Volume(volume.data, spacing=volume.spacing, origin=volume.origin)  # noqa: E731
        rows.append(ours_against_reference(name, type_name, lambda: processor.process(volume=fresh()),
                                           lambda: reference(volume.data), rounds))
    return rows


# name -> (processor type, its properties): the filters on a store, chunk by chunk
CHUNKED = {
    "Gaussian, sigma 2": ("VolumeSmooth", {"sigma": (2.0, 2.0, 2.0)}),
    "median, 3^3 voxels": ("VolumeSmooth", {"filter": "median", "size": (3.0, 3.0, 3.0)}),
    "threshold to a mask": ("VolumeThreshold", {"lower": 0.3, "upper": 0.7}),
    "Otsu to a mask": ("VolumeThreshold", {"method": "otsu"}),
    "crop 1/32 off each x, y side": ("VolumeCrop", {"units": "voxels"}),
    "resample, linear, spacing 1.5": ("VolumeResample", {"spacing": (1.5, 1.5, 1.5)}),
}


def make_store(size: int, brick: int, folder: Path) -> Path:
    """An N^3 float32 store: a .npy written slab by slab (never whole in memory), then converted."""
    from vgraph.io.convert import convert
    npy = folder / f"field{size}.npy"
    out = np.lib.format.open_memmap(npy, mode="w+", dtype=np.float32, shape=(size,) * 3)
    y, x = np.mgrid[0:size, 0:size] / size
    rng = np.random.default_rng(0)
    for z0 in range(0, size, 64):
        z = (np.arange(z0, min(size, z0 + 64)) / size)[:, None, None]
        field = 0.5 + 0.25 * np.sin(9 * x) * np.cos(7 * y) + 0.2 * np.sin(11 * z)
        out[z0:z0 + len(z)] = field + rng.normal(0, 0.05, (len(z), size, size))
    out.flush()
    del out
    store = folder / f"field{size}.zarr"
    convert(npy, store, brick=brick, progress=False)
    npy.unlink()
    return store


def run_one(store: str, type_name: str, properties: str, budget: float) -> None:
    """In this (fresh) process: one filter on the store; prints seconds and memory as JSON."""
    import importlib
    for module in ("dask.array", "dask_image.ndfilters", "skimage.filters"):  # code, not data:
        importlib.import_module(module)  # imported before the baseline
    from vgraph.bricks.volume import BrickedVolume
    volume = BrickedVolume.open(store, memory_budget_mb=budget)
    properties = json.loads(properties)
    if type_name == "VolumeCrop":
        n = volume.dims[0]
        properties["voxel_box"] = [n // 32, n // 32, 0, n - n // 32 - 1, n - n // 32 - 1, n - 1]
    processor = registry.get(type_name)("bench", **properties)
    measure(lambda: processor.process(volume=volume), int(np.prod(volume.dims)))


def bench_chunked(size: int, budget: float, brick: int, folder: Path, cases: dict) -> list[str]:
    store = make_store(size, brick, folder)
    stored = sum(f.stat().st_size for f in store.rglob("*") if f.is_file())
    rows = [f"{size}^3 float32 store ({4 * size**3 / 2**20:.0f} MiB of voxels, {stored / 2**20:.0f} MiB on disk), "
            f"bricks {brick}^3, memory budget {budget:g} MiB, {os.cpu_count()} cores", "", *table_columns("filter")]
    print("\n".join(rows), flush=True)
    for name, (type_name, properties) in cases.items():
        env = dict(os.environ, VGRAPH_CACHE=str(folder / "cache"))
        rows.append(fresh_process_row(name, type_name, [sys.executable, __file__, "--run-one", str(store), type_name,
                                                        json.dumps(properties), str(budget)], env))
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--size", type=int, default=256, help="N: the bonsai resampled to N^3 (linear)")
    parser.add_argument("--out", type=Path)
    parser.add_argument("--chunked", type=int, help="N: the filters on a generated N^3 store, chunk by chunk")
    parser.add_argument("--budget", type=float, default=256.0, help="the store's memory budget, MiB")
    parser.add_argument("--brick", type=int, default=64)
    parser.add_argument("--only", nargs="+", help="--chunked: only the filters whose names contain one of these words")
    parser.add_argument("--folder", type=Path, help="where the store and the filtered stores go (default: a temporary folder)")
    parser.add_argument("--run-one", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.run_one:
        store, type_name, properties, budget = args.run_one
        run_one(store, type_name, properties, float(budget))
        return
    if args.chunked:
        with tempfile.TemporaryDirectory(dir=args.folder) as folder:
            cases = {name: case for name, case in CHUNKED.items()
                     if not args.only or any(word in name for word in args.only)}
            rows = bench_chunked(args.chunked, args.budget, args.brick, Path(folder), cases)
        if args.out:
            args.out.write_text("\n".join(rows) + "\n")
        return
    volume = bonsai(args.data, args.size)
    header = table_header(volume, args.rounds)
    rows = bench(volume, args.rounds)
    if args.out:
        args.out.write_text("\n".join(header + rows) + "\n")


if __name__ == "__main__":
    main()
