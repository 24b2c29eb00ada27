"""Benchmark: the issue-35 image processors (GL passes) and statistics processors against the
numpy / scipy.ndimage computation each one equals (the formulas of tests/test_image_filters.py,
tests/test_image_processors.py and tests/test_statistics_processors.py).

Usage:  python bench/bench_image_processors.py [--rounds N] [--size N] [--data FOLDER] [--out FILE.md]

Image processors: ours is process() on an image already on the GPU, with ctx.finish() (the GL's
work done; nothing read back, as between processors); the reference is the numpy formula on the
float32 pixels in memory. Statistics: ours is process() on a fresh Volume (its percentiles'
table and histogram worked out in its time, as in a first run); the reference is np.percentile /
np.histogram on the bare array. Variants take turns after an untimed warm-up (bench/interleave.py).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

from filter_timing import timed
from interleave import interleaved, spread
from vgraph.gl_context import get_context
from vgraph.image import Image
from vgraph.io import read_volume
from vgraph.registry import registry
from vgraph.volume import Volume

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LUMINANCE = np.array([0.30, 0.59, 0.11], np.float32)


def gamma_reference(rgba):
    alpha = rgba[..., 3:]
    straight = np.where(alpha > 0, rgba[..., :3] / np.where(alpha > 0, alpha, 1), rgba[..., :3])
    x = 2.0 * np.maximum(straight, 0)
    return np.concatenate([(x / (1 + x)) ** (1 / 2.2) * alpha, alpha], axis=-1)


def threshold_reference(rgba):
    above, below = np.ones(4, np.float32), np.array([0, 0, 0, 1], np.float32)
    return np.where((rgba[..., :3] @ LUMINANCE >= 0.3)[..., None], above, below)


def background_reference(rgba):
    height = rgba.shape[0]
    t = ((np.arange(height) + 0.5) / height)[:, None, None]
    back = (1 - t) * np.array([0.28, 0.3, 0.35, 1.0], np.float32) + t * np.array([0.05, 0.05, 0.07, 1.0], np.float32)
    return rgba + (1 - rgba[..., 3:]) * back


def blur_reference(rgba):
    return ndimage.gaussian_filter(rgba, (3.0, 3.0, 0.0), mode="nearest", truncate=4.0)


def edges_reference(rgba):
    values = rgba[..., :3] @ LUMINANCE
    magnitude = np.hypot(ndimage.sobel(values, 0, mode="nearest"), ndimage.sobel(values, 1, mode="nearest"))
    return np.concatenate([np.repeat(0.25 * magnitude[..., None], 3, -1), np.ones_like(rgba[..., 3:])], axis=-1)


def depth_darkening_reference(rgba, depth):
    red = depth[..., 0]
    normalised = (red - red.min()) / (red.max() - red.min())
    delta = ndimage.gaussian_filter(normalised, 8.0, mode="nearest", truncate=4.0) - normalised
    return np.concatenate([np.maximum(rgba[..., :3] + np.minimum(delta, 0.0)[..., None], 0.0), rgba[..., 3:]], axis=-1)


def mix_reference(rgba, other):
    return 0.7 * rgba + 0.3 * other


def text_reference(rgba):
    from PIL import Image as PILImage, ImageDraw, ImageFont
    side = min(rgba.shape[:2])  # TextOverlay's defaults: text 0.05 of the shorter side, 3 % from the corner
    mask = PILImage.new("L", rgba.shape[1::-1])
    ImageDraw.Draw(mask).multiline_text((round(0.03 * side), round(0.03 * side)), "CT head", fill=255,
                                        font=ImageFont.load_default(size=round(0.05 * side)), anchor="la")
    coverage = np.asarray(mask, np.float32)[..., None] / 255
    return coverage + (1 - coverage) * rgba


# name -> (processor type, its properties, the images it takes, the reference on the pixels)
IMAGE_CASES = {
    "Reinhard, gamma 2.2": ("ImageGamma", {"tone_mapping": "reinhard", "exposure": 2.0, "gamma": 2.2},
                            ("image",), gamma_reference),
    "luminance threshold": ("ImageThreshold", {"threshold": 0.3}, ("image",), threshold_reference),
    "gradient under the image": ("Background", {}, ("image",), background_reference),
    "mix 0.3": ("ImageMix", {"factor": 0.3}, ("a", "b"), mix_reference),
    "caption": ("TextOverlay", {"text": "CT head"}, ("image",), text_reference),
    "Gaussian, sigma 3 pixels": ("ImageBlur", {"sigma": 3.0}, ("image",), blur_reference),
    "Sobel magnitude of the luminance": ("EdgeDetect", {"overlay": False, "scale": 0.25}, ("image",), edges_reference),
    "unsharp-masked depth, sigma 8": ("DepthDarkening", {"sigma": 8.0, "strength": 1.0}, ("image", "depth"),
                                      depth_darkening_reference),
}


def bench_images(size: int, rounds: int) -> list[str]:
    ctx = get_context()
    rng = np.random.default_rng(35)
    pixels = [rng.random((size, size, 4)).astype(np.float32) for _ in range(2)]
    for p in pixels:
        p[..., :3] *= p[..., 3:]
    images = [Image.from_numpy(ctx, p) for p in pixels]
    rows = []
    for name, (type_name, properties, inports, reference) in IMAGE_CASES.items():
        processor = registry.get(type_name)("bench", **properties)
        inputs = dict(zip(inports, images))

        def ours(_):
            start = time.perf_counter()
            processor.process(**inputs)
            ctx.finish()
            return time.perf_counter() - start

        variants = {"ours": ours, "numpy": lambda _: timed(lambda: reference(*pixels[:len(inports)]))}
        seconds, _ = interleaved(variants, [None] * rounds, None)
        ratio = np.median(seconds["ours"]) / np.median(seconds["numpy"])
        rows.append(f"| {type_name} | {name}, {size}^2 | {spread(seconds['ours'], 4)} | "
                    f"{spread(seconds['numpy'], 4)} | {ratio:.2f} |")
        print(rows[-1], flush=True)
    return rows


def bench_statistics(volume: Volume, rounds: int) -> list[str]:
    percents = (1.0, 25.0, 50.0, 75.0, 99.0)
    lo, hi = float(volume.data.min()), float(volume.data.max())
    cases = {
        "VolumeInfo": ("5 percentiles, extremes", {},
                       lambda a: (np.percentile(a, percents), a.min(), a.max())),
        "Histogram": ("128 bins, 512 x 256 image", {"bins": 128},
                      lambda a: np.histogram(a, bins=128, range=(lo, hi))),
    }
    rows = []
    for type_name, (name, properties, reference) in cases.items():
        processor = registry.get(type_name)("bench", **properties)
        processor.render_size = (512, 256)
        fresh = lambda: Volume(volume.data, spacing=volume.spacing)  # noqa: E731
        variants = {"ours": lambda _: timed(lambda: processor.process(volume=fresh())),
                    "numpy": lambda _: timed(lambda: reference(volume.data))}
        seconds, _ = interleaved(variants, [None] * rounds, None)
        ratio = np.median(seconds["ours"]) / np.median(seconds["numpy"])
        rows.append(f"| {type_name} | {name}, {'x'.join(map(str, volume.dims))} {volume.data.dtype} | "
                    f"{spread(seconds['ours'])} | {spread(seconds['numpy'])} | {ratio:.2f} |")
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    renderer = get_context().info["GL_RENDERER"]
    header = [f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, {renderer}, "
              f"{args.rounds} rounds", "",
              "| processor | case | ours s (min / median / max) | numpy s | ours / numpy |",
              "|---|---|---|---|---|"]
    print("\n".join(header), flush=True)
    rows = bench_images(args.size, args.rounds)
    rows += bench_statistics(read_volume(args.data / "ct_bonsai" / "bonsai.nii.gz"), args.rounds)
    if args.out:
        args.out.write_text("\n".join(header + rows) + "\n")


if __name__ == "__main__":
    main()
