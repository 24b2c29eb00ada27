"""Fuzz the cluster with faults: render a small network on a LocalCluster of two worker processes
again and again while a random fault hits a worker that holds a task of the frame, for minutes.

    .venv/bin/python bench/cluster_faults.py --minutes 10 [--seed N] [--json counts.json]
    (bench/fuzz.py --target cluster, or --target all, runs it alongside the file targets)

A case draws the split (tiles: 2x2, 3x2 or 4x4; leaves: 2 to 5 runs of bricks), the fault and
how long after a task shows up on a worker it strikes (0 to 0.5 s):

- kill: SIGKILL (Dask reruns the worker's tasks; its nanny starts a new one)
- stop: SIGSTOP (the worker answers nobody: restarted after its task's allowance)
- slow: the worker's GL lock held for 60 s, past any allowance here (restarted)
- slow-short: held for 1-4 s, within the allowance (nothing to do but wait)
- hang: every task of the frame waits 600 s (a FaultPoint in the network): no worker can finish
- none: no fault

Every tile sleeps 0.1 s (FaultPoint) so that a fault finds a frame in flight. A case must end,
within --case-seconds, with the right picture (tiles: the single-process pixels bit for bit;
leaves: at least 50 dB PSNR against them and the 8-bit PNG within one level, as
docs/guide/distributed.md states) or a ClusterTaskError (exit 2 of vgraph run; the only right end of a
hang). Anything else is a failure: a wrong picture, another exception, or no end in time (a
hang: the cluster is then started afresh). Printed: cases per fault, outcomes, failures; each
failure is saved under bench/results/fuzz/cluster/<seed>/case.txt.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import tempfile
import time
import traceback
from collections import Counter, defaultdict
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from pathlib import Path

import numpy as np

FAULTS = ("kill", "stop", "slow", "slow-short", "hang", "none")
RESULTS = Path(__file__).resolve().parent / "results" / "fuzz" / "cluster"
PLUGIN = "vgraph.distributed.faults"
SIZE = (128, 96)
LEAVES_PSNR_FLOOR = 50.0  # dB against the single-process picture (docs/guide/distributed.md, Leaves)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=None, help="default: 1, or no limit with --cases")
    parser.add_argument("--cases", type=int, default=None, help="stop after this many cases")
    parser.add_argument("--seed", type=int, default=None, help="first seed (default: from the clock)")
    parser.add_argument("--case-seconds", type=float, default=180.0, help="a case that runs longer hangs")
    parser.add_argument("--json", type=Path, help="also write the counts and failures here")
    parser.add_argument("--verbose", action="store_true", help="a line per case")
    args = parser.parse_args(argv)
    start = time.monotonic()
    minutes = args.minutes if args.minutes is not None or args.cases is not None else 1.0
    counts, failures = run(cases=args.cases, minutes=minutes, seed=args.seed,
                           case_seconds=args.case_seconds, verbose=args.verbose)
    print_report(counts, failures, (time.monotonic() - start) / 60)
    if args.json:
        args.json.write_text(json.dumps({"counts": {k: dict(v) for k, v in counts.items()},
                                         "failures": failures}))
    return 1 if failures else 0


def run(cases: int | None = None, minutes: float | None = None, seed: int | None = None,
        folder: Path | None = None, case_seconds: float = 180.0, verbose: bool = False):
    """Run cases until ``cases`` are done or ``minutes`` are up; ({fault: Counter(outcome)},
    [(fault, seed, problem)]). Ctrl-C (SIGINT, SIGTERM) ends the run with what was done."""
    import signal

    from vgraph.distributed.faults import fault_network

    if threading_is_main():
        signal.signal(signal.SIGTERM, signal.default_int_handler)
    import warnings

    from vgraph.distributed.watch import ClusterWarning
    warnings.simplefilter("ignore", ClusterWarning)  # a restart is what a case expects
    seed = seed if seed is not None else int(time.time() * 1000)
    deadline = time.monotonic() + 60 * minutes if minutes is not None else float("inf")
    counts: dict[str, Counter] = defaultdict(Counter)
    failures: list[tuple[str, int, str]] = []
    done = 0
    with tempfile.TemporaryDirectory(prefix="vgraph-cluster-faults-") as scratch:
        folder = Path(folder or scratch)
        networks = {kind: fault_network(_made(folder / kind), **options)
                    for kind, options in (("sleepy", {"fault": "sleep", "seconds": 0.1}),
                                          ("hang", {"fault": "hang", "seconds": 600.0}))}
        references: dict = {}
        cluster = Cluster()
        try:
            while done < (cases if cases is not None else float("inf")) and time.monotonic() < deadline:
                seed += 1
                fault, outcome, problem = one_case(cluster, networks, references, seed, case_seconds)
                if verbose:
                    ended = outcome or problem.splitlines()[0]
                    print(f"seed {seed}: {draw(seed)[:3]} -> {ended}", flush=True)
                counts[fault]["FAILED" if problem else outcome] += 1
                if problem:
                    failures.append((fault, seed, problem))
                    save(fault, seed, problem)
                done += 1
        except KeyboardInterrupt:
            print("interrupted: the counts below are those of the cases finished", flush=True)
        finally:
            cluster.close()
    return counts, failures


def threading_is_main() -> bool:
    import threading
    return threading.current_thread() is threading.main_thread()


def _made(path: Path) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    return path


class Cluster:
    """The LocalCluster the cases share, started afresh after a case that hung."""

    def __init__(self):
        self.stack = self.client = None

    def get(self):
        import contextlib

        from distributed import Client

        from vgraph.distributed.cluster import local_cluster

        if self.client is None:
            self.stack = contextlib.ExitStack()
            cluster = self.stack.enter_context(local_cluster(2))
            self.client = self.stack.enter_context(Client(cluster))
        return self.client

    def close(self) -> None:
        if self.stack is not None:
            try:
                self.stack.close()
            except Exception:  # a cluster that hung may not close cleanly; the next one is new
                pass
        self.stack = self.client = None


def draw(seed: int):
    """(split, options, fault, settle seconds, slow seconds) of case ``seed``."""
    rng = random.Random(seed)
    split = rng.choice(("tiles", "leaves"))
    options = {"tiles": rng.choice(((2, 2), (3, 2), (4, 4)))} if split == "tiles" else \
        {"runs": rng.randint(2, 5)}
    fault = rng.choice(FAULTS)
    return split, options, fault, rng.uniform(0.0, 0.5), (60.0 if fault == "slow" else rng.uniform(1.0, 4.0))


def one_case(cluster: Cluster, networks: dict, references: dict, seed: int, case_seconds: float):
    """(fault, outcome, problem or None) of case ``seed``."""
    from vgraph.distributed import render
    from vgraph.distributed.faults import inject, resume, worker_pids
    from vgraph.distributed.watch import ClusterTaskError, TaskTimeout

    split, options, fault, settle, slow_seconds = draw(seed)
    network = networks["hang" if fault == "hang" else "sleepy"]
    client = cluster.get()
    client.wait_for_workers(2, timeout=60)
    pids = worker_pids(client)
    timeout = TaskTimeout(first=6.0, multiple=4.0, floor=4.0, attempts=2)  # short: cases end sooner
    outcome = problem = None
    with ThreadPoolExecutor(1, thread_name_prefix=f"vgraph-case-{seed}") as pool:
        result = pool.submit(render, network, client, split=split, size=SIZE, plugins=(PLUGIN,),
                             timeout=timeout, cluster="local:2", **options)
        try:
            hit = None
            if fault in ("kill", "stop", "slow", "slow-short"):
                is_ours = (lambda key: key.startswith("vgraph-tile-")) if split == "tiles" else \
                    (lambda key: key.startswith("vgraph-leaves-") and "-run" in key)
                hit = inject(client, fault.split("-")[0], is_ours, seconds=slow_seconds, settle=settle,
                             deadline=case_seconds, done=result.done)
            image = result.result(timeout=case_seconds)
            missed = hit is None and fault not in ("none", "hang")
            outcome = "picture (frame done first)" if missed else "picture"
            problem = wrong_picture(image, split, network, references)
            if fault == "hang":
                problem = "a frame whose every task hangs gave a picture"
        except ClusterTaskError:
            outcome = "exit-2 error"
        except FutureTimeout:
            where = stack_of(f"vgraph-case-{seed}")
            problem = f"hung: no end within {case_seconds:g} s; the render was at\n{where}"
        except Exception as error:  # noqa: BLE001 - any other end is what the bench looks for
            problem = f"raised {type(error).__name__}: {error}\n{traceback.format_exc()}"
        finally:
            resume(pids.values())
    if problem and problem.startswith("hung"):
        cluster.close()  # whatever is stuck in it goes with it
    return fault, outcome, problem


def stack_of(prefix: str) -> str:
    """Where the thread whose name starts with ``prefix`` is now (what a hung case waits on)."""
    import threading

    frames = sys._current_frames()
    for thread in threading.enumerate():
        if thread.name.startswith(prefix) and thread.ident in frames:
            return "".join(traceback.format_stack(frames[thread.ident]))
    return "(the thread is gone)"


def wrong_picture(image, split: str, network, references: dict) -> str | None:
    from vgraph.imagefile import to_uint8

    if "picture" not in references:  # the single-process picture (its FaultPoint sleeps once)
        references["picture"] = network.evaluate(size=SIZE)
    reference = references["picture"]
    if image.shape != reference.shape:
        return f"wrong picture: shape {image.shape}, expected {reference.shape}"
    if split == "tiles":
        return None if np.array_equal(image, reference) else \
            f"wrong picture: tiles differ from one process by {np.abs(image - reference).max():.3g}"
    mse = float(np.mean((image.astype(np.float64) - reference) ** 2))
    psnr = float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)
    levels = int(np.abs(to_uint8(image).astype(int) - to_uint8(reference)).max())
    if psnr < LEAVES_PSNR_FLOOR or levels > 1:
        return f"wrong picture: leaves at {psnr:.1f} dB, {levels} levels in 8 bits"
    return None


def save(fault: str, seed: int, problem: str) -> None:
    place = RESULTS / str(seed)
    place.mkdir(parents=True, exist_ok=True)
    split, options, _, settle, slow_seconds = draw(seed)
    (place / "case.txt").write_text(
        f"target: cluster\nfault: {fault}\nseed: {seed}\nsplit: {split} {options}\nsettle: {settle:.2f} s\n"
        f"slow: {slow_seconds:.1f} s\nproblem: {problem}\n"
        f"replay: .venv/bin/python bench/cluster_faults.py --cases 1 --seed {seed - 1}\n")
    (place / "traceback.txt").write_text(problem)


def print_report(counts, failures, minutes: float) -> None:
    total = sum(sum(c.values()) for c in counts.values())
    print(f"cluster faults: {total} cases in {minutes:.1f} min")
    for line in report_lines(counts):
        print(line)
    for fault, seed, problem in failures:
        print(f"FAIL cluster:{fault} seed {seed}: {problem.splitlines()[0]} -> {RESULTS / str(seed)}")


def report_lines(counts) -> list[str]:
    """One line per fault, as bench/fuzz.py prints its targets."""
    lines = []
    for fault in FAULTS:
        outcomes = counts.get(fault, Counter())
        listing = ", ".join(f"{name} {n}" for name, n in sorted(outcomes.items()) if name != "FAILED")
        lines.append(f"  {'cluster:' + fault:18s} {sum(outcomes.values()):5d} cases: {listing}; "
                     f"failures {outcomes.get('FAILED', 0)}")
    return lines


if __name__ == "__main__":
    sys.exit(main())
