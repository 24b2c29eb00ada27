"""Benchmark: GPU tricubic B-spline evaluation (vgraph.gl.tricubic), speed and precision.

Usage:  python bench/bench_tricubic.py [--points 1048576] [--size 128] [--repeats 5] [--out FILE.md]

Speed: evaluations per second of each variant (direct 64-fetch sum, fast Sigg-Hadwiger form) for
value, value + gradient and value + gradient + Hessian, at --points points inside a --size^3
random coefficient volume, once in random order and once as a coherent lattice (point_sets).
"GPU pass" is one fullscreen pass with the points already on the GPU (best of --repeats,
ctx.finish() included; "CPU ms" is the process's CPU time for it, llvmpipe's threads included);
"evaluate_gl" adds uploading the points and reading the results back. The variants run
alternately so a busy machine slows both alike; M evals/s is points / best GPU-pass wall time.

Precision: max |GPU - CPU reference| / max |reference| per quantity at 20 000 points inside the
grid, on a random coefficient volume and on prefiltered FunctionSelector samples, for both
variants on this machine's GL, and for the fast form emulated in numpy with the 8-bit fractional
filter weights of typical GPU texture units (emulate_fast below; float64 otherwise), which is the
precision the fast variant would have there.
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

from vgraph.gl_context import get_context
from vgraph.gl.tricubic import FETCHES, VARIANTS, ProbeBatch, evaluate_gl, probe_program
from vgraph.implicit import sample
from vgraph.numerics.bspline import bspline_weights, evaluate, prefilter
from vgraph.volume import Volume

ORDERS = {0: "value", 1: "+ gradient", 2: "+ Hessian"}
PARTIALS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (2, 0, 0), (0, 2, 0), (0, 0, 2), (1, 1, 0),
            (1, 0, 1), (0, 1, 1)]


# ------------------------------------------------------------------------------------- emulation

def fast_taps(u: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions and weights (N, taps) of the fast form along one axis (tricubic_fast.glsl)."""
    base = np.floor(u)
    t = u - base
    if order == 2:
        return np.stack([u - 1.0, u, u + 1.0], -1), np.broadcast_to([1.0, -2.0, 1.0], u.shape + (3,))
    w = bspline_weights(t, order)
    g0, g1 = w[:, 0] + w[:, 1], w[:, 2] + w[:, 3]
    positions = np.stack([base - 1.0 + w[:, 1] / g0, base + 1.0 + w[:, 3] / g1], -1)
    return positions, np.stack([g0, g1], -1)


def mirror_coordinate(u: np.ndarray, n: int) -> np.ndarray:
    if n < 2:
        return np.zeros_like(u)
    last = n - 1.0
    return last - np.abs(np.mod(np.abs(u), 2.0 * last) - last)


def linear_fetch(c: np.ndarray, ux, uy, uz, weight_bits: int | None) -> np.ndarray:
    """Trilinear interpolation of c [z, y, x] at folded voxel coordinates (broadcast), with the
    fractional weights rounded to ``weight_bits`` bits as a texture unit does (None: exact)."""
    result = 0.0
    corners = []
    for u, n in ((ux, c.shape[2]), (uy, c.shape[1]), (uz, c.shape[0])):
        u = mirror_coordinate(u, n)
        i0 = np.floor(u)
        f = u - i0
        if weight_bits is not None:
            f = np.round(f * 2**weight_bits) / 2**weight_bits
        i0 = i0.astype(np.int64)
        corners.append(((np.minimum(i0, n - 1), 1.0 - f), (np.minimum(i0 + 1, n - 1), f)))
    for ix, wx in corners[0]:
        for iy, wy in corners[1]:
            for iz, wz in corners[2]:
                result = result + wx * wy * wz * c[iz, iy, ix]
    return result


def emulate_fast(c: np.ndarray, points: np.ndarray, weight_bits: int | None = 8) -> np.ndarray:
    """(N, 10) value, gradient, Hessian (xx, yy, zz, xy, xz, yz) per voxel by the fast form."""
    c = c.astype(np.float64)
    taps = [[fast_taps(points[:, axis], order) for order in range(3)] for axis in range(3)]
    out = np.empty((len(points), len(PARTIALS)))
    for column, (ox, oy, oz) in enumerate(PARTIALS):
        (px, wx), (py, wy), (pz, wz) = taps[0][ox], taps[1][oy], taps[2][oz]
        fetched = linear_fetch(c, px[:, :, None, None], py[:, None, :, None], pz[:, None, None, :],
                               weight_bits)
        weights = wx[:, :, None, None] * wy[:, None, :, None] * wz[:, None, None, :]
        out[:, column] = (fetched * weights).sum(axis=(1, 2, 3))
    return out


# ------------------------------------------------------------------------------------------ speed

def time_variants(ctx, volume: Volume, points: np.ndarray, order: str, repeats: int) -> list[str]:
    """Rows of the speed table for one point set: best wall and CPU time (the process's CPU time
    includes llvmpipe's rendering threads, and is steadier on a shared machine)."""
    width = 1024
    height = -(-len(points) // width)
    rows = []
    for derivatives in (0, 1, 2):
        best = {variant: [float("inf")] * 3 for variant in VARIANTS}  # wall, CPU, evaluate_gl
        batch = ProbeBatch(ctx, width, height, derivatives)
        batch.upload(points)
        try:
            for variant in VARIANTS:  # compile and JIT outside the timing
                batch.run(probe_program(ctx, variant, derivatives), volume, variant)
            ctx.finish()
            for _ in range(repeats):
                for variant in VARIANTS:
                    program = probe_program(ctx, variant, derivatives)
                    wall, cpu = time.perf_counter(), time.process_time()
                    batch.run(program, volume, variant)
                    ctx.finish()
                    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
                    start = time.perf_counter()
                    evaluate_gl(ctx, volume, points, variant, derivatives)
                    total = time.perf_counter() - start
                    best[variant] = [min(a, b) for a, b in zip(best[variant], (wall, cpu, total))]
        finally:
            batch.release()
        for variant in VARIANTS:
            wall, cpu, total = best[variant]
            rows.append(f"| {order} | {variant} | {ORDERS[derivatives]} | "
                        f"{FETCHES[variant][derivatives]} | {wall * 1e3:.0f} | {cpu * 1e3:.0f} | "
                        f"{len(points) / wall / 1e6:.2f} | {total * 1e3:.0f} |")
    return rows


def point_sets(count: int, size: int) -> dict[str, np.ndarray]:
    """'random': uniform in the grid's interior; 'coherent': a lattice in x-fastest order with
    about the same count (neighbouring pixels sample neighbouring points, as along rays)."""
    rng = np.random.default_rng(0)
    random = rng.uniform(1.0, size - 2.0, size=(count, 3)).astype(np.float32)
    side = max(2, round(count ** (1.0 / 3.0)))
    axis = np.linspace(1.0, size - 2.0, side)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    coherent = np.stack([x.ravel(), y.ravel(), z.ravel()], -1).astype(np.float32)
    return {"random": random, "coherent": coherent}


# -------------------------------------------------------------------------------------- precision

def relative_errors(columns: np.ndarray, reference) -> tuple[float, float, float]:
    ref = np.concatenate([reference.value[:, None], reference.gradient,
                          reference.hessian[:, [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]], axis=1)
    parts = (slice(0, 1), slice(1, 4), slice(4, 10))
    return tuple(float(np.abs(columns[:, s] - ref[:, s]).max() / np.abs(ref[:, s]).max())
                 for s in parts)


def precision_rows(ctx, count: int = 20000) -> list[str]:
    rng = np.random.default_rng(5)
    volumes = {"random 48^3": Volume(prefilter(rng.standard_normal((48, 48, 48))),
                                     is_spline_coefficients=True)}
    for name in ("torus", "marschner_lobb"):
        sampled = sample(name, 64)
        volumes[f"{name} 64^3"] = Volume(prefilter(sampled.data), spacing=sampled.spacing,
                                         is_spline_coefficients=True)
    rows = []
    for name, volume in volumes.items():
        dims = np.array(volume.dims)
        points = rng.uniform(1.0, dims - 2.0, size=(count, 3)).astype(np.float32).astype(np.float64)
        reference = evaluate(volume.data, points, volume.spacing, 2)
        for variant in VARIANTS:
            got = evaluate_gl(ctx, volume, points, variant, 2)
            columns = np.concatenate([got.value[:, None], got.gradient,
                                      got.hessian[:, [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]], 1)
            rows.append(_precision_row(name, f"{variant} (this GL)", relative_errors(columns, reference)))
        emulated = emulate_fast(volume.data, points, weight_bits=8)
        step = np.asarray(volume.spacing)
        emulated[:, 1:4] /= step
        emulated[:, 4:10] /= np.array([step[0] ** 2, step[1] ** 2, step[2] ** 2, step[0] * step[1],
                                       step[0] * step[2], step[1] * step[2]])
        rows.append(_precision_row(name, "fast, 8-bit weights (emulated)",
                                   relative_errors(emulated, reference)))
    return rows


def _precision_row(volume: str, variant: str, errors) -> str:
    return f"| {volume} | {variant} | " + " | ".join(f"{e:.1e}" for e in errors) + " |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1 << 20)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    ctx = get_context()
    rng = np.random.default_rng(0)
    volume = Volume(prefilter(rng.standard_normal((args.size,) * 3)), is_spline_coefficients=True)
    sets = point_sets(args.points, args.size)
    lines = [f"GL: {ctx.info['GL_RENDERER']}; {platform.processor() or platform.machine()}; "
             f"{args.points} points ({len(sets['coherent'])} coherent) in a {args.size}^3 volume; "
             f"best of {args.repeats}.", "",
             "| points | variant | result | fetches/point | GPU pass ms | CPU ms | M evals/s | "
             "evaluate_gl ms |", "|---|---|---|---|---|---|---|---|"]
    for order, points in sets.items():
        lines += time_variants(ctx, volume, points, order, args.repeats)
    lines += ["", "Max error relative to max |reference| (CPU float64, numerics.bspline.evaluate), "
              "20 000 interior points:", "",
              "| volume | variant | value | gradient | Hessian |", "|---|---|---|---|---|"]
    lines += precision_rows(ctx)
    text = "\n".join(lines)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
