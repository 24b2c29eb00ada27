"""The tables of bench/distributed_costs.py's result (its JSON): constants, the check on 1 and 2
workers, the predictions for 4-64 workers."""

from __future__ import annotations

from interleave import spread

NAMES = {  # constant -> (what it is, unit scale, unit)
    "read": ("read one brick from the store (per brick)", 1e3, "ms"),
    "upload": ("upload one brick to the worker's GL context (per brick)", 1e3, "ms"),
    "build": ("build the shipped network on a worker", 1e3, "ms"),
    "cold": ("first frame of a fresh network beyond a warm one", 1e3, "ms"),
    "plan": ("warm frame of the whole picture drawing no brick (plan task)", 1e3, "ms"),
    "resolve": ("resolve frame of the leaves split", 1e3, "ms"),
    "roundtrip": ("scheduler round trip of a trivial task", 1e3, "ms"),
    "task": ("each further task queued on one worker", 1e3, "ms"),
    "mb": ("a task's result, per MiB (worker to client)", 1e3, "ms"),
    "composite": ("composite two partial accumulations (leaves)", 1e3, "ms"),
    "contention": ("a worker's frame while the other worker draws too (ratio)", 1.0, "x"),
}


def _text(s: dict, scale: float = 1.0, digits: int = 2) -> str:
    return f"{s['low'] * scale:.{digits}f} / {s['mid'] * scale:.{digits}f} / {s['high'] * scale:.{digits}f}"


def _splits(read) -> str:
    """Bricks read per worker: one split ('320 / 320') or those the rounds saw ('320 / 320 or 368 / 368')."""
    splits = read if read and isinstance(read[0], list) else [read]
    return " or ".join(" / ".join(map(str, split)) for split in splits)


def markdown(result: dict) -> str:
    size, costs = result["size"], result["costs"]
    lines = [f"Bonsai, {size[0]}x{size[1]}, BrickedRayCaster, OME-Zarr bricks of {result['brick']}^3, "
             f"{len(result['plans']['weights'])} planned bricks; LocalClusters of 1 and 2 single-threaded "
             f"workers; {result['rounds']} rounds, every cost and every checked frame once a round; "
             f"min / median / max over the rounds; {result.get('seconds', 0):.0f} s in all.", "",
             "| constant | min / median / max | unit |", "|---|---|---|"]
    for name, (what, scale, unit) in NAMES.items():
        lines.append(f"| {name}: {what} | {_text(costs[name], scale, 3 if unit == 'x' else 2)} | {unit} |")
    for grid in costs["slope"]:
        lines.append(f"| slope {grid}: per brick drawn, heaviest tile of {grid} "
                     f"({max(result['plans']['tiles'][grid])} bricks) | {_text(costs['slope'][grid], 1e3)} | ms |")
        lines.append(f"| fixed {grid}: that tile's frame without bricks | {_text(costs['fixed'][grid], 1e3)} | ms |")
        lines.append(f"| assemble {grid}: the client puts the tiles together | "
                     f"{_text(costs['assemble'][grid], 1e3)} | ms |")
    lines += ["", "Check (cold frames; model interval from every constant's min to its max):", "",
              "| split | grid | workers | measured s (min / median / max) | model s (low / mid / high) | "
              "error of the median | inside | bricks read per worker (measured; model) | "
              "busiest worker's reading s (in the frames; model) |",
              "|---|---|---|---|---|---|---|---|---|"]
    for c in result["checks"]:
        lines.append(f"| {c['split']} | {c['grid']} | {c['workers']} | {_text(c['measured'])} | {_text(c['model'])} | "
                     f"{c['error']:+.0%} | {'yes' if c['inside'] else 'NO'} | "
                     f"{_splits(c['bricks_read'])}; {' / '.join(map(str, c['bricks_modelled']))} | "
                     f"{_text(c['read_measured']) if 'read_measured' in c else '-'}; {c.get('read_modelled', 0):.2f} |")
    lines += ["", "Predictions, one worker per machine (contention 1; the other constants as measured here):",
              "", "| workers | tiles grid | bricks of the busiest worker (tiles) | tiles s (low / mid / high) | "
              "bricks of the busiest run (leaves) | leaves s (low / mid / high) |", "|---|---|---|---|---|---|"]
    for p in result["predictions"]:
        lines.append(f"| {p['workers']} | {p['grid']} | {p['tiles_bricks']} | {_text(p['tiles'])} | "
                     f"{p['leaves_bricks']} | {_text(p['leaves'])} |")
    lines += ["", "Contention by round: " + spread(result["contention"], 3)]
    return "\n".join(lines) + "\n"
