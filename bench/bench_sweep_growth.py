"""How the SweepPlaneRenderer's (RZSweep's) frame time grows with the number of vertices and with
the image size, measured, with a least-squares model and its residuals
(docs/explanations/sweep-plane.md, section "Measured", records the numbers; the plot goes to
docs/images/sweep_growth.png).

    .venv/bin/python bench/bench_sweep_growth.py [--sizes 32 48 64 96 128 192 256] [--size-image 128]
        [--images 128 256 400 560 800] [--image-volumes 64 128] [--repeat 3] [--plot PNG] [--quick]

Volume: the smooth blob of bench/bench_sweep_plane.py (n^3 vertices, no threshold: every vertex
swept). Series 1: n^3 at --size-image^2 pixels; series 2: for each of --image-volumes, v^3 at m^2
pixels (two volume sizes separate the ray-face crossings, P N^(1/3), from the pixels, P). Each
point is the median of --repeat frames (a new camera angle each) after one untimed warm-up; the
points of a series are interleaved round by round (bench/interleave.py).

Models fitted to both series together (numpy least squares, seconds):
- A: t = a N log2 N + b P + c  (N vertices, P pixels; the heap is O(N log N))
- B: t = a N log2 N + b P N^(1/3) + c P + d  (P N^(1/3): the ray-face crossings, about one per
  cell a pixel's ray crosses)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import matplotlib
import numpy as np
from tqdm import tqdm

from bench_sweep_plane import CAMERA, TF, blob
from interleave import interleaved, spread
from vgraph.network import Network
from vgraph.testing import GivenVolume

matplotlib.use("Agg")  # headless: write a PNG
import matplotlib.pyplot as plt  # noqa: E402

PLOT = Path(__file__).resolve().parents[1] / "docs" / "images" / "sweep_growth.png"


def sweep_network(n: int) -> Network:
    network = Network()
    network.add(GivenVolume(id="src", volume=blob(n)))
    network.add("SweepPlaneRenderer", id="rc", camera=CAMERA, transfer_function=TF)
    network.connect("src.volume", "rc.volume")
    return network


def frame(network: Network, image: int):
    def draw(round_):
        if round_ is not None:
            network.processors["rc"].camera = CAMERA.rotate(0.3 * (round_ + 1), 0.1)
        start = time.perf_counter()
        network.evaluate("rc.image", size=(image, image))
        return time.perf_counter() - start
    return draw


def measure(points, repeat: int, label: str) -> dict:
    """points: name -> (n, image side). Returns name -> seconds of each timed frame."""
    variants = {name: frame(sweep_network(n), image) for name, (n, image) in
                tqdm(points.items(), desc=f"{label}: volumes", file=sys.stderr)}
    seconds, _ = interleaved(variants, list(range(repeat)), None)
    return seconds


def design(vertices, pixels, model: str) -> np.ndarray:
    vertices, pixels = np.asarray(vertices, float), np.asarray(pixels, float)
    heap = vertices * np.log2(vertices)
    if model == "A":
        return np.stack([heap, pixels, np.ones_like(pixels)], axis=1)
    return np.stack([heap, pixels * np.cbrt(vertices), pixels, np.ones_like(pixels)], axis=1)


def fit(rows, model: str):
    """(coefficients, predicted seconds) of ``model`` over rows of (N, P, median seconds)."""
    vertices, pixels, seconds = (np.array(column, float) for column in zip(*rows))
    matrix = design(vertices, pixels, model)
    coefficients = np.linalg.lstsq(matrix, seconds, rcond=None)[0]
    return coefficients, matrix @ coefficients


def plot(series_n, series_p, coefficients, args) -> None:
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    panels = [(left, series_n, lambda r: r[0], "", "C0")]
    panels += [(right, [r for r in series_p if r[0] == v ** 3], lambda r: r[1], f"{v}^3: ", f"C{k}")
               for k, v in enumerate(args.image_volumes)]
    for axis, rows, x_of, prefix, colour in panels:
        xs = np.array([x_of(r) for r in rows], float)
        axis.plot(xs, [r[2] for r in rows], "o", color=colour, label=f"{prefix}measured (median)")
        vertices, pixels = np.array([r[0] for r in rows], float), np.array([r[1] for r in rows], float)
        for model, style in (("A", "--"), ("B", "-")):
            axis.plot(xs, design(vertices, pixels, model) @ coefficients[model], style, color=colour,
                      label=f"{prefix}model {model}")
    for axis, label in ((left, "vertices N"), (right, "pixels P")):
        axis.set_xlabel(label)
        axis.set_ylabel("frame seconds")
        axis.legend(fontsize="small")
    left.set_title(f"n^3, {args.size_image}^2 pixels")
    right.set_title(f"{' and '.join(f'{v}^3' for v in args.image_volumes)}, m^2 pixels")
    figure.suptitle("SweepPlaneRenderer (RZSweep) frame time; 2 shared cores, numba, serial sweep")
    figure.tight_layout()
    args.plot.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.plot, dpi=90)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[32, 48, 64, 96, 128, 192, 256])
    parser.add_argument("--size-image", type=int, default=128)
    parser.add_argument("--images", type=int, nargs="+", default=[128, 256, 400, 560, 800])
    parser.add_argument("--image-volumes", type=int, nargs="+", default=[64, 128],
                        help="the pixel series' volume sizes (two or more separate crossings from pixels)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--plot", type=Path, default=PLOT)
    parser.add_argument("--quick", action="store_true", help="tiny sizes, for the test: seconds")
    args = parser.parse_args()
    if args.quick:
        args.sizes, args.size_image, args.images, args.image_volumes, args.repeat = [8, 12, 16], 24, [16, 24, 32], [8, 12], 1
    print(f"settings: {vars(args)}")
    by_size = measure({f"{n}^3": (n, args.size_image) for n in args.sizes}, args.repeat, "vertices")
    pixel_points = [(v, m) for v in args.image_volumes for m in args.images]
    by_image = measure({f"{v}^3 at {m}^2": (v, m) for v, m in pixel_points}, args.repeat, "pixels")
    series_n = [(n ** 3, args.size_image ** 2, float(np.median(by_size[f"{n}^3"]))) for n in args.sizes]
    series_p = [(v ** 3, m * m, float(np.median(by_image[f"{v}^3 at {m}^2"]))) for v, m in pixel_points]
    rows = series_n + series_p
    coefficients, predicted = {}, {}
    for model in ("A", "B"):
        coefficients[model], predicted[model] = fit(rows, model)
    print("\n| point | N vertices | P pixels | frame s (min / median / max) | model A s | residual A | model B s | residual B |")
    print("|---|---|---|---|---|---|---|---|")
    names = [f"{n}^3 at {args.size_image}^2" for n in args.sizes] + [f"{v}^3 at {m}^2" for v, m in pixel_points]
    frames = [by_size[f"{n}^3"] for n in args.sizes] + [by_image[name] for name in names[len(args.sizes):]]
    for k, (name, (vertices, pixels, median)) in enumerate(zip(names, rows)):
        print(f"| {name} | {vertices} | {pixels} | {spread(frames[k], 3)} | {predicted['A'][k]:.3f} | "
              f"{median - predicted['A'][k]:+.3f} | {predicted['B'][k]:.3f} | {median - predicted['B'][k]:+.3f} |")
    a = coefficients["A"]
    b = coefficients["B"]
    print(f"\nmodel A: t = {a[0]:.3e} N log2 N + {a[1]:.3e} P + {a[2]:.3f}   "
          f"(rms residual {np.sqrt(np.mean((np.array([r[2] for r in rows]) - predicted['A']) ** 2)):.3f} s)")
    print(f"model B: t = {b[0]:.3e} N log2 N + {b[1]:.3e} P N^(1/3) + {b[2]:.3e} P + {b[3]:.3f}   "
          f"(rms residual {np.sqrt(np.mean((np.array([r[2] for r in rows]) - predicted['B']) ** 2)):.3f} s)")
    plot(series_n, series_p, coefficients, args)
    print(f"plot: {args.plot}")


if __name__ == "__main__":
    main()
