"""Benchmark: the segmentation processors (VolumeMorphology, ConnectedComponents, GradientMagnitude,
VolumeMath, VolumeMask) and cubic resampling on a store larger than its memory budget, chunk by
chunk into a new store (vgraph.chunked_segmentation).

Usage:  python bench/bench_chunked_segmentation.py --size 512 [--budget MIB] [--mask-budget MIB]
                 [--brick 16] [--folder DIR] [--only components gradient ...] [--out FILE.md]

The stores: bench_volume_filters' N^3 float32 field (a smooth field with noise, converted with
vgraph convert, bricks --brick) and its mask (VolumeThreshold at normalised level 0.6, made chunk
by chunk before the timings: a uint8 label store, a quarter of the field's bytes, so opened with
its own smaller budget --mask-budget to be over it). Each case runs once in a fresh process, as
bench_volume_filters --chunked: seconds (reading the
stores, computing, writing the new store with its pyramid), voxels per second, and the process's
peak resident memory during the processor (VmHWM, reset before it) above what it held after its
imports.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from bench_volume_filters import make_store
from chunked_runs import fresh_process_row, measure, table_columns
from vgraph.registry import registry

# name -> (processor, its properties, its inputs: port -> "field" or "mask")
CASES = {
    "grey dilation, ball r 2": ("VolumeMorphology", {"radius": 2.0}, {"volume": "field"}),
    "mask closing, ball r 2": ("VolumeMorphology", {"operation": "close", "radius": 2.0}, {"volume": "mask"}),
    "components, 26": ("ConnectedComponents", {}, {"volume": "mask"}),
    "components, 26, of the mask as float32": ("ConnectedComponents", {}, {"volume": "float mask"}),
    "gradient, central": ("GradientMagnitude", {}, {"volume": "field"}),
    "gradient, Gaussian sigma 1": ("GradientMagnitude", {"method": "gaussian"}, {"volume": "field"}),
    "add two volumes": ("VolumeMath", {}, {"first": "field", "second": "mask"}),
    "mask by label 1": ("VolumeMask", {"keep": "1"}, {"volume": "field", "labels": "mask"}),
    "resample, cubic, spacing 1.5": ("VolumeResample", {"spacing": (1.5, 1.5, 1.5), "interpolation": "cubic"},
                                     {"volume": "field"}),
}


def make_mask(field: Path, budget: float) -> Path:
    """The field's mask at normalised level 0.6, chunk by chunk (a label store in the cache)."""
    from vgraph.bricks.volume import BrickedVolume
    volume = BrickedVolume.open(field, memory_budget_mb=budget)
    mask = registry.get("VolumeThreshold")("mask", lower=0.6).process(volume=volume)
    assert mask.holds_labels
    return Path(mask.source)


def make_float_mask(mask: Path, brick: int, folder: Path) -> Path:
    """The mask as float32 0 / 1, written slab by slab and converted (four times its bytes, for
    ConnectedComponents under a budget below its size at 512^3: a uint8 mask in 16^3 bricks is
    smaller than the labelling's own working set there)."""
    from vgraph.bricks.volume import BrickedVolume
    from vgraph.io.convert import convert
    volume = BrickedVolume.open(mask, memory_budget_mb=1)
    npy = folder / "float_mask.npy"
    out = np.lib.format.open_memmap(npy, mode="w+", dtype=np.float32, shape=volume.shape)
    for z0 in range(0, volume.shape[0], 64):
        out[z0:z0 + 64] = volume.bricks.read(0, (z0, 0, 0), (z0 + 64, *volume.shape[1:]))
    out.flush()
    del out
    convert(npy, folder / "float_mask.zarr", brick=brick, progress=False)
    npy.unlink()
    return folder / "float_mask.zarr"


def run_one(stores: str, type_name: str, properties: str) -> None:
    """In this (fresh) process: one processor on the stores; prints seconds and memory as JSON."""
    import importlib
    for module in ("dask.array", "dask_image.ndfilters", "dask_image.ndmorph", "dask_image.ndmeasure",
                   "vgraph.numerics.bspline"):
        importlib.import_module(module)  # code, not data: imported before the baseline
    from vgraph.bricks.volume import BrickedVolume
    inputs = {port: BrickedVolume.open(path, memory_budget_mb=budget)
              for port, (path, budget) in json.loads(stores).items()}
    assert not any(volume.fits_budget for volume in inputs.values())
    processor = registry.get(type_name)("bench", **json.loads(properties))
    measure(lambda: processor.process(**inputs), int(np.prod(next(iter(inputs.values())).dims)))


def bench(size: int, budgets: dict, brick: int, folder: Path, cases: dict) -> list[str]:
    os.environ["VGRAPH_CACHE"] = str(folder / "cache")
    stores = {"field": make_store(size, brick, folder)}
    stores["mask"] = make_mask(stores["field"], budgets["field"])
    if any("float mask" in ports.values() for _, _, ports in cases.values()):
        stores["float mask"] = make_float_mask(stores["mask"], brick, folder)
    rows = [f"{size}^3 float32 store and its uint8 mask, bricks {brick}^3, memory budgets {budgets['field']:g} "
            f"and {budgets['mask']:g} MiB (the float32 mask: {budgets['field']:g}), {os.cpu_count()} cores", "",
            *table_columns("case")]
    print("\n".join(rows), flush=True)
    for name, (type_name, properties, ports) in cases.items():
        paths = json.dumps({port: (str(stores[kind]), budgets.get(kind, budgets["field"]))
                            for port, kind in ports.items()})
        rows.append(fresh_process_row(name, type_name, [sys.executable, __file__, "--run-one", paths, type_name,
                                                        json.dumps(properties)]))
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--budget", type=float, default=400.0, help="the field store's memory budget, MiB")
    parser.add_argument("--mask-budget", type=float, default=120.0, help="the mask store's memory budget, MiB")
    parser.add_argument("--brick", type=int, default=16)
    parser.add_argument("--only", nargs="+", help="only the cases whose names contain one of these words")
    parser.add_argument("--folder", type=Path, help="where the stores go (default: a temporary folder)")
    parser.add_argument("--out", type=Path)
    parser.add_argument("--run-one", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.run_one:
        run_one(*args.run_one)
        return
    cases = {name: case for name, case in CASES.items() if not args.only or any(w in name for w in args.only)}
    with tempfile.TemporaryDirectory(dir=args.folder) as folder:
        rows = bench(args.size, {"field": args.budget, "mask": args.mask_budget}, args.brick, Path(folder), cases)
    if args.out:
        args.out.write_text("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
