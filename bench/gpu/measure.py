"""vgraph on a real GPU (issue 31, item 5): frame times of the shipped networks and of the CT bonsai,
each image checked against llvmpipe's, then bench_distributed's scaling against its cost model.

    bench/gpu/run.sh [--budget 390]           # on the GPU machine (run.sh installs what travels)
    bench/gpu/run.sh --dry-run [--write-refs] # here, llvmpipe, tiny sizes (--write-refs: new references)

Phases, each inside its share of --budget seconds (a case that does not fit is skipped and the table
says so; the whole run, installation included, stays under 8 minutes):

1. Image checks: each case drawn at 256x256 and compared with the llvmpipe image of the same network
   in bench/gpu/refs/ (PNG, written by --dry-run --write-refs): passed when the PSNR over RGBA is
   at least PSNR_MIN dB (llvmpipe and a GPU differ in rounding and texture filtering, not in what
   they draw).
2. Frame times at 512^2 and 1024^2 (dry run: 64^2 and 96^2): one untimed frame (compile, upload),
   then REPEAT frames, each re-running every processor below the data sources and reading the
   image back (so the frame is finished). The bonsai is resampled to 512^3 and 1024^3 (trilinear,
   bench/resample_bonsai.py) on the machine: nothing that large travels.
3. bench/bench_distributed.py: LocalClusters of 1 and 2 single-threaded CPU workers (its cost model is
   fitted to them and predicts 4-64); then, if it fits, bench/distributed_costs.py (the model
   composed from measured costs, checked on 1 and 2 workers, two rounds); then clusters of 4, 8 and
   16 workers measured with --scheduler, each compared with both models' prediction for its tile
   grid (a bonsai frame outside the measured-costs interval falsifies that model on this machine).

Writes gpu_bench.md and gpu_bench.json to --out (default $OUT, else bench/results/gpu)."""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
REFS = HERE / "refs"
CHECK_SIZE = 256
PSNR_MIN = 30.0  # dB over RGBA 8 bit: llvmpipe against itself gives inf, a wrong picture under 20
NETWORKS = ["raycast_sphere", "raycast_head", "curvature_volume", "curvature_torus", "tets_bonsai",
            "tets_lox_post", "tets_disk_out_ref"]
# render_share: the part of the budget the frames may use before the remaining cases are skipped
# (bench_distributed gets the rest). The dry run gives it nearly all: here bench_distributed cannot
# finish in a test's minute anyway, and its row then says it was stopped at the budget.
FULL = {"sizes": [512, 1024], "bonsai": [256, 512, 1024], "repeat": 5, "workers": [1, 2, 4, 8, 16],
        "dist_size": 512, "budget": 390.0, "render_share": 0.5}
DRY = {"sizes": [64, 96], "bonsai": [256, 32], "repeat": 1, "workers": [1, 2, 4], "dist_size": 64,
       "budget": 40.0, "render_share": 0.85}
COSTS_SHARE, COSTS_MIN_S = 0.4, 60  # distributed_costs.py: its part of the time left, the least worth starting
COLUMNS = ["case", "volume", "size", "first_s", "best_s", "median_s", "check", "psnr_db", "note"]

sys.path.insert(0, str(ROOT / "bench"))


def data_folder() -> Path:
    """The data sets: the copy bench/gpu/prepare.sh made, else the shared folder beside the checkout."""
    carried = HERE / "data"
    return carried if carried.is_dir() else ROOT.parent / "shared" / "data"


def shipped_network(name: str, work: Path):
    """networks/NAME.json loaded from a copy whose ../../shared/data is the data folder."""
    import vgraph
    folder = work / "repo" / "networks"
    if not folder.is_dir():
        folder.mkdir(parents=True)
        (work / "shared").mkdir()
        (work / "shared" / "data").symlink_to(data_folder())
    shutil.copy(ROOT / "networks" / f"{name}.json", folder)
    return vgraph.load(folder / f"{name}.json")


def bonsai_network(resolution: int, work: Path):
    """The CT bonsai (resampled to resolution^3 unless 256) ray cast shaded, framed from the front-left."""
    from raycaster_speed import BONSAI_TF
    from resample_bonsai import resample
    from vgraph.camera import Camera
    from vgraph.io import read_volume
    from vgraph.numerics.reference_raycast import volume_box
    from vgraph.testing import ray_caster_network
    from vgraph.volume import Volume
    path = data_folder() / "ct_bonsai" / "bonsai.nii.gz"
    if resolution == 256:
        volume = read_volume(path)
    else:
        volume = Volume(np.load(resample(resolution, work / f"bonsai{resolution}.npy", path), mmap_mode="r"))
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.45, -0.35, -1.0))
    network = ray_caster_network(volume, camera, sampling_rate=1.0, shading="blinn_phong",
                                 transfer_function=BONSAI_TF)
    network.add("Canvas", id="canvas")
    network.connect("rc.image", "canvas.image")
    return network


def frame(network, size: int) -> np.ndarray:
    """Every processor that draws (has an Image outport) re-run, the canvas read back as 8-bit RGBA.
    Sources and mesh or volume filters (tetrahedralisation, derivatives) keep their output: the
    frame is the GPU's work, as when the camera moves."""
    from vgraph.image import Image
    for processor in network.processors.values():
        if any(issubclass(port.data_type, Image) for port in processor.outports):
            processor.invalidate()
    image = np.asarray(network.evaluate(size=(size, size)))
    if image.dtype != np.uint8:
        image = np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)
    return image


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


def check(network, name: str, write: bool) -> dict:
    from PIL import Image
    image = frame(network, CHECK_SIZE)
    ref = REFS / f"{name}.png"
    if write:
        REFS.mkdir(exist_ok=True)
        Image.fromarray(image).save(ref, optimize=True)
    if not ref.is_file():
        return {"check": "no reference", "psnr_db": None}
    value = psnr(image, np.asarray(Image.open(ref)))
    return {"check": "pass" if value >= PSNR_MIN else "FAIL", "psnr_db": round(value, 1)}


def timed(network, size: int, repeat: int) -> dict:
    start = time.perf_counter()
    frame(network, size)
    first = time.perf_counter() - start
    seconds = []
    for _ in range(repeat):
        start = time.perf_counter()
        frame(network, size)
        seconds.append(time.perf_counter() - start)
    return {"first_s": round(first, 4), "best_s": round(min(seconds), 4),
            "median_s": round(float(np.median(seconds)), 4)}


def render_phase(settings: dict, deadline: float, write_refs: bool, work: Path) -> list[dict]:
    """One row per case and size; a case whose first row did not fit before ``deadline`` is skipped."""
    cases = [(name, "-", lambda name=name: shipped_network(name, work)) for name in NETWORKS]
    cases += [(f"bonsai_{n}", f"{n}^3", lambda n=n: bonsai_network(n, work)) for n in settings["bonsai"]]
    rows = []
    for name, volume, make in cases:
        if time.monotonic() > deadline:
            rows += [dict.fromkeys(COLUMNS) | {"case": name, "volume": volume, "size": s, "check": "skipped",
                                               "note": "over the render phase's budget"} for s in settings["sizes"]]
            continue
        network = make()
        # Only the 256^3 bonsai has a llvmpipe reference: the resampled ones are too large for llvmpipe.
        checked = check(network, name, write_refs) if volume in ("-", "256^3") else \
            {"check": "n/a", "psnr_db": None}
        for size in settings["sizes"]:
            row = {"case": name, "volume": volume, "size": size, "note": ""} | checked
            row |= timed(network, size, settings["repeat"])
            rows.append(row)
            print(row, file=sys.stderr, flush=True)
        del network
    return rows


def distributed_phase(settings: dict, deadline: float, out: Path) -> tuple[list[dict], dict | None, dict]:
    """bench_distributed on 1+2 workers (its model), distributed_costs (costs_phase), then
    bench_distributed on clusters of the larger counts: the rows, the 1+2-worker result (model and
    predictions; None if it did not finish) and distributed_costs' result. ``out`` is a work
    folder: the run tool brings back at most 8 files, so its tables and plots stay there."""
    env = os.environ | {"VGRAPH_BENCH_DATA": str(data_folder())}
    source = ROOT / "bench" / "bench_distributed.py"
    script = [sys.executable, str(source), "--size", str(settings["dist_size"])]
    if "--rounds" in source.read_text():  # one round per configuration: four clusters must fit the budget
        script += ["--rounds", "1"]
    rows, base = [], out / "distributed_1_2"
    small = [n for n in settings["workers"] if n <= 2]
    status, seconds = _run(script + ["--out", str(base)], env, deadline)
    result = json.loads((base / "distributed_scaling.json").read_text()) if status == "ok" else None
    for n in small:
        rows.append(_readable(_measured_row, result, n, status, seconds))
    costs = costs_phase(settings, env, deadline, out / "costs")
    for n in (n for n in settings["workers"] if n > 2):
        if result is None or time.monotonic() + seconds * 1.5 > deadline:
            rows.append({"workers": n, "status": "skipped: " + ("no model (1+2 workers did not finish)"
                         if result is None else "would not fit the time budget")})
            continue
        status, seconds_n = _on_cluster(script, env, deadline, n, out / f"distributed_{n}")
        rows.append(_readable(_predicted_row, result, n, status, seconds_n, out / f"distributed_{n}"))
        _add_costs_model(rows[-1], costs)
    return rows, result, costs


def costs_phase(settings: dict, env: dict, deadline: float, out: Path) -> dict:
    """bench/distributed_costs.py (the model composed from measured costs, checked on 1 and 2
    workers, its intervals for more) at the distributed size, two rounds, in at most
    COSTS_SHARE of the time left; its JSON, or {"status": why not}."""
    left = deadline - time.monotonic()
    if left < COSTS_MIN_S:
        return {"status": f"skipped: {left:.0f} s left, it needs {COSTS_MIN_S} s"}
    script = [sys.executable, str(ROOT / "bench" / "distributed_costs.py"), "--size", str(settings["dist_size"]),
              "--rounds", "2", "--out", str(out)]
    status, seconds = _run(script, env, time.monotonic() + COSTS_SHARE * left)
    if status != "ok":
        return {"status": status, "phase_s": round(seconds, 1)}
    return json.loads((out / "distributed_costs.json").read_text()) | {"status": "ok", "phase_s": round(seconds, 1)}


def _add_costs_model(row: dict, costs: dict) -> None:
    """The measured-costs model's interval beside each bonsai case of a larger cluster (contention 1)."""
    predicted = {p["workers"]: p for p in costs.get("predictions", [])}.get(row["workers"], {})
    for case in row.get("cases", []):
        interval = predicted.get("tiles_by_grid", {}).get(case["grid"]) if case["data"] == "bonsai" else None
        if interval:
            case["costs_model"] = interval


def _readable(make_row, result, workers: int, *args) -> dict:
    """The row, or one saying that bench_distributed's JSON lacked what the row needs (a changed format)."""
    try:
        return make_row(result, workers, *args)
    except (KeyError, StopIteration, TypeError, ValueError, OSError) as error:
        return {"workers": workers, "status": f"ran, but its JSON was not understood: {type(error).__name__} {error}"}


def _run(command: list[str], env: dict, deadline: float) -> tuple[str, float]:
    """``command`` in a process group of its own, killed with the workers it spawned at ``deadline``."""
    start = time.monotonic()
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    try:
        _, stderr = process.communicate(timeout=max(deadline - start, 1))
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        _, stderr = process.communicate()
        print(f"{command[1]} stopped at the budget; its last lines:\n{stderr[-1500:]}", file=sys.stderr)
        return "killed at the time budget", time.monotonic() - start
    if process.returncode:
        print(stderr[-3000:], file=sys.stderr)
        return f"failed (exit {process.returncode})", time.monotonic() - start
    return "ok", time.monotonic() - start


def _on_cluster(script, env, deadline, workers: int, out: Path) -> tuple[str, float]:
    from distributed import LocalCluster
    os.environ["VGRAPH_BENCH_DATA"] = env["VGRAPH_BENCH_DATA"]
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None, silence_logs=50) as cluster:
        return _run(script + ["--scheduler", cluster.scheduler_address, "--out", str(out)], env, deadline)


def _measured_row(result, workers: int, status: str, seconds: float) -> dict:
    if result is None:
        return {"workers": workers, "status": status, "phase_s": round(seconds, 1)}
    rows = [r for r in result["rows"] if r["workers"] == workers and r["split"] == "tiles" and "cold_s" in r]
    return {"workers": workers, "status": status, "phase_s": round(seconds, 1),
            "cases": [{"data": r["data"], "grid": r["grid"], "cold_s": r["cold_s"],
                       "model_s": r.get("model_s")} for r in rows]}


def _predicted_row(result, workers: int, status: str, seconds: float, out: Path) -> dict:
    row = {"workers": workers, "status": status, "phase_s": round(seconds, 1), "cases": []}
    if status != "ok":
        return row
    measured = json.loads((out / "distributed_scaling.json").read_text())["rows"]
    for name, predictions in result["predictions"].items():
        prediction = next(p for p in predictions if p["workers"] == workers)
        match = [r for r in measured if r["data"] == name and r["split"] == "tiles"
                 and r["grid"] == prediction["grid"] and "cold_s" in r]
        row["cases"].append({"data": name, "grid": prediction["grid"], "model_s": prediction["tiles_s"],
                             "cold_s": match[0]["cold_s"] if match else None})
    return row


def travelling_mib() -> float:
    """What the run tool sends: the working tree without .git, the venv and caches (carry included)."""
    skip = {".git", ".venv", "__pycache__", ".pytest_cache", ".hypothesis", "results", "out"}
    total = 0
    for folder, subfolders, files in os.walk(ROOT):
        subfolders[:] = [s for s in subfolders if s not in skip]
        total += sum(os.lstat(os.path.join(folder, f)).st_size for f in files)
    return total / 2 ** 20


def device_name() -> str:
    from vgraph.gl_context import get_context
    info = get_context().info
    return f"{info.get('GL_RENDERER')} ({info.get('GL_VERSION')})"


def markdown(result: dict) -> str:
    lines = [f"Device: {result['device']}; {result['cpus']} CPUs; python {result['python']}; "
             f"{'dry run (llvmpipe, tiny sizes)' if result['dry_run'] else 'full run'}; "
             f"{result['travelling_mib']:.1f} MiB travelled; {result['seconds']:.0f} s of a "
             f"{result['budget_s']:.0f} s budget.",
             f"Image check: {CHECK_SIZE}x{CHECK_SIZE} against the llvmpipe image of the same network "
             f"(bench/gpu/refs), pass at PSNR >= {PSNR_MIN:g} dB (RGBA, 8 bit). Times: one untimed frame "
             f"(first_s), then best and median of {result['repeat']} frames, image read back.", "",
             "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for row in result["renders"]:
        lines.append("| " + " | ".join("" if row.get(c) is None else str(row[c]) for c in COLUMNS) + " |")
    lines += ["", f"bench_distributed --size {result.get('distributed_size')} (tiles split, cold frames, one round, "
              "single-threaded CPU workers): measured against the cost model fitted to 1 and 2 workers "
              "(for 4+ workers: its prediction for that grid).", "",
              "| workers | status | phase s | data | grid | measured cold s | model s | measured / model | "
              "measured-costs model s (low / mid / high) |",
              "|---|---|---|---|---|---|---|---|---|"]
    for row in result["distributed"]:
        cases = row.get("cases") or [{}]
        for case in cases:
            ratio = case["cold_s"] / case["model_s"] if case.get("cold_s") and case.get("model_s") else None
            lines.append(f"| {row['workers']} | {row['status']} | {row.get('phase_s', '')} | {case.get('data', '')} | "
                         f"{case.get('grid', '')} | {_num(case.get('cold_s'))} | {_num(case.get('model_s'))} | "
                         f"{_num(ratio)} | {_interval(case.get('costs_model'))} |")
    lines += ["", "bench/distributed_costs.py (the model composed from measured costs): "
              + result.get("costs", {}).get("status", "not run"), ""]
    if result.get("costs", {}).get("status") == "ok":
        from distributed_costs_report import markdown as costs_markdown
        lines.append(costs_markdown(result["costs"]))
    return "\n".join(lines) + "\n"


def _interval(spread) -> str:
    return "" if not spread else f"{spread['low']:.3f} / {spread['mid']:.3f} / {spread['high']:.3f}"


def _num(value) -> str:
    return "" if value is None else f"{value:.3f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dry-run", action="store_true", help="llvmpipe here, tiny sizes")
    parser.add_argument("--write-refs", action="store_true", help="write bench/gpu/refs from this run's images")
    parser.add_argument("--budget", type=float, default=None,
                        help="seconds for the whole measurement (default 390; dry run 40)")
    parser.add_argument("--out", type=Path, default=Path(os.environ.get("OUT") or ROOT / "bench" / "results" / "gpu"))
    args = parser.parse_args(argv)
    settings = DRY if args.dry_run else FULL
    budget = args.budget or settings["budget"]
    start = time.monotonic()
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"dry_run": args.dry_run, "distributed_size": settings["dist_size"], "budget_s": budget, "repeat": settings["repeat"], "cpus": os.cpu_count(),
              "python": platform.python_version(), "travelling_mib": travelling_mib(), "device": device_name()}
    print(f"travelling: {result['travelling_mib']:.1f} MiB; device: {result['device']}", file=sys.stderr, flush=True)
    with tempfile.TemporaryDirectory(prefix="vgraph-gpu-bench-") as work:
        # The rest of the budget goes to bench_distributed (its 1+2-worker run and three larger
        # clusters, each a fresh conversion and fit).
        deadline = start + settings["render_share"] * budget
        result["renders"] = render_phase(settings, deadline, args.write_refs, Path(work))
        result["distributed"], fitted, result["costs"] = distributed_phase(settings, start + budget, Path(work))
    if fitted:
        result["distributed_model"] = {key: fitted.get(key) for key in ("model", "predictions", "size", "cluster")}
    result["seconds"] = time.monotonic() - start
    (args.out / "gpu_bench.json").write_text(json.dumps(result, indent=1))
    (args.out / "gpu_bench.md").write_text(markdown(result))
    print(markdown(result))
    failed = [r["case"] for r in result["renders"] if r["check"] == "FAIL"]
    if failed:
        print(f"image check failed: {', '.join(sorted(set(failed)))}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
