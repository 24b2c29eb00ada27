"""Benchmark: vgraph's cubic B-spline prefilter against scipy.ndimage.spline_filter.

Usage:  python bench/bench_prefilter.py [--repeats N] [--sizes 64 128 256] [--out FILE.md]

For each size and input type (float32, uint8) both filters run on the same deterministic random
volume, alternately (so a busy machine slows both alike), and the best of N runs is kept, both as
wall time and as CPU time of the process (the CPU time is steadier when other programs share the
machine; with two threads it adds both threads up). speed-up = scipy wall time / our wall time
(> 1: ours is faster). max |diff| compares our float32 coefficients with scipy's float64 ones;
"in float32 ulps" divides it by the float32 spacing at the largest coefficient.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np
import scipy
from scipy import ndimage
from tqdm import tqdm

from vgraph.numerics.bspline import prefilter


def make_volume(size: int, dtype: str) -> np.ndarray:
    rng = np.random.default_rng(size)
    if dtype == "uint8":
        return rng.integers(0, 256, size=(size,) * 3, dtype=np.uint8)
    return (rng.random((size,) * 3) * 1000.0).astype(np.float32)


def best_times(volume: np.ndarray, repeats: int) -> dict:
    """Best wall and CPU seconds of `repeats` alternating runs, and the last results."""
    best = {"ours": [float("inf")] * 2, "scipy": [float("inf")] * 2}
    results = {}
    runners = {"scipy": lambda: ndimage.spline_filter(volume, order=3, mode="mirror"),
               "ours": lambda: prefilter(volume)}
    for _ in range(repeats):
        for name, runner in runners.items():
            wall, cpu = time.perf_counter(), time.process_time()
            results[name] = runner()
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            best[name] = [min(best[name][0], wall), min(best[name][1], cpu)]
    return {"best": best, "ours": results["ours"], "scipy": results["scipy"]}


def run(sizes: list[int], repeats: int) -> str:
    cases = [(size, dtype) for size in sizes for dtype in ("float32", "uint8")]
    rows = []
    for size, dtype in tqdm(cases, desc="prefilter benchmark", unit="case"):
        timing = best_times(make_volume(size, dtype), repeats)
        (ours_s, ours_cpu), (scipy_s, scipy_cpu) = timing["best"]["ours"], timing["best"]["scipy"]
        difference = float(np.abs(timing["ours"].astype(np.float64) - timing["scipy"]).max())
        ulp = float(np.spacing(np.float32(np.abs(timing["scipy"]).max())))
        rows.append(f"| {size}^3 | {dtype} | {ours_s:.4f} | {scipy_s:.4f} | {scipy_s / ours_s:.2f} | "
                    f"{ours_cpu:.4f} | {scipy_cpu:.4f} | {difference:.3g} | {difference / ulp:.2f} |")
    header = [
        f"Prefilter benchmark: best of {repeats} alternating runs, seconds. "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
        f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}.",
        "",
        "| size | input | ours s | scipy s | speed-up (scipy/ours) | ours CPU s | scipy CPU s "
        "| max abs diff | in float32 ulps |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    return "\n".join(header + rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256])
    parser.add_argument("--repeats", type=int, default=9, help="runs per case; the best counts")
    parser.add_argument("--out", type=Path, help="also write the markdown table to this file")
    args = parser.parse_args(argv)
    if args.repeats < 1 or any(size < 1 for size in args.sizes):
        parser.error("--repeats and --sizes must be positive")
    table = run(args.sizes, args.repeats)
    print(table)
    if args.out:
        args.out.write_text(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
