"""The costs of a distributed frame, each measured on its own, the model composed from them
(bench/cost_model.py), checked against cold frames on 1 and 2 workers, and its predictions for
4-64 workers with intervals (issue #31, item 4).

    nice -n 10 .venv/bin/python bench/distributed_costs.py [--size 256] [--rounds 3] [--out bench/results]

The CT bonsai (VGRAPH_BENCH_DATA, default /work/shared/data) becomes an OME-Zarr store of 32^3
bricks in a temporary folder, drawn by bench_distributed's network (BrickedRayCaster, level 0).
Two LocalClusters of single-threaded workers (1 and 2) run side by side. Each round measures, in
this order, every cost once (variants in turn, after one untimed warm-up of each):

- on the 1-worker cluster's worker, inside one task (no scheduler time in these): building the
  shipped network; its first frame (plan only, no brick) against a second one (``cold``, ``plan``);
  reading the whole picture's planned bricks into a fresh BrickCache, then uploading them (per
  brick); for the
  heaviest tile of every grid, warm frames drawing 0, half and all of its planned bricks
  (a LeafPass; ``fixed`` + ``slope`` * bricks, the line through the three); the resolve frame;
- on the client: a trivial task's round trip, 8 tasks queued on one worker, a 4 MiB result
  (per MiB), the client's assembly of each grid's tiles, one compositing of two partials;
- on the 2-worker cluster: the same full frame on one worker alone and on both at once
  (``contention``);
- then the check: cold frames (the workers dropped their networks) of tiles 1x1, 2x1, 2x2 and
  leaves, on each cluster in turn, with the bricks each worker read.

The constants are min / median / max over the rounds; the model at every constant's min and max
is the interval. Writes distributed_costs.json and distributed_costs.md to --out.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_distributed import (BRICK, DATA_SETS, forget_networks, network_for, open_client,  # noqa: E402
                               timed_render, worker_stats)
from cost_model import (Costs, Spread, TileWork, grid_for, in_turn, leaves_frame, predict, predict_tiles,  # noqa: E402
                        tiles_for)

GRIDS = ["1x1", "2x1", "2x2", "4x2", "4x4", "8x4", "8x8"]
CHECKS = [("tiles", "1x1"), ("tiles", "2x1"), ("tiles", "2x2"), ("leaves", "-")]
PREDICT = [4, 8, 16, 32, 64]
CASTER = "rc"
_STATE: dict = {}  # per worker process: the warm network of the render costs


# --- in a worker process -------------------------------------------------------------------------
def _grid(text: str) -> tuple[int, int]:
    return tuple(int(v) for v in text.split("x"))


def _leaf_frame(network, target, size, **leaf):
    """Seconds of one frame of ``target`` with a LeafPass(**leaf), the picture read back (the entry
    and exit points drawn again, as for a new tile); and the LeafPass."""
    from vgraph.bricks.selection import LeafPass
    from vgraph.frame_context import FrameContext
    network["eep"].invalidate()
    leaf = LeafPass(**leaf)
    start = time.perf_counter()
    network.update(target, size=tuple(size), context=FrameContext(leaf=leaf))
    network.output(target).to_numpy()
    return time.perf_counter() - start, leaf


def worker_plans(document, base_dir, target, size) -> dict:
    """Per grid, each tile's planned bricks ((key, rect) front to back) and rendered pixels; the
    whole picture's planned bricks and their weights (voxels)."""
    from vgraph.bricks.cache import brick_extent
    from vgraph.distributed.tiles import cameras, cut, set_tile_cameras
    from vgraph.distributed.worker import GL_LOCK, build
    with GL_LOCK:
        network = build(document, base_dir)
        full = cameras(network)
        plans = {}
        for grid in GRIDS:
            plans[grid] = []
            for tile in cut(size, _grid(grid)):
                set_tile_cameras(network, full, tile, size)
                _, leaf = _leaf_frame(network, target, tile.rendered[2:], bricks=[])
                plans[grid].append({"bricks": [[list(k), list(r)] for k, r in leaf.plan.bricks],
                                    "pixels": int(tile.rendered[2] * tile.rendered[3])})
        source = network[CASTER].brick_source(network[CASTER].inputs["volume"])
        whole = plans["1x1"][0]["bricks"]
        weights = [int(np.prod(stop - start)) for start, stop in (brick_extent(source, tuple(k)) for k, _ in whole)]
    del network
    gc.collect()
    return {"tiles": plans, "weights": weights}


def worker_round(document, base_dir, target, size, plans, heaviest, warm_up=False) -> dict:
    """One round of the worker's costs (see the module docstring), every variant once, in turn."""
    from vgraph.distributed.worker import GL_LOCK
    with GL_LOCK:
        seconds = _setup_costs(document, base_dir, target, size, plans)
        seconds |= _render_costs(document, base_dir, target, size, plans, heaviest, warm_up)
    return seconds


def _setup_costs(document, base_dir, target, size, plans) -> dict:
    from vgraph import gl_context
    from vgraph.bricks.cache import BrickCache
    from vgraph.distributed.worker import build
    start = time.perf_counter()
    network = build(document, base_dir)
    built = time.perf_counter() - start
    first, _ = _leaf_frame(network, target, size, bricks=[])
    second, _ = _leaf_frame(network, target, size, bricks=[])
    caster = network[CASTER]
    volume = caster.inputs["volume"]
    cache = BrickCache()
    cache.use_source(caster.brick_source(volume), volume.value_range)
    whole = plans["1x1"][0]["bricks"]
    # Every planned brick, in the frame's order, into one cache: a brick's read includes the cache's
    # bookkeeping, which grows with the bricks it holds (BrickCache._evict sums them all per insert).
    keys = [tuple(key) for key, _ in whole]
    start = time.perf_counter()
    for key in keys:
        cache.brick(key)
    read = (time.perf_counter() - start) / len(keys)
    ctx = gl_context.get_context()
    start = time.perf_counter()
    for key in keys:
        cache.texture(ctx, key)
    ctx.finish()
    upload = (time.perf_counter() - start) / len(keys)
    cache.clear()
    del network, caster, volume
    gc.collect()
    return {"build": built, "cold": first - second, "plan": second, "read": read, "upload": upload}


def _render_costs(document, base_dir, target, size, plans, heaviest, warm_up) -> dict:
    """Per grid: the heaviest tile drawn warm with 0, half and all its bricks -> (fixed, slope);
    then the resolve frame of the whole picture's accumulation."""
    from vgraph.distributed.tiles import cameras, cut, set_tile_cameras
    from vgraph.distributed.worker import build
    if "network" not in _STATE:
        _STATE["network"] = build(document, base_dir)
        _STATE["cameras"] = cameras(_STATE["network"])
    network, full = _STATE["network"], _STATE["cameras"]
    out, partial = {}, None
    for grid in GRIDS:
        index = heaviest[grid]
        tile = cut(size, _grid(grid))[index]
        bricks = [(tuple(k), tuple(r)) for k, r in plans[grid][index]["bricks"]]
        set_tile_cameras(network, full, tile, size)
        counts = [0, len(bricks) // 2, len(bricks)] if not warm_up else [len(bricks)]
        times = []
        for count in counts:
            elapsed, leaf = _leaf_frame(network, target, tile.rendered[2:], bricks=bricks[:count])
            times.append(elapsed)
        if grid == "1x1":
            partial = leaf.partial
        if not warm_up:
            slope, intercept = np.polyfit(counts, times, 1) if len(bricks) else (0.0, float(np.mean(times)))
            out[f"slope:{grid}"], out[f"fixed:{grid}"] = float(slope), float(intercept)
    for address, camera in full.items():
        network.set(address, camera)
    out["resolve"], _ = _leaf_frame(network, target, size, accumulated=partial)
    return out


def worker_full_frame(target, size, plans) -> float:
    """A cold frame's work without the scheduler (the contention check): the whole picture's
    bricks read into a fresh cache, then its warm frame with all of them, on the warm network."""
    from vgraph.bricks.cache import BrickCache
    from vgraph.distributed.worker import GL_LOCK
    bricks = [(tuple(k), tuple(r)) for k, r in plans["1x1"][0]["bricks"]]
    network = _STATE["network"]
    with GL_LOCK:
        start = time.perf_counter()
        volume = network[CASTER].inputs["volume"]
        cache = BrickCache()
        cache.use_source(network[CASTER].brick_source(volume), volume.value_range)
        for key, _ in bricks:
            cache.brick(key)
        cache.clear()
        return time.perf_counter() - start + _leaf_frame(network, target, size, bricks=bricks)[0]


def read_seconds() -> float:
    """Runs on each worker (client.run): seconds its networks' BrickCaches spent reading bricks."""
    from vgraph.bricks.cache import BrickCache
    from vgraph.distributed import worker
    return sum(p.cache.stats["read_seconds"] for network, _ in worker._NETWORKS.values()
               for p in network.processors.values() if isinstance(getattr(p, "cache", None), BrickCache))


def drop_state() -> None:
    _STATE.clear()
    gc.collect()


def noop() -> None:
    return None


def payload(mib: int) -> np.ndarray:
    return np.ones(mib * 2 ** 18, dtype=np.float32)


# --- on the client ---------------------------------------------------------------------------------
def client_round(client, size) -> dict:
    """The scheduler's and the client's costs, once each."""
    from distributed_costs import noop, payload
    from vgraph.distributed.leaves import composite
    from vgraph.distributed.tiles import assemble, cut
    out = {}
    start = time.perf_counter()
    client.submit(noop, pure=False).result()
    out["roundtrip"] = time.perf_counter() - start
    start = time.perf_counter()
    client.gather([client.submit(noop, pure=False) for _ in range(8)])
    out["task"] = max(time.perf_counter() - start - out["roundtrip"], 0.0) / 7
    start = time.perf_counter()
    client.submit(payload, 4, pure=False).result()
    out["mb"] = max(time.perf_counter() - start - out["roundtrip"], 0.0) / 4
    for grid in GRIDS:
        tiles = cut(size, _grid(grid))
        parts = [np.ones((t.rendered[3], t.rendered[2], 4), np.float32) for t in tiles]
        start = time.perf_counter()
        assemble(size, tiles, parts)
        out[f"assemble:{grid}"] = time.perf_counter() - start
    rng = np.random.default_rng(0)
    front, back = [tuple(rng.random((size[1], size[0], 4), dtype=np.float32) for _ in range(2)) for _ in range(2)]
    start = time.perf_counter()
    composite(front, back, "dvr")
    out["composite"] = time.perf_counter() - start
    return out


def contention_round(client, workers, target, size, plans) -> dict:
    """The full frame on the first worker alone, then on both at once (each reports its own time)."""
    from distributed_costs import worker_full_frame
    alone = client.submit(worker_full_frame, target, size, plans, workers=[workers[0]], pure=False).result()
    both = client.gather([client.submit(worker_full_frame, target, size, plans, workers=[w], pure=False)
                          for w in workers])
    return {"contention": float(np.mean(both)) / alone}


def check_round(clients, network, size) -> list[dict]:
    """Every checked configuration's cold frame on each cluster in turn, with the bricks each worker
    read and the seconds its reading took (its BrickCache's own clock)."""
    from distributed_costs import read_seconds
    rows = []
    for split, grid in CHECKS:
        for client, workers in clients:
            client.run(forget_networks)
            seconds = timed_render(client, network, split, _grid(grid) if split == "tiles" else (1, 1), size)
            read = sorted((s["bricks_read"] for s in client.run(worker_stats).values()), reverse=True)
            reading = sorted(client.run(read_seconds).values(), reverse=True)
            rows.append({"split": split, "grid": grid, "workers": workers, "seconds": seconds, "bricks_read": read,
                         "read_seconds": reading})
            print(rows[-1], file=sys.stderr, flush=True)
    return rows


def costs_of(samples: list[dict], contention: list[float] | None) -> Costs:
    """The constants as Spreads over the rounds' samples (keys 'name' or 'name:grid')."""
    values: dict = {}
    for sample in samples:
        for key, value in sample.items():
            values.setdefault(key, []).append(value)
    plain, per_grid = {}, {"slope": {}, "fixed": {}, "assemble": {}}
    for key, column in values.items():
        name, _, grid = key.partition(":")
        (per_grid[name].__setitem__(grid, Spread.of(column)) if grid else plain.__setitem__(name, Spread.of(column)))
    plain["contention"] = Spread.of(contention) if contention else Spread(1.0, 1.0, 1.0)
    return Costs(**plain, **per_grid)


def tile_work(plans: dict, grid: str) -> list[TileWork]:
    return [TileWork(frozenset(tuple(k) for k, _ in tile["bricks"]), tile["pixels"]) for tile in plans["tiles"][grid]]


def modelled(costs: Costs, plans: dict, split: str, grid: str, workers: int, size) -> Spread:
    if split == "leaves":
        return predict(costs, leaves_frame, plans["weights"], size[0] * size[1], workers)
    return predict_tiles(costs, grid, tile_work(plans, grid), workers)


def checked(rows: list[dict], costs1: Costs, costs2: Costs, plans: dict, size) -> list[dict]:
    """Per checked configuration: the measured spread, the model's interval and its error."""
    table = []
    for split, grid in CHECKS:
        for workers, costs in ((1, costs1), (2, costs2)):
            runs = [r for r in rows if (r["split"], r["grid"], r["workers"]) == (split, grid, workers)]
            measured = Spread.of(r["seconds"] for r in runs)
            model = modelled(costs, plans, split, grid, workers, size)
            bricks = _modelled_bricks(plans, split, grid, workers)
            table.append({"split": split, "grid": grid, "workers": workers, "measured": measured.__dict__,
                          "model": model.__dict__, "error": measured.mid / model.mid - 1,
                          "inside": model.low <= measured.mid <= model.high,
                          # every split the rounds saw (the scheduler deals 2x2 on 2 workers either way)
                          "bricks_read": [list(b) for b in sorted({tuple(r["bricks_read"]) for r in runs})],
                          "bricks_modelled": bricks,
                          # the busiest worker's reading: in the frames (its cache's clock), in the model
                          "read_measured": Spread.of(max(r.get("read_seconds") or [0.0]) for r in runs).__dict__,
                          "read_modelled": bricks[0] * costs.pick("mid").read})
    return table


def _modelled_bricks(plans, split, grid, workers) -> list[int]:
    """The bricks the model has each worker read (busiest first; tiles dealt in turn)."""
    from vgraph.distributed.leaves import split_runs
    if split == "leaves":
        return sorted((b - a for a, b in split_runs(plans["weights"], workers)), reverse=True)
    tiles = tile_work(plans, grid)
    return sorted((len(frozenset().union(*(tiles[i].bricks for i in d))) if d else 0
                   for d in in_turn(len(tiles), workers)), reverse=True)


def predictions(costs: Costs, plans: dict, size) -> list[dict]:
    """4-64 workers, one machine each (contention 1): tiles on the grid with a tile per worker (and,
    in ``tiles_by_grid``, on every coarser-tiled grid that still has a tile per worker: what
    bench_distributed --scheduler measures), and leaves."""
    alone = Costs(**{**costs.__dict__, "contention": Spread(1.0, 1.0, 1.0)})
    out = []
    for workers in PREDICT:
        grid = grid_for(workers, GRIDS)
        by_grid = {g: modelled(alone, plans, "tiles", g, workers, size).__dict__
                   for g in GRIDS if tiles_for(g) >= workers}
        out.append({"workers": workers, "grid": grid, "tiles": by_grid[grid], "tiles_by_grid": by_grid,
                    "leaves": modelled(alone, plans, "leaves", "-", workers, size).__dict__,
                    "tiles_bricks": _modelled_bricks(plans, "tiles", grid, workers)[0],
                    "leaves_bricks": _modelled_bricks(plans, "leaves", "-", workers)[0]})
    return out


def measure(size, rounds: int, store: Path) -> dict:
    # The tasks' functions by reference to this module as the workers import it (run as a script,
    # __main__'s would travel by value, with a copy of _STATE each time).
    import distributed_costs as here
    network = network_for(store)
    from vgraph.distributed.worker import shipped
    document, base_dir = shipped(network)
    target = "canvas"
    samples, contention, rows = [], [], []
    with contextlib.ExitStack() as stack:
        clients = [open_client(stack, n) for n in (1, 2)]
        (one, _), (two, _) = clients
        for client, workers in clients:  # the bench's modules on the workers; GL contexts made
            client.run(sys.path.insert, 0, str(HERE))
            timed_render(client, network, "tiles", (workers * 2, 1), (64, 64))
        plans = one.submit(here.worker_plans, document, base_dir, target, size, pure=False).result()
        heaviest = {g: int(np.argmax([len(t["bricks"]) for t in plans["tiles"][g]])) for g in GRIDS}
        pair = sorted(two.scheduler_info()["workers"])
        arguments = (document, base_dir, target, size, plans["tiles"], heaviest)
        one.submit(here.worker_round, *arguments, warm_up=True, pure=False).result()  # warm-ups
        two.gather([two.submit(here.worker_round, *arguments, warm_up=True, workers=[w], pure=False) for w in pair])
        client_round(one, size)
        for split in ("tiles", "leaves"):
            for client, _ in clients:
                timed_render(client, network, split, (2, 1), size)
        for round_index in range(rounds):
            sample = one.submit(here.worker_round, *arguments, pure=False).result()
            sample |= client_round(one, size)
            samples.append(sample)
            contention.append(contention_round(two, pair, target, size, plans["tiles"])["contention"])
            print(round_index, sample, contention[-1], file=sys.stderr, flush=True)
            rows += check_round(clients, network, size)
        for client, _ in clients:
            client.run(here.drop_state)
    costs1, costs2 = costs_of(samples, None), costs_of(samples, contention)
    return {"size": list(size), "brick": BRICK, "rounds": rounds, "samples": samples, "contention": contention,
            "rows": rows, "plans": {"weights": plans["weights"],
                                    "tiles": {g: [len(t["bricks"]) for t in plans["tiles"][g]] for g in GRIDS}},
            "checks": checked(rows, costs1, costs2, plans, size),
            "predictions": predictions(costs2, plans, size), "costs": _costs_json(costs2)}


def _costs_json(costs: Costs) -> dict:
    def one(value):
        return {k: one(v) for k, v in value.items()} if isinstance(value, dict) else value.__dict__
    return {name: one(value) for name, value in costs.__dict__.items()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=256, help="picture width and height (default 256)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args(argv)
    from distributed_costs_report import markdown
    from vgraph.io.convert import convert
    args.out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="vgraph-bench-costs-") as folder:
        store = Path(folder) / "bonsai.zarr"
        convert(DATA_SETS["bonsai"], store, brick=BRICK, progress=False)
        result = measure((args.size, args.size), args.rounds, store)
    result["seconds"] = time.perf_counter() - started
    (args.out / "distributed_costs.json").write_text(json.dumps(result, indent=1))
    (args.out / "distributed_costs.md").write_text(markdown(result))
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
