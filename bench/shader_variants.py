"""bench_vtk's frames of our RayCaster with different shader trees, alternating frame by frame in
one process (issue #31: the only comparison a shared machine allows).

    .venv/bin/python bench/shader_variants.py --tree before=/tmp/before/shaders --tree now=shaders
        [--volume bonsai|torus] [--modes composite MIP ...] [--repeat 9] [--wall]

A tree is a copy of the repository's shaders/ (e.g. an older commit's:
`git archive COMMIT shaders | tar -x -C /tmp/before`). The first tree is the baseline. Each frame
is bench_vtk's (set the camera, evaluate, glFinish, no read-back), a new camera each round; each
variant draws one untimed frame first (bench/interleave.py). By default a frame's time is the
process CPU time it took (llvmpipe's rasterizer threads included), which load from other processes
hardly moves; --wall gives wall seconds. Prints min / median / max per variant, the per-round
ratio to the baseline (min - max, median), and the largest 8-bit difference of its image at the
base camera from the baseline's.

How: the builtin shader directory is switched per frame (vgraph.gl.shaders.builtin_shader_dir),
and a define naming the tree keeps each variant's program apart in the program cache.
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

import vgraph.gl.shaders as shaders  # noqa: E402
from vgraph.processors.raycaster import RayCaster  # noqa: E402


class Trees:
    """Which shader tree the next frame compiles from."""

    def __init__(self, trees: dict[str, Path]):
        self.trees, self.current = trees, next(iter(trees))
        own_defines = RayCaster.shader_defines
        shaders.builtin_shader_dir = lambda: self.trees[self.current]
        RayCaster.shader_defines = lambda processor: {**own_defines(processor),
                                                      f"SHADER_TREE_{self.index()}": True}

    def index(self) -> int:
        return list(self.trees).index(self.current)


def frame_of(renderer: OurRenderer, trees: Trees, name: str, base, order: int, wall: bool):
    """One bench frame from tree ``name`` at round r's camera (a hair apart per variant, so that
    no variant finds the previous one's camera and skips its work); round 0 is the base camera."""
    def frame(r: int) -> float:
        trees.current = name
        renderer.net.processors["rc"].invalidate()
        camera = base.rotate(math.radians(r * 3.0 + (order * 0.01 if r else 0.0)), 0.0)
        start = time.process_time()
        seconds = renderer.render(camera)
        return seconds if wall else time.process_time() - start
    return frame


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", action="append", required=True, help="NAME=DIR (a copy of shaders/)")
    parser.add_argument("--volume", choices=["torus", "bonsai"], default="bonsai")
    parser.add_argument("--modes", nargs="*", help="bench_vtk's rows (default: all four)")
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--wall", action="store_true", help="wall seconds instead of process CPU")
    args = parser.parse_args()
    named = dict(tree.split("=", 1) for tree in args.tree)
    trees = Trees({name: Path(directory).resolve() for name, directory in named.items()})
    volume = load_volume(args.volume, 256)
    base = camera_sequence(volume, 1, 3.0)[0]
    renderer = OurRenderer(volume, base, args.size)
    rows = scenes(args.volume)
    unit = "wall s" if args.wall else "process CPU s"
    print(f"{args.volume}, {args.size}^2, {unit} per frame, {args.repeat} rounds, frames alternating")
    for mode in args.modes or list(rows):
        renderer.configure(rows[mode])
        variants = {name: frame_of(renderer, trees, name, base, k, args.wall) for k, name in enumerate(named)}
        seconds, _ = interleaved(variants, list(range(1, args.repeat + 1)), 0)
        images = {}
        for name, frame in variants.items():
            frame(0)
            images[name] = renderer.image()
        first = next(iter(named))
        print(mode)
        for name in named:
            ratio = np.array(seconds[name]) / np.array(seconds[first])
            difference = int(np.abs(images[name].astype(int) - images[first]).max())
            print(f"  {name:12s} {spread(seconds[name], 4)}   / {first}: {ratio.min():.3f} - {ratio.max():.3f}, "
                  f"median {np.median(ratio):.3f}   max 8-bit difference {difference}")


if __name__ == "__main__":
    main()
