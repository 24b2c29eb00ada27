"""Long leak check: every shipped network evaluated many times (each processor re-run in turn with
its downstream, as in tests/test_leaks.py), printing live GL textures and resident memory per
network and writing a plot of memory against evaluations.

    python bench/leak_check.py --evaluations 5000 [--out bench/results/leaks]
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

from tqdm import tqdm

import vgraph
from vgraph.leaks import repeated_evaluations, writers_redirected

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--evaluations", type=int, default=5000)
    parser.add_argument("--every", type=int, default=250, help="sample every N evaluations")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "leaks")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore")
    curves = {}
    print(f"{'network':28s} {'evaluations':>11s} {'seconds':>8s} {'textures first/last':>20s} "
          f"{'RSS MiB first/peak/last':>24s}")
    with tempfile.TemporaryDirectory() as scratch:
        for path in tqdm(sorted((REPO / "networks").glob("*.json")), desc="networks", leave=False):
            network = writers_redirected(vgraph.load(path), Path(scratch))
            start = time.perf_counter()
            samples = repeated_evaluations(network, args.evaluations, every=args.every)
            seconds = time.perf_counter() - start
            curves[path.stem] = samples
            rss = [s.resident_mb for s in samples]
            print(f"{path.stem:28s} {args.evaluations:11d} {seconds:8.1f} "
                  f"{samples[0].textures:>9d} / {samples[-1].textures:<8d} "
                  f"{rss[0]:8.0f} / {max(rss):5.0f} / {rss[-1]:5.0f}", flush=True)
    plot(curves, args.out / "leak_check.png")


def plot(curves, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, axis = plt.subplots(figsize=(8, 4.5))
    for name, samples in curves.items():
        axis.plot([s.evaluation for s in samples], [s.resident_mb for s in samples], label=name)
    axis.set_xlabel("evaluations of the network")
    axis.set_ylabel("resident memory (MiB)")
    axis.set_title("Resident memory over repeated evaluations (one process, networks in turn)")
    axis.legend(fontsize=6, ncol=2)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    print(f"plot: {path}")


if __name__ == "__main__":
    main()
