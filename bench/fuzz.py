"""Fuzz the volume readers, ImageSource and the network loader for minutes, with time and memory
limits per case.

    .venv/bin/python bench/fuzz.py --minutes 40 [--target all | networks | nrrd,nhdr | ...]
    .venv/bin/python bench/fuzz.py --replay nrrd 1234        # one case again, in this process

Cases come from fuzz_cases.py beside this script: valid files of every format built from scratch and the
shipped networks, mutated (bit flips, truncations, header line edits, numbers replaced by
extremes, JSON documents edited). The only allowed outcomes are success and a VGraphError. Each
case runs in a worker process whose address space is limited (RLIMIT_AS: its size at start +
--address-space-mb), so a reader that allocates what a header claims fails instead of taking the
machine. A case is a failure when it raises anything else (MemoryError included), takes more
than --max-seconds, raises the worker's peak resident memory by more than --max-memory-mb, hangs
(killed after --kill-seconds) or kills the worker. Targets take turns, one case each, until the
time is up. Printed per target: cases run, outcomes by error type, failures; each failure is
saved under bench/results/fuzz/<target>/<seed>/ (the files, case.txt, traceback.txt).

The target ``cluster`` (part of ``all``) is bench/cluster_faults.py: renders on a LocalCluster of
two workers while a worker is killed, stopped or slowed, or every task hangs; it runs alongside
the file targets, in a process of its own, for the same minutes, and its counts are printed per
fault (``cluster:kill``, ``cluster:stop``, ...). Its allowed outcomes are the right picture and
the named exit-2 error (ClusterTaskError); a hang or anything else is a failure.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter, defaultdict
from pathlib import Path

from fuzz_cases import TARGETS, make_case, run_case

RESULTS = Path(__file__).resolve().parent / "results" / "fuzz"
CLUSTER = "cluster"  # bench/cluster_faults.py, run alongside in a process of its own


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.replay:
        return replay(*args.replay, int(args.address_space_mb * 2**20))
    known = (*TARGETS, CLUSTER)
    targets = known if args.target == "all" else tuple(args.target.split(","))
    unknown = set(targets) - set(known)
    if unknown:
        sys.exit(f"unknown target(s) {sorted(unknown)}; known: all, {', '.join(known)}")
    # an interrupted run (Ctrl-C, kill) still reports what it did
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    start = time.monotonic()
    files = tuple(t for t in targets if t != CLUSTER)
    cluster = ClusterFaults(args) if CLUSTER in targets else None
    counts, failures = fuzz(files, args) if files else (defaultdict(Counter), [])
    if cluster is not None:
        files += cluster.finish(counts, failures)
    report(files, counts, failures, args, (time.monotonic() - start) / 60)
    return 1 if failures else 0


class ClusterFaults:
    """bench/cluster_faults.py running alongside for the same minutes (its own process: it keeps
    a LocalCluster and must not share the file cases' address-space limit)."""

    def __init__(self, args):
        self.folder = Path(tempfile.mkdtemp(prefix="vgraph-fuzz-cluster-"))
        command = [sys.executable, str(Path(__file__).with_name("cluster_faults.py")), "--minutes",
                   str(args.minutes), "--json", str(self.folder / "counts.json")]
        if args.seed is not None:
            command += ["--seed", str(args.seed)]
        self.log = open(self.folder / "output.txt", "w")
        self.process = subprocess.Popen(command, stdout=self.log, stderr=subprocess.STDOUT)

    def finish(self, counts, failures) -> tuple[str, ...]:
        """Wait for it (a case in flight ends within its own deadline), add its counts per fault
        and its failures; the targets it reports under."""
        from cluster_faults import FAULTS, RESULTS as CLUSTER_RESULTS
        try:
            self.process.wait()
        except KeyboardInterrupt:  # a second Ctrl-C: stop it now, it reports what it finished
            self.process.send_signal(signal.SIGINT)
            self.process.wait()
        self.log.close()
        try:
            found = json.loads((self.folder / "counts.json").read_text())
        except (OSError, ValueError):
            found = {"counts": {}, "failures": [["none", 0, "bench/cluster_faults.py wrote no counts: "
                                                 + (self.folder / "output.txt").read_text()[-2000:]]]}
        for fault, outcomes in found["counts"].items():
            counts[f"{CLUSTER}:{fault}"].update(outcomes)
        for fault, seed, problem in found["failures"]:
            place = CLUSTER_RESULTS / str(seed)
            place.mkdir(parents=True, exist_ok=True)
            if not (place / "traceback.txt").exists():
                (place / "traceback.txt").write_text(problem)
            failures.append((f"{CLUSTER}:{fault}", seed, problem.splitlines()[0], place))
        shutil.rmtree(self.folder, ignore_errors=True)
        return tuple(f"{CLUSTER}:{fault}" for fault in FAULTS)


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=1.0)
    parser.add_argument("--target", default="all", help=f"all or a comma list of {', '.join(TARGETS)}")
    parser.add_argument("--seed", type=int, default=None, help="first seed (default: from the clock)")
    parser.add_argument("--max-seconds", type=float, default=3.0)
    parser.add_argument("--max-memory-mb", type=float, default=300.0)
    parser.add_argument("--address-space-mb", type=float, default=2048.0)
    parser.add_argument("--kill-seconds", type=float, default=30.0)
    parser.add_argument("--replay", nargs=2, metavar=("TARGET", "SEED"))
    return parser.parse_args(argv)


# --- the worker ----------------------------------------------------------------------------------
def worker(connection, address_space_bytes: int) -> None:
    """Runs cases sent as (target, seed, folder); answers (outcome, seconds, peak MB, traceback)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    limit_address_space(address_space_bytes)
    while (job := connection.recv()) is not None:
        target, seed, folder = job
        try:
            case = make_case(target, random.Random(seed))
        except Exception:  # a bug of the fuzzer itself: reported, and the run goes on
            connection.send(("generator failed", 0.0, 0.0, traceback.format_exc()))
            continue
        _reset_peak_memory()
        idle_kb = _status_kb("VmRSS")
        start = time.perf_counter()
        try:
            outcome, details = run_case(case, Path(folder)), None
        except BaseException as error:  # MemoryError and RecursionError are failures too
            outcome, details = f"raised {type(error).__name__}", traceback.format_exc()
        seconds = time.perf_counter() - start
        connection.send((outcome, seconds, (_status_kb("VmHWM") - idle_kb) / 1024, details))


def limit_address_space(extra_bytes: int) -> None:
    limit = _status_kb("VmSize") * 1024 + extra_bytes
    resource.setrlimit(resource.RLIMIT_AS, (limit, resource.RLIM_INFINITY))


def _status_kb(key: str) -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def _reset_peak_memory() -> None:
    """Linux resets VmHWM to the current resident size when 5 is written to clear_refs."""
    try:
        with open("/proc/self/clear_refs", "w") as clear:
            clear.write("5")
    except OSError:
        pass


class Worker:
    def __init__(self, address_space_bytes: int):
        context = multiprocessing.get_context("fork")
        self.connection, child = context.Pipe()
        self.process = context.Process(target=worker, args=(child, address_space_bytes), daemon=True)
        self.process.start()

    def run(self, target: str, seed: int, folder: Path, kill_seconds: float):
        """(outcome, seconds, peak MB, details); outcome 'hung' or 'worker died' when it did."""
        self.connection.send((target, seed, str(folder)))
        if not self.connection.poll(kill_seconds):
            self.stop()
            return "hung", kill_seconds, 0.0, f"no answer within {kill_seconds} s; killed"
        try:
            return self.connection.recv()
        except (EOFError, ConnectionResetError):
            self.process.join(5)
            return "worker died", 0.0, 0.0, f"exit code {self.process.exitcode}"

    def stop(self) -> None:
        if self.process.is_alive():
            self.process.kill()
        self.process.join(5)

    def close(self) -> None:
        if self.process.is_alive():
            self.connection.send(None)
            self.process.join(5)
        self.stop()


# --- the loop ------------------------------------------------------------------------------------
def fuzz(targets, args):
    counts: dict[str, Counter] = defaultdict(Counter)
    failures: list[tuple[str, int, str, Path]] = []
    try:
        _run_cases(targets, args, counts, failures)
    except KeyboardInterrupt:
        print("interrupted: the counts below are those of the cases finished", flush=True)
    return counts, failures


def _run_cases(targets, args, counts, failures) -> None:
    """Targets in turn, one case each, until the time is up; fills counts and failures."""
    # runs started a second apart draw from seed ranges a thousand apart: they do not overlap
    seed = args.seed if args.seed is not None else int(time.time() * 1000)
    deadline = time.monotonic() + 60 * args.minutes
    address_space = int(args.address_space_mb * 2**20)
    current = Worker(address_space)
    with tempfile.TemporaryDirectory(prefix="vgraph-fuzz-") as scratch:
        try:
            while time.monotonic() < deadline:
                for target in targets:
                    seed += 1
                    folder = Path(scratch) / f"{target}-{seed}"
                    folder.mkdir()
                    outcome, seconds, peak_mb, details = current.run(target, seed, folder,
                                                                     args.kill_seconds)
                    problem = judge(outcome, seconds, peak_mb, args)
                    if problem:
                        counts[target]["FAILED"] += 1
                        failures.append((target, seed, problem,
                                         save(target, seed, folder, problem, details)))
                    else:
                        counts[target][outcome] += 1
                    if not current.process.is_alive():
                        current = Worker(address_space)
                    shutil.rmtree(folder, ignore_errors=True)
        finally:
            current.close()


def judge(outcome: str, seconds: float, peak_mb: float, args) -> str | None:
    if outcome in ("hung", "worker died", "generator failed") or outcome.startswith("raised "):
        return outcome
    if seconds > args.max_seconds:
        return f"slow: {seconds:.1f} s ({outcome})"
    if peak_mb > args.max_memory_mb:
        return f"memory: peak +{peak_mb:.0f} MB ({outcome})"
    return None


def save(target: str, seed: int, folder: Path, problem: str, details: str | None) -> Path:
    place = RESULTS / target / str(seed)
    shutil.rmtree(place, ignore_errors=True)
    shutil.copytree(folder, place, symlinks=True, copy_function=_copy_case_file)
    try:
        case = make_case(target, random.Random(seed))
        entry, raw = case.entry, case.raw
    except Exception:  # the generator failed: the traceback says where
        entry = raw = "(no case: the generator failed)"
    (place / "case.txt").write_text(f"target: {target}\nseed: {seed}\nentry: {entry!r}\n"
                                    f"raw: {raw!r}\nproblem: {problem}\n"
                                    f"replay: .venv/bin/python bench/fuzz.py --replay {target} {seed}\n")
    (place / "traceback.txt").write_text(details or problem)
    return place


def _copy_case_file(source: str, target: str) -> None:
    """copy2, but a FIFO (a store case's) is made anew: opening one to copy it waits forever."""
    if Path(source).is_fifo():
        os.mkfifo(target)
    else:
        shutil.copy2(source, target)


def report(targets, counts, failures, args, minutes: float) -> None:
    total = sum(sum(c.values()) for c in counts.values())
    print(f"fuzzed {total} cases in {minutes:.1f} min (limits: {args.max_seconds:g} s, "
          f"+{args.max_memory_mb:g} MB resident, {args.address_space_mb:g} MB address space)")
    for target in targets:
        outcomes = counts[target]
        listing = ", ".join(f"{name} {n}" for name, n in sorted(outcomes.items()) if name != "FAILED")
        print(f"  {target:18s} {sum(outcomes.values()):7d} cases: {listing}; "
              f"failures {outcomes['FAILED']}")
    for target, seed, problem, place in failures:
        last = (place / "traceback.txt").read_text().strip().splitlines()[-1:]
        print(f"FAIL {target} seed {seed}: {problem}: {last[0] if last else ''} -> {place}")


def replay(target: str, seed: str, address_space_bytes: int) -> int:
    """One case again, in this process (under the same address-space limit), with the full
    traceback."""
    case = make_case(target, random.Random(int(seed)))
    limit_address_space(address_space_bytes)
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        outcome = run_case(case, Path(folder))
    print(f"{target} seed {seed}: {outcome} in {time.perf_counter() - start:.2f} s "
          f"(peak resident {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
