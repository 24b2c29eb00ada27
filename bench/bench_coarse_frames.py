"""Where a drag's frame of the 1024^3 store goes, without the GUI (issue #33).

    .venv/bin/python bench/bench_coarse_frames.py [--canvas 256 512] [--frames 8] [--store URL] [--profile]

The network of ``bench_interaction.py --networks store`` (the virtual store
``implicit:torus?size=1024&brick=64`` drawn by a BrickedRayCaster, method auto: dvr in one pass),
evaluated as the GUI's render process evaluates a drag's frames: ``evaluate_view`` at the GUI's
``INTERACTIVE_SCALE`` of the canvas with the context ``frame_context`` gives a job below full scale
(the GUI's load limit, ``interactive``). The camera turns 2 degrees a frame about the vertical.
First the coarse frames are drawn until one is complete (their bricks read), then ``--frames``
frames are timed: the wall clock, the CPU time of this thread (``time.thread_time``; llvmpipe's
rasterising threads not counted) and, with ``--profile``, cProfile's split of a frame into the
plan, the leaf table, the block flags, the ray requests, the uniforms and the GL pass (the time in
``ctx.finish``: llvmpipe drawing). It prints the level drawn, the sample stride
(``last_frame["sample_stride"]``, absent before vgraph.bricks.coarse_step) and the samples the rays
evaluated (the depth output's counter).

Run it with another tree's ``PYTHONPATH`` for the frame before a change; on a shared machine run
the two in turn, twice, as the load drifts.
"""

from __future__ import annotations

import argparse
import cProfile
import math
import pstats
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_interaction import STORE, store_network  # noqa: E402

# cProfile entries reported, (function name, a part of its file's name)
PARTS = {"plan": ("plan", "sampling.py"), "leaf table": ("leaf_table", "paged_sampling.py"),
         "block flags": ("block_flags", "paged_grids.py"), "ray requests": ("read", "ray_requests.py"),
         "uniforms": ("binding_of", "paged_sampling.py"), "entry/exit points": ("process", "entry_exit_points.py"),
         "frame report": ("drawn_report", "paged_report.py")}


def turned(camera, degrees: float):
    """``camera`` turned about the vertical through its focus."""
    angle = math.radians(degrees)
    focus = np.asarray(camera.focus, dtype=float)
    x, y, z = np.asarray(camera.position, dtype=float) - focus
    c, s = math.cos(angle), math.sin(angle)
    return camera.model_copy(update={"position": tuple(focus + (c * x + s * z, y, -s * x + c * z))})


def measure(canvas: int, frames: int, url: str, profile: bool) -> None:
    from vgraph.fileformat import load_network
    from vgraph.gui.live_evaluation import INTERACTIVE_SCALE
    from vgraph.live.evaluator import evaluate_view
    from vgraph.live.render_messages import RenderJob
    from vgraph.live.render_server import frame_context

    network = load_network(store_network(Path(tempfile.mkdtemp()), url))
    network.set("canvas.size", [canvas, canvas])
    context = frame_context(RenderJob(1, None, scale=INTERACTIVE_SCALE))
    caster, start = network["rc"], network["eep"].camera

    def drag_frame(i: int):
        network.set("eep.camera", turned(start, 2.0 * i))
        evaluate_view(network, INTERACTIVE_SCALE, context=context)

    started = time.perf_counter()
    drag_frame(0)
    for _ in range(60):  # read the coarse frame's bricks (as the GUI does before a drag gets there)
        if caster.last_frame.get("complete"):
            break
        network.invalidate_downstream("rc")
        evaluate_view(network, INTERACTIVE_SCALE, context=context)
    warm = time.perf_counter() - started
    profiler = cProfile.Profile() if profile else None
    wall, cpu = [], []
    for i in range(1, frames + 1):
        w, c = time.perf_counter(), time.thread_time()
        if profiler:
            profiler.enable()
        drag_frame(i)
        if profiler:
            profiler.disable()
        wall.append(1000 * (time.perf_counter() - w))
        cpu.append(1000 * (time.thread_time() - c))
    frame = caster.last_frame
    size = round(canvas * INTERACTIVE_SCALE)
    depth = np.asarray(network.evaluate("rc.depth", size=(size, size), context=context))
    print(f"canvas {canvas}: drag frames of {size} x {size}, level {frame['levels']}, stride "
          f"{frame.get('sample_stride', 1)}, {depth[..., 2].sum() / (size * size):.0f} samples a pixel; "
          f"wall ms median {statistics.median(wall):.1f} (min {min(wall):.1f}), thread CPU ms median "
          f"{statistics.median(cpu):.1f}; reading the coarse bricks first {warm:.1f} s", flush=True)
    if profiler:
        stats = pstats.Stats(profiler).stats
        for label, (name, file) in PARTS.items():
            ms = sum(entry[3] for (path, _, function), entry in stats.items() if function == name and file in path)
            print(f"  {label:18s} {1000 * ms / frames:7.2f} ms a frame")
        finish = sum(entry[3] for (_, _, function), entry in stats.items() if "finish' of 'mgl" in function)
        print(f"  {'GL (ctx.finish)':18s} {1000 * finish / frames:7.2f} ms a frame", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--canvas", type=int, nargs="+", default=[256, 512])
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--store", default=STORE)
    parser.add_argument("--profile", action="store_true", help="split a frame's time (cProfile)")
    args = parser.parse_args(argv)
    for canvas in args.canvas:
        measure(canvas, args.frames, args.store, args.profile)
    return 0


if __name__ == "__main__":
    sys.exit(main())
