"""One processor on stores over their memory budget, each run in a fresh process (bench_volume_filters
--chunked, bench_chunked_segmentation): the child measures seconds and the peak resident memory
above what it held after its imports (``measure``), the parent makes a markdown row of each
(``fresh_process_row``) under ``table_columns``."""

from __future__ import annotations

import json
import subprocess

from filter_timing import timed


def resident(field: str) -> int:
    """Bytes of VmRSS (resident now) or VmHWM (its peak since reset_peak_resident) of this process
    (ru_maxrss would carry the parent's peak across exec on Linux)."""
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) * 1024 for line in status if line.startswith(field + ":"))


def reset_peak_resident() -> None:
    with open("/proc/self/clear_refs", "w") as refs:
        refs.write("5")  # resets VmHWM to the current VmRSS (Linux proc(5))


def measure(run, voxels: int) -> None:
    """In the fresh process: ``run()`` timed, its peak resident memory and ``voxels`` printed as JSON."""
    before = resident("VmRSS")
    reset_peak_resident()
    seconds = timed(run)
    peak = resident("VmHWM")
    print(json.dumps({"seconds": seconds, "before": before, "peak": peak, "voxels": voxels}))


def table_columns(first: str) -> list[str]:
    """The table's header and rule; ``first`` names the first column (filter, case)."""
    return [f"| {first} | processor | s | M voxels / s | peak RSS above the baseline | baseline after imports |",
            "|---|---|---|---|---|---|"]


def fresh_process_row(name: str, type_name: str, command: list[str], env: dict | None = None) -> str:
    """The row of one case: ``command`` run (a script's --run-one, which calls ``measure``), or the
    last line of its error where it failed."""
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode:
        return f"| {name} | {type_name} | {done.stderr.strip().splitlines()[-1]} | | | |"
    result = json.loads(done.stdout.strip().splitlines()[-1])
    rate = result["voxels"] / result["seconds"] / 1e6
    return (f"| {name} | {type_name} | {result['seconds']:.1f} | {rate:.1f} | "
            f"{(result['peak'] - result['before']) / 2**20:.0f} MiB | {result['before'] / 2**20:.0f} MiB |")
