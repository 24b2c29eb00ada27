"""Where one bench_vtk frame of ours goes (issue #31, item 3): its parts timed as variants whose
frames alternate in one process.

    .venv/bin/python bench/frame_breakdown.py [--volume bonsai|torus] [--modes ...] [--repeat 9]

Per mode of bench_vtk (same volume, TF, camera orbit and settings), each round draws one frame of
every variant, each at its own camera (a hair apart, so none finds its work done):
- frame: bench_vtk's frame (set the camera, evaluate the RayCaster's image, glFinish);
- entry/exit: EntryExitPoints alone (its Python and its GL pass), then glFinish;
- ray caster: the RayCaster alone, EntryExitPoints' images ready (its Python, the fill pass
  and the ray pass), then glFinish;
- ray caster Python: the same until the evaluation returns (llvmpipe draws after glFinish,
  which is not counted);
- read-back: reading the finished image into numpy (bench_vtk's frames do not).
Wall seconds and process CPU seconds (llvmpipe's threads included: on a loaded machine the
steadier one). Then the samples the ray caster evaluated per covered pixel (the depth output's
counter) at the base camera.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_vtk import OurRenderer, camera_sequence, load_volume, scenes  # noqa: E402
from interleave import interleaved, spread  # noqa: E402


class Clock:
    """Wall and process CPU seconds from start() to stop()."""

    def start(self) -> None:
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def stop(self) -> tuple[float, float]:
        return time.perf_counter() - self.wall, time.process_time() - self.cpu


def parts(renderer: OurRenderer) -> dict:
    """Variant name -> draw(camera) -> (wall, process CPU) seconds of the timed part."""
    net, ctx, size = renderer.net, renderer.ctx, renderer.size
    clock = Clock()

    def frame(camera):
        clock.start()
        renderer.render(camera)
        return clock.stop()

    def entry_exit(camera):
        clock.start()
        net.set("eep.camera", camera)
        net.update("eep.entry", "eep.exit", size=size)
        ctx.finish()
        return clock.stop()

    def ray_caster(camera, finish: bool = True):
        entry_exit(camera)
        clock.start()
        net.processors["rc"].invalidate()
        net.update("rc.image", size=size)
        if finish:
            ctx.finish()
        return clock.stop()

    def read_back(camera):
        renderer.render(camera)
        clock.start()
        net.output("rc.image").to_numpy()
        return clock.stop()

    return {"frame": frame, "entry/exit": entry_exit, "ray caster": ray_caster,
            "ray caster Python": lambda camera: ray_caster(camera, finish=False), "read-back": read_back}


def timed(draw, ctx, base, order: int, cpu: list):
    """round r -> wall seconds of ``draw``'s part at r's camera; its process CPU seconds go to
    ``cpu``."""
    def frame(r: int) -> float:
        ctx.finish()
        wall, seconds = draw(base.rotate(math.radians(r * 3.0 + order * 0.01), 0.0))
        ctx.finish()  # what a part left queued is not the next part's
        cpu.append(seconds)
        return wall
    return frame


def samples_per_covered_pixel(renderer: OurRenderer, base) -> float:
    renderer.render(base)
    depth = renderer.net.evaluate("rc.depth", size=renderer.size)
    covered = renderer.net.evaluate("eep.entry", size=renderer.size)[..., 3] > 0
    return float(depth[..., 2][covered].mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", choices=["torus", "bonsai"], default="bonsai")
    parser.add_argument("--modes", nargs="*", help="bench_vtk's rows (default: all four)")
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--size", type=int, default=512)
    args = parser.parse_args()
    volume = load_volume(args.volume, 256)
    base = camera_sequence(volume, 1, 3.0)[0]
    renderer = OurRenderer(volume, base, args.size)
    rows = scenes(args.volume)
    print(f"{args.volume}, {args.size}^2, {args.repeat} rounds, parts alternating; min / median / max")
    for mode in args.modes or list(rows):
        renderer.configure(rows[mode])
        cpu = {name: [] for name in parts(renderer)}
        variants = {name: timed(draw, renderer.ctx, base, k, cpu[name])
                    for k, (name, draw) in enumerate(parts(renderer).items())}
        wall, _ = interleaved(variants, list(range(1, args.repeat + 1)), args.repeat + 10)
        print(f"{mode}: {samples_per_covered_pixel(renderer, base):.1f} samples per covered pixel")
        for name in variants:
            print(f"  {name:18s} wall ms {spread(np.array(wall[name]) * 1e3, 2):>22s}   "
                  f"process CPU ms {spread(np.array(cpu[name][1:]) * 1e3, 2):>22s}")


if __name__ == "__main__":
    main()
