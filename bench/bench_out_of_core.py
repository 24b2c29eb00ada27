"""Out of core (issue #14's evidence): a volume larger than the memory it is given, converted and
rendered brick by brick; and Retondaro 2008 figs. 5.1-5.5 redone for one process (frame time against
the octree's depth and the brick size, the in-core RayCaster as the baseline).

    .venv/bin/python bench/bench_out_of_core.py [--size 1024] [--budget 256] [--image 512]
        [--work /tmp/vgraph-bench] [--out bench/results] [--skip-large] [--skip-depth]

Large: the CT bonsai resampled to SIZE^3 uint16 (bench/resample_bonsai.py, 2 GiB at 1024) is
converted by ``vgraph convert`` (its own process: time, peak RSS, bytes written), then a fresh
process loads the store through VolumeSource (memory_budget = BUDGET) and renders it with the
BrickedRayCaster (ram_budget = gl_budget = BUDGET MB): the first frame's latency from the start of
the process, then one frame per lod_bias (coarse to fine), each with the levels it drew, the bytes
it read and its time, and the process's peak RSS at the end.

Depth: the in-memory 256^3 bonsai, octree depth d = 1, 2, 3 (bricks of 256 / 2^d voxels: 8, 64
and 512 leaves, the seed's levels) and smaller bricks, each against the RayCaster on the same view.

Writes bench/results/out_of_core.md and out_of_core_depth.png.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BONSAI = ROOT.parent / "shared" / "data" / "ct_bonsai" / "bonsai.nii.gz"
PYTHON = sys.executable


def peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def transfer_function():
    from vgraph.transfer_function import TransferFunction
    return TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.4, 0.9, 0.0),
                                    (0.6, 1.0, 0.7, 0.2, 0.3), (1.0, 1, 1, 1, 0.6)])


# --- the large volume -------------------------------------------------------------------------------
def converted_store(args) -> tuple[Path, dict]:
    """The SIZE^3 store (made once; the conversion measured in a child process)."""
    npy = args.work / f"bonsai{args.size}.npy"
    store = args.work / f"bonsai{args.size}.zarr"
    if not npy.exists():
        subprocess.run([PYTHON, str(ROOT / "bench" / "resample_bonsai.py"), "--size", str(args.size),
                        "--out", str(npy)], check=True)
    started = time.perf_counter()
    run = subprocess.run([PYTHON, "-c", CONVERT, str(npy), str(store)], check=True,
                         capture_output=True, text=True)
    report = json.loads(run.stdout.strip().splitlines()[-1])
    report["wall_seconds"] = time.perf_counter() - started
    return store, report


CONVERT = """
import json, resource, sys
from vgraph.io.convert import convert
report = convert(sys.argv[1], sys.argv[2], brick=64, progress=False)
print(json.dumps({"seconds": report.seconds, "bytes_written": report.bytes_written,
                  "levels": [list(shape) for shape in report.shapes],
                  "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))
"""


def render_large(store: Path, budget: float, image: int, biases) -> dict:
    """In a fresh process: first-frame latency, then a frame per lod_bias (RENDER below)."""
    run = subprocess.run([PYTHON, "-c", RENDER, str(store), str(budget), str(image), json.dumps(biases)],
                         check=True, capture_output=True, text=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


RENDER = """
import time
started = time.perf_counter()
import json, resource, sys, warnings
import vgraph
from vgraph.camera import Camera
store, budget, size, biases = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), json.loads(sys.argv[4])
warnings.simplefilter("ignore")
sys.path.insert(0, %r)
from bench_out_of_core import transfer_function
net = vgraph.Network()
net.add("VolumeSource", id="src", path=store, memory_budget=budget)
net.add("EntryExitPoints", id="eep")
net.add("BrickedRayCaster", id="rc", ram_budget=budget, gl_budget=budget, lod_bias=biases[0],
        transfer_function=transfer_function())
net.link("eep.camera", "rc.camera")
for a, b in (("src.volume", "eep.volume"), ("src.volume", "rc.volume"), ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit")):
    net.connect(a, b)
rows = []
for number, bias in enumerate(biases):
    net.set("rc.lod_bias", bias)
    cache = net["rc"].cache
    before = dict(cache.stats)
    began = time.perf_counter()
    net.evaluate("rc.image", size=(size, size))
    seconds = time.perf_counter() - began
    frame = net["rc"].last_frame
    rows.append({"lod_bias": bias, "seconds": seconds, "levels": frame["levels"], "bricks": frame["bricks"],
                 "bytes_read": cache.stats["bytes_read"] - before["bytes_read"],
                 "floor_level": frame["floor_level"],
                 "first_frame": time.perf_counter() - started if number == 0 else None})
print(json.dumps({"frames": rows, "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))
""" % str(ROOT / "bench")


def large_section(args) -> list[str]:
    store, conversion = converted_store(args)
    biases = [4.0, 3.0, 2.0, 1.0, 0.0, -16.0]
    render = render_large(store, args.budget, args.image, biases)
    gib = args.size ** 3 * 2 / 2**30
    lines = [f"{args.size}^3 uint16 ({gib:.1f} GiB) converted with 64^3 bricks: "
             f"{conversion['seconds']:.1f} s, peak RSS {conversion['peak_rss_mib']:.0f} MiB, "
             f"{conversion['bytes_written'] / 2**20:.0f} MiB written, levels "
             f"{', '.join('x'.join(map(str, s[::-1])) for s in conversion['levels'])}.", "",
             f"Rendered at {args.image}^2 with ram_budget = gl_budget = {args.budget:g} MB (a fresh "
             f"process; peak RSS over all frames {render['peak_rss_mib']:.0f} MiB):", "",
             "| lod_bias | levels drawn | bricks | bytes read (MiB) | frame (s) |", "|---|---|---|---|---|"]
    for row in render["frames"]:
        lines.append(f"| {row['lod_bias']:g} | {', '.join(map(str, row['levels']))} | {row['bricks']} | "
                     f"{row['bytes_read'] / 2**20:.1f} | {row['seconds']:.2f} |")
    first = render["frames"][0]["first_frame"]
    lines += ["", f"First frame {first:.2f} s after the process started (imports, opening the store, "
                  f"reading and drawing level {min(render['frames'][0]['levels'])})."]
    return lines


# --- octree depth and brick size --------------------------------------------------------------------
def depth_section(args) -> tuple[list[str], list[tuple]]:
    from vgraph.camera import Camera
    from vgraph.io import read_volume
    from vgraph.numerics.reference_raycast import volume_box
    from vgraph.testing import ray_caster_network
    volume = read_volume(BONSAI)
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    size = (args.image, args.image)

    def best(network) -> float:
        network.evaluate("rc.image", size=size)  # warm up: pyramid, programs, bricks
        times = []
        for k in range(args.repeats):
            network.set("rc.sampling_rate", 1.0 + 1e-6 * (k + 1))
            began = time.perf_counter()
            network.evaluate("rc.image", size=size)
            times.append(time.perf_counter() - began)
        return min(times)

    tf = transfer_function()
    baseline = best(ray_caster_network(volume, camera, "RayCaster", transfer_function=tf, early_termination=1.0,
                                       shading="none"))  # as the bricked one (the RayCaster starts shaded)
    rows = []
    for brick in (128, 64, 32, 16):
        network = ray_caster_network(volume, camera, "BrickedRayCaster", transfer_function=tf,
                                     brick_size=brick, lod_bias=-16.0)
        seconds = best(network)
        depth = int(np.log2(256 // brick))
        rows.append((depth, brick, (256 // brick) ** 3, network["rc"].last_frame["bricks"], seconds))
    lines = [f"RayCaster (in core, early termination off): {baseline:.3f} s at {args.image}^2.", "",
             "| octree depth | brick (voxels) | leaves | drawn (not empty, in view) | frame (s) | / RayCaster |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {d} | {b}^3 | {n} | {drawn} | {s:.3f} | {s / baseline:.1f} |" for d, b, n, drawn, s in rows]
    return lines, [(baseline,)] + rows


def plot_depth(rows, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    baseline, data = rows[0][0], rows[1:]
    figure, axis = plt.subplots(figsize=(5.5, 3.6))
    axis.plot([d for d, *_ in data], [s for *_, s in data], "o-", label="BrickedRayCaster")
    for depth, brick, *_, seconds in data:
        axis.annotate(f"{brick}^3", (depth, seconds), textcoords="offset points", xytext=(4, 4), fontsize=8)
    axis.axhline(baseline, color="gray", linestyle="--", label="RayCaster (in core)")
    axis.set_xlabel("octree depth (bricks of 256 / 2^depth voxels)")
    axis.set_ylabel("frame time (s)")
    axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--budget", type=float, default=256.0)
    parser.add_argument("--image", type=int, default=512)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--work", type=Path, default=Path("/tmp/vgraph-bench"))
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results")
    parser.add_argument("--skip-large", action="store_true")
    parser.add_argument("--skip-depth", action="store_true")
    args = parser.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    args.out.mkdir(parents=True, exist_ok=True)
    report = [f"# Out of core ({' '.join(sys.argv[1:]) or 'defaults'})", ""]
    if not args.skip_large:
        report += ["## A volume larger than its memory budget", "", *large_section(args), ""]
    if not args.skip_depth:
        lines, rows = depth_section(args)
        report += ["## Octree depth and brick size (one process)", "", *lines, ""]
        plot_depth(rows, args.out / "out_of_core_depth.png")
    text = "\n".join(report) + "\n"
    (args.out / "out_of_core.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
