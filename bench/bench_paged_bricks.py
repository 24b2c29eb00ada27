"""Benchmark (issue #33, item 1): the BrickedRayCaster's single pass through a page table against
its pass per brick and the in-core RayCaster, everything resident at level 0.

Usage:  python bench/bench_paged_bricks.py [--volume FILE | --implicit FUNCTION:N] [--size 256] [--rounds 3]
                                          [--bricks 32 64] [--cpu] [--modes dvr shaded mip iso]
                                          [--methods passes single_pass] [--budget MB]

Per compositing mode, the variants draw one untimed frame, then take turns frame by frame
(bench/interleave.py), each frame re-planned (the sampling rate is nudged so the processor
evaluates again); min / median / max per variant. Beside each bricked variant: its largest pixel
difference from the RayCaster's image (in 8-bit steps) and its PSNR. The RayCaster and the single
pass share ``early_termination`` (the pass per brick has none at 1.0). ``--cpu`` times the process's
CPU seconds (all of llvmpipe's threads) instead of the wall clock: steady on a machine that other
jobs share, and on llvmpipe the same work. ``--implicit torus:512`` draws a function of vgraph.implicit
sampled into memory (uint8, N^3) instead of a file: a volume larger than the bonsai without a file
(``--implicit torus:1024 --budget 2048``: a 1024^3 volume, the bricked variants' ram and GL budgets
raised so that level 0 stays resident; the defaults of 1024 / 512 MB hold up to 512^3). Numbers go to
docs/explanations/bricked-ray-casting.md ("One pass, a page table").
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np

from tqdm import tqdm

from vgraph.bricks.implicit_url import open_implicit
from vgraph.camera import Camera
from vgraph.errors import ProcessorError
from vgraph.implicit import sample
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from interleave import interleaved, spread

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
WINDOW = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.4, 0.9, 0.0),
                                  (0.6, 1.0, 0.7, 0.2, 0.3), (1.0, 1, 1, 1, 0.6)])
CASES = [("dvr", {"transfer_function": WINDOW, "early_termination": 1.0}),
         ("dvr shaded, termination 0.99", {"transfer_function": WINDOW, "early_termination": 0.99,
                                            "shading": "blinn_phong"}),
         ("mip", {}), ("iso", {"iso_level": 0.3})]


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0.0 else 10.0 * np.log10(1.0 / mse)


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def frame_of(network, size, images: dict, name: str, clock=time.perf_counter):
    """A frame(argument) -> seconds for interleaved(); the last image is kept in ``images``."""
    count = [0]

    def frame(_argument) -> float:
        count[0] += 1
        network.set("rc.sampling_rate", 1.0 + 1e-6 * count[0])
        began = clock()
        images[name] = np.asarray(network.evaluate("rc.image", size=size))
        return clock() - began
    return frame


def implicit_volume(function: str, n: int) -> Volume:
    """``function`` sampled n^3 uint8 in memory: vgraph.implicit.sample up to its 512^3, past it
    level 0 of the virtual store implicit:FUNCTION?size=N (the same map of f to uint8), read in slabs."""
    if n <= 512:
        return sample(function, n, "uint8")
    store = open_implicit(f"implicit:{function}?size={n}&brick=64")
    data = np.empty((n, n, n), dtype=np.uint8)
    for z in tqdm(range(0, n, 64), desc=f"reading {function} {n}^3", unit="slab"):
        data[z:z + 64] = store.read(0, (z, 0, 0), (z + 64, n, n))
    return Volume(data)


def drawn(network) -> str:
    """What the bricked variant's last frame drew: the comparison holds for level 0, complete."""
    frame = network["rc"].last_frame or {}
    levels = frame.get("levels")
    return f"levels {levels}, {'complete' if frame.get('complete') else 'NOT complete'}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", default=str(DATA / "ct_bonsai" / "bonsai.nii.gz"))
    parser.add_argument("--implicit", help="FUNCTION:N, a vgraph.implicit function sampled N^3 (uint8)")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--bricks", type=int, nargs="+", default=[32, 64])
    parser.add_argument("--cpu", action="store_true", help="CPU seconds of the process, not wall seconds")
    parser.add_argument("--modes", nargs="+", choices=["dvr", "shaded", "mip", "iso"], default=["dvr", "shaded", "mip", "iso"],
                        help="the cases to run (shaded: dvr shaded with early termination 0.99)")
    parser.add_argument("--methods", nargs="+", choices=["passes", "single_pass"], default=["passes", "single_pass"])
    parser.add_argument("--budget", type=float, help="MB: the bricked variants' ram_budget and gl_budget (level 0 resident)")
    args = parser.parse_args()
    clock = cpu_seconds if args.cpu else time.perf_counter
    if args.implicit:
        function, count = args.implicit.split(":")
        volume, args.volume = implicit_volume(function, int(count)), f"implicit {args.implicit}"
    else:
        volume = read_volume(args.volume)
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    size = (args.size, args.size)
    print(f"{args.volume}: {volume.dims}, {size[0]} x {size[1]}, {args.rounds} rounds (min / median / max ms, "
          f"{'CPU' if args.cpu else 'wall'})" + (f", bricked budgets {args.budget:g} MB" if args.budget else ""))
    for name, properties in CASES:
        mode = name.split(" ")[0].rstrip(",")
        if ("shaded" if "shaded" in name else mode) not in args.modes:
            continue
        properties = {"shading": "none", "compositing": mode, **properties}
        variants, images, networks = {}, {}, {}
        variants["RayCaster"] = frame_of(ray_caster_network(volume, camera, "RayCaster", **properties),
                                         size, images, "RayCaster", clock)
        for brick in args.bricks:
            for method in args.methods:
                label = f"{method} {brick}^3"
                budgets = {"ram_budget": args.budget, "gl_budget": args.budget} if args.budget else {}
                network = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=brick, lod_bias=-16.0,
                                             method=method, **budgets, **properties)
                variants[label], networks[label] = frame_of(network, size, images, label, clock), network
        try:
            seconds, _ = interleaved(variants, [None] * args.rounds, None)
        except ProcessorError as error:  # e.g. llvmpipe refuses the RayCaster's 2 GiB R16 texture of 1024^3
            raise SystemExit(f"{name}: refused: {error}")
        print(f"{name}:")
        for label, values in seconds.items():
            line = f"  {label:>18}: {spread([v * 1e3 for v in values], 0)} ms"
            median = float(np.median(values)) / float(np.median(seconds["RayCaster"]))
            if label != "RayCaster":
                line += f"  [{drawn(networks[label])}]"
                steps = float(np.abs(images[label] - images["RayCaster"]).max()) * 255.0
                line += (f"  ({median:.2f}x the RayCaster; max difference {steps:.2f} steps of 1/255, "
                         f"PSNR {psnr(images[label], images['RayCaster']):.1f} dB)")
            print(line, flush=True)


if __name__ == "__main__":
    main()
