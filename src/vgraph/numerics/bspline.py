"""Cubic B-spline prefilter and tricubic evaluation (value, gradient, Hessian): the CPU reference.

Conventions
- Volumes are [z, y, x] arrays. Points are voxel-index coordinates in (x, y, z) order: voxel
  (i, j, k) = data[k, j, i] sits at point (i, j, k). World units = voxel units times spacing (x, y, z).
- Boundary: whole-sample mirror, g[-k] = g[k] and g[n-1+k] = g[n-1-k], exactly scipy.ndimage's
  mode='mirror'. The prefilter uses the matching initial values, so the coefficients of the mirrored
  signal are the mirrored coefficients; evaluation therefore mirrors coefficient indices outside the
  grid, which makes the spline an even function about both end samples (no coordinate folding, so
  derivatives keep their sign just outside the grid).
- An axis of length 1 is constant: its coefficients equal the data (scipy does the same).

Prefilter (Cabral 2010, sec. 3.1-3.2): with the pole z = sqrt(3) - 2 and gain 6 per axis,
    causal      o[k] = g[k] + z o[k-1],   o[0] = sum_k z^k g_mirrored[k]
    anticausal  c[k] = z (c[k+1] - o[k]), c[n-1] = z / (z^2 - 1) (o[n-1] + z o[n-2])
computed in float64 and rounded once to float32. The recursions run over whole 2D slabs at a time
(vectorised across the two other axes). x and y are filtered inside blocks of z-slices small
enough to stay in cache (x on a transposed copy, so that its slabs are contiguous); z runs last
over the whole volume and writes the gained float32 result during its final sweep. Large volumes
share the blocks between two threads (numpy releases the GIL inside its loops).

Evaluation: f(p) = sum c[k, j, i] B3(x - i) B3(y - j) B3(z - k) (seed eq. 3.10); derivatives use B3'
and B3'' (eq. 3.5, 3.6) in the factor of the differentiated axis. Everything is float64.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from typing import Callable, NamedTuple

import numpy as np

POLE = np.sqrt(3.0) - 2.0
GAIN = 6.0  # (1 - z)(1 - 1/z) for the cubic pole: makes the filter exact on constants
# Beyond this many terms z^k < 1e-20, far below float64 resolution: the causal start sum is cut there.
_HORIZON = 36
_X_SLAB = 4096  # elements per slab in the transposed x pass (32 KiB float64: stays in L1/L2; measured)
_XY_SHARE = 0.6  # share of the prefilter's time spent on the x and y passes, for progress reports
_THREADED_VOXELS = 1 << 22  # below this, a second thread costs more than it saves (measured)
_EVAL_CHUNK = 32768  # points per evaluation chunk: bounds the (N, 4, 4, 4) gather to ~16 MB

ProgressFn = Callable[[float], None]


class SplineSample(NamedTuple):
    """Result of :func:`evaluate`; ``gradient``/``hessian`` are None when not requested."""

    value: np.ndarray  # shape (...)
    gradient: np.ndarray | None  # shape (..., 3), (d/dx, d/dy, d/dz) per world unit
    hessian: np.ndarray | None  # shape (..., 3, 3), rows/columns in (x, y, z) order, world units


# ----------------------------------------------------------------------------------------------
# Prefilter
# ----------------------------------------------------------------------------------------------

def prefilter(data, progress: ProgressFn | None = None, workers: int | None = None) -> np.ndarray:
    """Cubic B-spline coefficients of a [z, y, x] volume, as a float32 [z, y, x] array.

    Agrees with ``scipy.ndimage.spline_filter(data, order=3, mode='mirror')`` to float32 rounding
    (the work is float64; the result is rounded once). ``progress`` (optional) is called with the
    finished fraction in [0, 1]. ``workers``: threads sharing the work; default 1 for small
    volumes (thread hand-offs cost more than they save) and up to 2 from 4 M voxels on.
    NaN/Inf in the data spread along the recursion lines, as in scipy.
    """
    volume = np.ascontiguousarray(data)
    if volume.ndim != 3:
        raise ValueError(f"prefilter: expected a 3D [z, y, x] array, got shape {volume.shape}")
    if volume.dtype.kind not in "uif" or 0 in volume.shape:
        raise ValueError(f"prefilter: need a non-empty integer or float volume, got dtype "
                         f"{volume.dtype}, shape {volume.shape}")
    if workers is None:
        workers = min(2, os.cpu_count() or 1) if volume.size >= _THREADED_VOXELS else 1
    report = progress or (lambda fraction: None)
    nz, ny, nx = volume.shape
    work = np.empty(volume.shape, dtype=np.float64)
    coefficients = np.empty(volume.shape, dtype=np.float32)
    gain = GAIN ** sum(n > 1 for n in volume.shape)
    depth = max(1, min(nz, _X_SLAB // ny))
    if workers > 1:
        depth = max(1, min(depth, -(-nz // workers)))
    blocks = [(z0, min(nz, z0 + depth)) for z0 in range(0, nz, depth)]
    pool = ThreadPoolExecutor(max_workers=workers) if workers > 1 else None
    try:
        # x and y inside cache-sized blocks of z-slices, then z across the whole volume with the
        # gained float32 result written during its last sweep
        report(0.0)
        _run(pool, [partial(_filter_xy_block, volume, work, z0, z1) for z0, z1 in blocks],
             lambda done: report(_XY_SHARE * done / len(blocks)))
        _run(pool, [partial(_filter_lines, work[:, lo:hi], work[:, lo:hi], 0,
                            coefficients[:, lo:hi], gain) for lo, hi in _split(ny, workers)])
    finally:
        if pool is not None:
            pool.shutdown()
    report(1.0)
    return coefficients


def _filter_xy_block(volume: np.ndarray, work: np.ndarray, z0: int, z1: int) -> None:
    """Filter slices z0..z1 along x on a transposed float64 copy (so x slabs are contiguous; the
    conversion rides along with the transposition), then along y in place in `work`."""
    # always a copy: with float64 input and one-voxel axes the transposed view can already be
    # contiguous, and filtering it in place would change the caller's data
    transposed = np.array(volume[z0:z1].transpose(2, 0, 1), dtype=np.float64, order="C", copy=True)
    _filter_lines(transposed, transposed, 0)  # (x, z, y)
    block = work[z0:z1]
    block[...] = transposed.transpose(1, 2, 0)
    _filter_lines(block, block, 1)


def _split(length: int, parts: int) -> list[tuple[int, int]]:
    edges = np.linspace(0, length, max(1, min(parts, length)) + 1).astype(int)
    return [(int(lo), int(hi)) for lo, hi in zip(edges[:-1], edges[1:]) if hi > lo]


def _run(pool, jobs, done: Callable[[int], None] | None = None) -> None:
    """Run the jobs (in the pool if there is one); done(count) is called on the calling thread."""
    pending = [pool.submit(job) for job in jobs] if pool is not None else None
    for count, job in enumerate(jobs, start=1):
        if pending is None:
            job()
        else:
            pending[count - 1].result()
        if done is not None:
            done(count)


def causal_start_weights(n: int) -> np.ndarray:
    """Weights w with o[0] = sum_k w[k] g[k] for the mirror boundary (length min(n, horizon)).

    The mirrored signal has period 2n-2, sample j appearing at offsets j and 2n-2-j, so
    o[0] = sum_j (z^j + z^(2n-2-j)) g[j] / (1 - z^(2n-2)), the ends counted once; this is the
    closed form scipy uses. For long axes the terms past the horizon are below float64 resolution.
    """
    if n < 2:
        return np.ones(1)
    z = POLE
    if n > _HORIZON:
        return z ** np.arange(_HORIZON, dtype=np.float64)
    j = np.arange(n, dtype=np.float64)
    weights = z**j + z ** (2 * n - 2 - j)
    weights[0] = 1.0
    weights[-1] = z ** (n - 1)
    return weights / (1.0 - z ** (2 * n - 2))


def _filter_lines(source: np.ndarray, target: np.ndarray, axis: int,
                  output: np.ndarray | None = None, gain: float = 1.0) -> None:
    """Causal + anticausal recursion (no gain) along `axis` (0 or 1) of 3D arrays.

    The causal pass reads `source` (any numeric dtype) and writes `target` (float64, same shape;
    may be the same array). The anticausal pass works in place, or, if `output` is given, writes
    gain * result there instead (cast on the fly) and leaves `target` holding the causal pass.
    Each step is one numpy operation on a whole 2D slab, so the Python loop runs n times per pass.
    """
    n = target.shape[axis]
    if n < 2:
        if output is not None:
            np.multiply(source, gain, out=output, casting="same_kind")
        elif source is not target:
            target[...] = source
        return
    # views with the recursion axis first, so that slab k is simply view[k]
    src = source if axis == 0 else source.swapaxes(0, 1)
    dst = target if axis == 0 else target.swapaxes(0, 1)
    z = POLE
    weights = causal_start_weights(n)
    # einsum's own loop, not BLAS: a BLAS call here wakes its worker threads, whose spinning
    # afterwards competes with this thread for the CPUs (measured: small volumes 30 % slower)
    dst[0] = np.einsum("k...,k->...", src[: len(weights)], weights)
    scratch = np.empty(dst.shape[1:])
    for k in range(1, n):  # causal: o[k] = g[k] + z o[k-1]
        np.multiply(dst[k - 1], z, out=scratch)
        np.add(src[k], scratch, out=dst[k])
    # anticausal start from the mirror condition, then c[k] = z (c[k+1] - o[k])
    np.multiply(dst[n - 2], z, out=scratch)
    np.add(scratch, dst[n - 1], out=scratch)
    if output is None:
        np.multiply(scratch, z / (z * z - 1.0), out=dst[n - 1])
        for k in range(n - 2, -1, -1):
            np.subtract(dst[k + 1], dst[k], out=scratch)
            np.multiply(scratch, z, out=dst[k])
        return
    out = output if axis == 0 else output.swapaxes(0, 1)
    current = scratch * (z / (z * z - 1.0))  # c[k], rolled down the axis
    np.multiply(current, gain, out=out[n - 1], casting="same_kind")
    for k in range(n - 2, -1, -1):
        np.subtract(current, dst[k], out=current)
        np.multiply(current, z, out=current)
        np.multiply(current, gain, out=out[k], casting="same_kind")


# ----------------------------------------------------------------------------------------------
# Kernels
# ----------------------------------------------------------------------------------------------

def bspline_kernel(x, derivative: int = 0) -> np.ndarray:
    """B3(x), B3'(x) or B3''(x) (seed eq. 3.3, 3.5, 3.6), elementwise, float64."""
    x = np.asarray(x, dtype=np.float64)
    a = np.abs(x)
    inner, outer = a < 1.0, (a >= 1.0) & (a < 2.0)
    if derivative == 0:
        return np.where(inner, 2.0 / 3.0 - 0.5 * a * a * (2.0 - a),
                        np.where(outer, (2.0 - a) ** 3 / 6.0, 0.0))
    if derivative == 1:  # odd function: sign(x) times the derivative in |x|
        return np.sign(x) * np.where(inner, 1.5 * a * a - 2.0 * a,
                                     np.where(outer, -0.5 * (2.0 - a) ** 2, 0.0))
    if derivative == 2:
        return np.where(inner, 3.0 * a - 2.0, np.where(outer, 2.0 - a, 0.0))
    raise ValueError(f"bspline_kernel: derivative must be 0, 1 or 2, got {derivative!r}")


def bspline_weights(t, derivative: int = 0) -> np.ndarray:
    """Weights of the four coefficients at offsets -1, 0, 1, 2 from floor(x), t = x - floor(x).

    Returns shape t.shape + (4,): [B(t+1), B(t), B(t-1), B(t-2)] for the chosen derivative order.
    """
    t = np.asarray(t, dtype=np.float64)
    s = 1.0 - t
    if derivative == 0:
        rows = (s**3 / 6.0, (3.0 * t**3 - 6.0 * t**2 + 4.0) / 6.0,
                (-3.0 * t**3 + 3.0 * t**2 + 3.0 * t + 1.0) / 6.0, t**3 / 6.0)
    elif derivative == 1:
        rows = (-0.5 * s**2, 1.5 * t**2 - 2.0 * t, -1.5 * t**2 + t + 0.5, 0.5 * t**2)
    elif derivative == 2:
        rows = (s, 3.0 * t - 2.0, 1.0 - 3.0 * t, t)
    else:
        raise ValueError(f"bspline_weights: derivative must be 0, 1 or 2, got {derivative!r}")
    return np.stack(rows, axis=-1)


def mirror_index(index: np.ndarray, n: int) -> np.ndarray:
    """Fold integer indices into [0, n-1] by whole-sample mirroring (period 2n-2)."""
    if n == 1:
        return np.zeros_like(index)
    period = 2 * n - 2
    folded = np.mod(index, period)
    return np.where(folded >= n, period - folded, folded)


# ----------------------------------------------------------------------------------------------
# Evaluation
# ----------------------------------------------------------------------------------------------

def evaluate(coeffs, points_xyz_voxel, spacing=(1.0, 1.0, 1.0), derivatives: int = 0) -> SplineSample:
    """Tricubic B-spline value (and gradient, Hessian) at arbitrary points, float64.

    coeffs: [z, y, x] coefficients (from :func:`prefilter`). points_xyz_voxel: array (..., 3) of
    voxel coordinates (x, y, z). spacing: (x, y, z) world size of a voxel; gradient components are
    divided by the spacing of their axis and Hessian entries by the product of the two spacings.
    derivatives: 0 (value), 1 (+ gradient) or 2 (+ Hessian). Non-finite points give NaN results.
    """
    if derivatives not in (0, 1, 2):
        raise ValueError(f"evaluate: derivatives must be 0, 1 or 2, got {derivatives!r}")
    c = np.asarray(coeffs)
    if c.ndim != 3 or 0 in c.shape:
        raise ValueError(f"evaluate: coefficients must be a non-empty 3D [z, y, x] array, got {c.shape}")
    points = np.asarray(points_xyz_voxel, dtype=np.float64)
    if points.shape[-1:] != (3,):
        raise ValueError(f"evaluate: points must have shape (..., 3) in (x, y, z), got {points.shape}")
    step = np.asarray(spacing, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(step) & (step > 0)):
        raise ValueError(f"evaluate: spacing must be three positive numbers, got {spacing!r}")
    flat = points.reshape(-1, 3)
    count = flat.shape[0]
    value = np.empty(count)
    gradient = np.empty((count, 3)) if derivatives >= 1 else None
    hessian = np.empty((count, 3, 3)) if derivatives >= 2 else None
    for lo in range(0, count, _EVAL_CHUNK):
        hi = min(count, lo + _EVAL_CHUNK)
        parts = _evaluate_chunk(c, flat[lo:hi], derivatives)
        value[lo:hi] = parts[(0, 0, 0)]
        if gradient is not None:
            for axis in range(3):
                gradient[lo:hi, axis] = parts[_unit(axis)]
        if hessian is not None:
            for a in range(3):
                for b in range(3):
                    hessian[lo:hi, a, b] = parts[tuple(np.add(_unit(a), _unit(b)))]
    bad = ~np.all(np.isfinite(flat), axis=1)
    value[bad] = np.nan
    shape = points.shape[:-1]
    if gradient is not None:
        gradient = (gradient / step)
        gradient[bad] = np.nan
        gradient = gradient.reshape(shape + (3,))
    if hessian is not None:
        hessian = hessian / np.outer(step, step)
        hessian[bad] = np.nan
        hessian = hessian.reshape(shape + (3, 3))
    return SplineSample(value.reshape(shape), gradient, hessian)


def _unit(axis: int) -> tuple[int, int, int]:
    orders = [0, 0, 0]
    orders[axis] = 1
    return tuple(orders)


def _evaluate_chunk(c: np.ndarray, points: np.ndarray, derivatives: int) -> dict:
    """All partial derivatives up to `derivatives` (keys: (order_x, order_y, order_z)), voxel units."""
    finite = np.where(np.isfinite(points), points, 0.0)
    base = np.floor(finite)
    frac = finite - base
    base = base.astype(np.int64)
    offsets = np.arange(-1, 3)
    nz, ny, nx = c.shape
    ix = mirror_index(base[:, 0, None] + offsets, nx)
    iy = mirror_index(base[:, 1, None] + offsets, ny)
    iz = mirror_index(base[:, 2, None] + offsets, nz)
    block = c[iz[:, :, None, None], iy[:, None, :, None], ix[:, None, None, :]].astype(np.float64)
    weights = [[bspline_weights(frac[:, axis], order) for order in range(derivatives + 1)]
               for axis in range(3)]
    results = {}
    for ox in range(derivatives + 1):  # contract x first (64 -> 16 per point), then y, then z
        over_x = np.einsum("nzyx,nx->nzy", block, weights[0][ox])
        for oy in range(derivatives + 1 - ox):
            over_y = np.einsum("nzy,ny->nz", over_x, weights[1][oy])
            for oz in range(derivatives + 1 - ox - oy):
                results[(ox, oy, oz)] = np.einsum("nz,nz->n", over_y, weights[2][oz])
    return results
