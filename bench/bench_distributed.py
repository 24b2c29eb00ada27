"""Scaling of the cluster split on this machine, and a cost model fitted to it (issue #15).

    .venv/bin/python bench/bench_distributed.py [--size 512] [--out bench/results]

What it does, per data set (CT bonsai and CT engine from /work/shared/data, each converted to an
OME-Zarr store in a temporary folder and drawn by a BrickedRayCaster, so every worker reads the
bricks it needs from the store itself, as on a cluster with a shared file system):

1. Per-tile brick counts, in this process: for grids 1x1, 2x2, 4x4 and 8x8, each tile is drawn by a
   FRESH network through its sub-frustum (as a worker draws it) and its BrickCache's
   ``bricks_read`` / ``bytes_read`` are read afterwards. That is the bricks a tile's worker reads
   when it has read nothing before; the predictions for 4-64 workers use them.
2. Frames on a LocalCluster of 1 and 2 single-threaded workers, tiles split (grids 1x1, 2x1, 2x2,
   4x4) and leaves split (if ``split="leaves"`` works; NotImplementedError leaves it empty). Each
   configuration starts from workers that dropped their networks (cold: the network is built, the store read and
   uploaded) and is timed cold and then warm (same frame again: nothing read). The two clusters run
   side by side and --rounds rounds (default 3) measure every configuration on each cluster in turn,
   so load drift falls on all alike (issue #31); the table gives min / median / max. Bytes read per
   worker are MEASURED on the workers: the BrickCache stats of the networks each worker built,
   fetched with ``client.run``.
3. A cost model fitted (non-negative least squares) to the median cold frame times:
       time = setup + per_brick * bricks read by the busiest worker
                    + per_tile * tasks of the busiest worker + composite * parts composited
   and its predictions for 4, 8, 16, 32 and 64 workers (tiles: the smallest counted grid with a
   tile per worker, bricks per worker from step 1; leaves: the bricks divided evenly). ``--refit``
   does step 3 again on the saved measurements. The fit is unstable (its 64-worker prediction
   moved 7x between fits, issue #31): bench/distributed_costs.py composes the model from costs
   measured one by one instead (docs/reports/cluster-scaling.md).

Writes bench/results/distributed_scaling.md (tables, constants, predictions),
distributed_scaling.json and distributed_scaling.png.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from interleave import spread  # noqa: E402

# VGRAPH_BENCH_DATA: a copy of the data sets elsewhere (bench/gpu/run.sh carries one to a GPU machine)
DATA = Path(os.environ.get("VGRAPH_BENCH_DATA", "/work/shared/data"))
DATA_SETS = {"bonsai": DATA / "ct_bonsai" / "bonsai.nii.gz", "engine": DATA / "ct_engine" / "engine.nii.gz"}
BRICK = 32               # voxels per brick edge of the stores
LOD_BIAS = -4.0         # finer than any grid here asks for: level 0 everywhere (network_for)
GRIDS = [(1, 1), (2, 1), (2, 2), (4, 4)]
COUNT_GRIDS = [(1, 1), (2, 2), (4, 4), (8, 8)]
PREDICT = [4, 8, 16, 32, 64]


def network_for(store: Path):
    """VolumeSource (the store) -> EntryExitPoints -> BrickedRayCaster -> Canvas, framed from the front."""
    from vgraph.network import Network
    network = Network(base_dir=store.parent)
    for pid, kind in (("source", "VolumeSource"), ("eep", "EntryExitPoints"), ("rc", "BrickedRayCaster"),
                      ("canvas", "Canvas")):
        network.add(kind, id=pid)
    network.set("source.path", str(store))
    network.set("rc.transfer_function", "auto")
    network.set("rc.shading", "blinn_phong")
    network.set("rc.brick_size", BRICK)
    # Pinned to level 0: a tile currently picks its level from its own (smaller) viewport, so 4x4
    # tiles of a 512 picture drew level 1 and 8x8 level 2 (a coarser picture than one process).
    # With LOD_BIAS every configuration draws the same bricks at level 0 and the comparison is fair.
    network.set("rc.lod_bias", LOD_BIAS)
    network.link("eep.camera", "rc.camera", bidirectional=True)
    network.set("eep.camera", network.get("eep.camera").viewed_from("front"))
    for source, target in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit"), ("rc.image", "canvas.image")):
        network.connect(source, target)
    return network


def cache_stats(network) -> dict:
    """bricks_read and bytes_read summed over the network's BrickCaches (the bricked casters')."""
    from vgraph.bricks.cache import BrickCache
    total = {"bricks_read": 0, "bytes_read": 0}
    for processor in network.processors.values():
        cache = getattr(processor, "cache", None)
        if isinstance(cache, BrickCache):
            for key in total:
                total[key] += cache.stats[key]
    return total


def worker_stats() -> dict:
    """Runs on each worker (client.run): what its networks read so far."""
    from vgraph.distributed import worker
    total = {"bricks_read": 0, "bytes_read": 0}
    for network, _ in worker._NETWORKS.values():
        for key, value in cache_stats(network).items():
            total[key] += value
    return total


def forget_networks() -> None:
    """Runs on each worker (client.run): drop the built networks, so the next frame builds, reads
    and uploads again. (client.restart() would be colder but hangs here with GL-holding workers.)"""
    import gc

    from vgraph.distributed import worker
    worker._NETWORKS.clear()
    gc.collect()


def per_tile_counts(network, size) -> dict:
    """(C, R) -> [bricks_read of each tile drawn by a fresh network], and the whole frame's bytes."""
    from vgraph.distributed.worker import shipped
    from vgraph.distributed.tiles import cameras, cut, set_tile_cameras
    from vgraph.distributed.worker import build
    document, base_dir = shipped(network)
    counts = {}
    for grid in COUNT_GRIDS:
        bricks, nbytes, levels = [], [], set()
        for tile in cut(size, grid):
            fresh = build(document, base_dir)
            set_tile_cameras(fresh, cameras(fresh), tile, size)
            fresh.update("canvas", size=tuple(tile.rendered[2:]))
            stats = cache_stats(fresh)
            levels.update(fresh["rc"].last_frame.get("levels", []))
            bricks.append(stats["bricks_read"])
            nbytes.append(stats["bytes_read"])
        counts[f"{grid[0]}x{grid[1]}"] = {"bricks": bricks, "bytes": nbytes, "levels": sorted(levels)}
    return counts


def timed_render(client, network, split, grid, size):
    from vgraph.distributed import render
    start = time.perf_counter()
    render(network, client, split=split, tiles=grid, size=size)
    return time.perf_counter() - start


def open_client(stack, workers: int | str):
    """(client, number of workers): a LocalCluster of ``workers`` single-threaded processes, or (an
    address) the running cluster there with all its workers (its workers must see the temporary
    stores: run the bench with TMPDIR on the shared file system)."""
    from distributed import Client, LocalCluster
    if isinstance(workers, str):
        client = stack.enter_context(Client(workers, timeout=10))
        return client, len(client.scheduler_info()["workers"])
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Port 8787 is already in use", category=UserWarning)
        cluster = stack.enter_context(LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
            dashboard_address=None, silence_logs=50))
    return stack.enter_context(Client(cluster)), workers


def measure(client, network, split, grid, size) -> dict:
    """One configuration once: a cold frame (workers dropped their networks: built, read and uploaded
    again; the GL context stays), what each worker read, and the best of two warm frames."""
    client.run(forget_networks)
    try:
        cold = timed_render(client, network, split, grid, size)
    except NotImplementedError as error:
        return {"error": f"not implemented: {error}"}
    except Exception as error:  # e.g. the leaves split being written right now
        return {"error": f"{type(error).__name__}: {error}"}
    stats = client.run(worker_stats)
    return {"cold_s": cold,
            "bytes_per_worker": sorted((s["bytes_read"] for s in stats.values()), reverse=True),
            "bricks_per_worker": sorted((s["bricks_read"] for s in stats.values()), reverse=True),
            "warm_s": min(timed_render(client, network, split, grid, size) for _ in range(2))}


def run_clusters(worker_counts: list, networks: dict, size, rounds: int) -> list[dict]:
    """Every configuration on every cluster, in alternation: the clusters run side by side and each
    round measures every (data, split, grid) on each cluster in turn, so drift in the machine's load
    falls on all configurations alike (issue #31: measured in separate phases, one worker's tile took
    9.7 s in one phase and 6.8 s in the next). A row per configuration and cluster: the median cold
    and warm times, with every round's times beside them."""
    import contextlib
    configs = [("tiles", g) for g in GRIDS] + [("leaves", (1, 1))]
    samples, failed = {}, {}
    with contextlib.ExitStack() as stack:
        clients = [open_client(stack, workers) for workers in worker_counts]
        first = next(iter(networks.values()))
        for client, workers in clients:  # every worker makes its GL context once, before any timing
            timed_render(client, first, "tiles", (workers * 2, 1), (64, 64))
        for round_index in range(rounds):
            for name, network in networks.items():
                for split, grid in configs:
                    for client, workers in clients:
                        key = (name, workers, split, f"{grid[0]}x{grid[1]}" if split == "tiles" else "-")
                        if key in failed:
                            continue
                        sample = measure(client, network, split, grid, size)
                        print(round_index, key, sample, file=sys.stderr)
                        if "error" in sample:
                            failed[key] = sample["error"]
                        else:
                            samples.setdefault(key, []).append(sample)
    rows = []
    for key in sorted(set(samples) | set(failed), key=lambda k: (k[0], k[1], k[2] != "tiles", _count_or_zero(k[3]))):
        row = dict(zip(("data", "workers", "split", "grid"), key))
        if key in failed:
            rows.append({**row, "error": failed[key]})
            continue
        runs = samples[key]
        rows.append({**row, "cold_s": float(np.median([r["cold_s"] for r in runs])),
                     "cold_all": [r["cold_s"] for r in runs],
                     "warm_s": float(np.median([r["warm_s"] for r in runs])),
                     "warm_all": [r["warm_s"] for r in runs],
                     "bytes_per_worker": runs[0]["bytes_per_worker"],
                     "bricks_per_worker": runs[0]["bricks_per_worker"]})
    return rows


def _count_or_zero(grid: str) -> int:
    return _count(grid) if grid != "-" else 0


def fit(rows: list[dict]) -> dict:
    """Non-negative least squares of the cold times on (1, bricks of the busiest worker, tasks of
    the busiest worker, parts composited)."""
    from scipy.optimize import nnls
    good = [r for r in rows if "cold_s" in r]
    features, times = [], []
    for r in good:
        tasks = _tasks(r)
        features.append([1.0, max(r["bricks_per_worker"]), math.ceil(tasks / r["workers"]), tasks])
        times.append(r["cold_s"])
    a, b = np.array(features), np.array(times)
    coefficients, _ = nnls(a, b)
    predicted = a @ coefficients
    for r, p in zip(good, predicted):
        r["model_s"] = float(p)
    names = ["setup_s", "per_brick_s", "per_task_s", "composite_s"]
    model = dict(zip(names, map(float, coefficients)))
    model["rms_error_s"] = float(np.sqrt(np.mean((predicted - b) ** 2)))
    model["max_rel_error"] = float(np.max(np.abs(predicted - b) / b))
    model["points"] = len(good)
    return model


def _tasks(row) -> int:
    if row["split"] == "tiles":
        c, r = (int(v) for v in row["grid"].split("x"))
        return c * r
    return row["workers"]  # leaves: one run of bricks per worker


def predict(model: dict, counts: dict, total_bricks: int) -> list[dict]:
    """Per worker count: tiles on the smallest counted grid with at least one tile per worker,
    dealt heaviest first to the least loaded worker, whose bricks are summed (an upper bound: tiles
    of one worker that share bricks read them once); leaves: the frame's bricks divided evenly."""
    out = []
    for n in PREDICT:
        grid = min((g for g in counts if _count(g) >= n), key=_count)
        bricks = sorted(counts[grid]["bricks"], reverse=True)
        per_worker = math.ceil(len(bricks) / n)
        loads = [0] * n  # heaviest tile first to the least loaded worker (Dask balances by time, alike)
        for count in bricks:
            loads[loads.index(min(loads))] += count
        tiles_bricks = max(loads)
        tiles = (model["setup_s"] + model["per_brick_s"] * tiles_bricks + model["per_task_s"] * per_worker
                 + model["composite_s"] * len(bricks))
        leaves_bricks = math.ceil(total_bricks / n)
        leaves = model["setup_s"] + model["per_brick_s"] * leaves_bricks + model["per_task_s"] + model["composite_s"] * n
        out.append({"workers": n, "grid": grid, "tiles_bricks_per_worker": tiles_bricks,
                    "tiles_redundancy": sum(bricks) / max(total_bricks, 1),
                    "tiles_s": tiles, "leaves_bricks_per_worker": leaves_bricks, "leaves_s": leaves})
    return out


def _count(grid: str) -> int:
    c, r = (int(v) for v in grid.split("x"))
    return c * r


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    parser.add_argument("--scheduler", help="tcp://HOST:PORT of a running cluster to measure instead of "
                        "LocalClusters of 1 and 2 workers (a real-cluster check)")
    parser.add_argument("--rounds", type=int, default=3,
                        help="rounds of every configuration on every cluster in turn (the table gives "
                             "the median and the spread)")
    parser.add_argument("--refit", action="store_true",
                        help="fit, predict, tabulate and plot the measurements in OUT again (no runs)")
    args = parser.parse_args(argv)
    if args.refit:
        out = Path(args.out)
        result = json.loads((out / "distributed_scaling.json").read_text())
        return report(result, out)
    from vgraph.io.convert import convert
    size = (args.size, args.size)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="vgraph-bench-dist-") as folder:
        networks, counts = {}, {}
        for name, path in DATA_SETS.items():
            store = Path(folder) / f"{name}.zarr"
            convert(path, store, brick=BRICK, progress=False)
            networks[name] = network_for(store)
            counts[name] = per_tile_counts(networks[name], size)
            print(name, {g: sum(c["bricks"]) for g, c in counts[name].items()}, file=sys.stderr)
        rows = run_clusters([args.scheduler] if args.scheduler else [1, 2], networks, size, args.rounds)
    cluster = f"the cluster at {args.scheduler}" if args.scheduler else \
        "a LocalCluster of single-threaded workers on this machine"
    return report({"size": size, "brick": BRICK, "rows": rows, "counts": counts, "cluster": cluster,
                   "rounds": args.rounds}, out)


def report(result: dict, out: Path) -> int:
    """Fit, predict, write the JSON, the markdown tables and the plot."""
    result["model"] = model = fit(result["rows"])
    result["predictions"] = {name: predict(model, counts, sum(counts["1x1"]["bricks"]))
                             for name, counts in result["counts"].items()}
    (out / "distributed_scaling.json").write_text(json.dumps(result, indent=1))
    (out / "distributed_scaling.md").write_text(markdown(result))
    plot(result, out / "distributed_scaling.png")
    print(markdown(result))
    return 0


def markdown(result: dict) -> str:
    mb = 1 / 2 ** 20
    lines = [f"Frames {result['size'][0]}x{result['size'][1]}, BrickedRayCaster, OME-Zarr bricks of "
             f"{result['brick']}^3, on {result.get('cluster', 'a LocalCluster on this machine')}"
             + (f"; {result['rounds']} rounds, every configuration on every cluster in turn; times "
                "min / median / max, the model fitted to the medians." if "rounds" in result
                else "; each configuration measured once, in phases (before issue #31).") , "",
             "| data | workers | split | tiles | cold s | warm s | MB read per worker | bricks per worker | model s |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        if "cold_s" not in r:
            lines.append(f"| {r['data']} | {r['workers']} | {r['split']} | {r['grid']} | - | - | - | - | "
                         f"({r['error'][:60]}) |")
            continue
        lines.append(f"| {r['data']} | {r['workers']} | {r['split']} | {r['grid']} | {_times(r, 'cold')} | "
                     f"{_times(r, 'warm')} | {' / '.join(f'{b * mb:.1f}' for b in r['bytes_per_worker'])} | "
                     f"{' / '.join(map(str, r['bricks_per_worker']))} | {r.get('model_s', float('nan')):.2f} |")
    lines += ["", "Bricks read by each tile drawn alone (fresh network), summed over the tiles "
              "(redundancy = sum / bricks of the whole frame):", "",
              "| data | 1x1 | 2x2 | 4x4 | 8x8 |", "|---|---|---|---|---|"]
    for name, counts in result["counts"].items():
        whole = max(sum(counts["1x1"]["bricks"]), 1)
        cells = [f"{sum(c['bricks'])} ({sum(c['bricks']) / whole:.2f}x, levels {c['levels']})"
                 for c in counts.values()]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    m = result["model"]
    lines += ["", f"Model (NNLS on {m['points']} cold frames): setup {m['setup_s']:.3f} s, per brick "
              f"{m['per_brick_s'] * 1000:.2f} ms, per task {m['per_task_s'] * 1000:.1f} ms, per part "
              f"composited {m['composite_s'] * 1000:.1f} ms; rms error {m['rms_error_s']:.3f} s, "
              f"largest relative error {m['max_rel_error']:.0%}.", "",
              "| data | workers | tiles | bricks/worker (tiles) | redundancy | tiles s | bricks/worker (leaves) | leaves s |",
              "|---|---|---|---|---|---|---|---|"]
    for name, rows in result["predictions"].items():
        for p in rows:
            lines.append(f"| {name} | {p['workers']} | {p['grid']} | {p['tiles_bricks_per_worker']} | "
                         f"{p['tiles_redundancy']:.2f}x | {p['tiles_s']:.2f} | {p['leaves_bricks_per_worker']} | "
                         f"{p['leaves_s']:.2f} |")
    return "\n".join(lines) + "\n"


def _times(row: dict, which: str) -> str:
    """min / median / max over the rounds (one number from a run before rounds)."""
    if f"{which}_all" not in row:
        return f"{row[f'{which}_s']:.2f}"
    return spread(row[f"{which}_all"], 2)


def plot(result: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for name in result["counts"]:
        for split, marker in (("tiles", "o"), ("leaves", "s")):
            measured = [r for r in result["rows"] if r["data"] == name and r["split"] == split and "cold_s" in r]
            best = {}
            for r in measured:
                best[r["workers"]] = min(best.get(r["workers"], math.inf), r["cold_s"])
            if best:
                axes[0].plot(list(best), list(best.values()), marker, label=f"{name} {split} measured")
        pred = result["predictions"][name]
        axes[0].plot([p["workers"] for p in pred], [p["tiles_s"] for p in pred], "--", label=f"{name} tiles model")
        axes[0].plot([p["workers"] for p in pred], [p["leaves_s"] for p in pred], ":", label=f"{name} leaves model")
        counts = result["counts"][name]
        whole = max(sum(counts["1x1"]["bricks"]), 1)
        tiles = [len(c["bricks"]) for c in counts.values()]
        axes[1].plot(tiles, [sum(c["bricks"]) / whole for c in counts.values()], "o-", label=f"{name} tiles")
    axes[1].axhline(1.0, color="gray", lw=1, label="leaves (each brick once)")
    axes[0].set(xscale="log", yscale="log", xlabel="workers", ylabel="cold frame time (s)",
                title="measured (1, 2 workers) and model (4-64)")
    axes[1].set(xscale="log", xlabel="tiles", ylabel="bricks read / bricks of the frame",
                title="bytes read: tiles against leaves")
    for ax in axes:
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    sys.exit(main())
