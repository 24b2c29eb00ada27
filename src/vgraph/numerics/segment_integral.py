"""The exact emission-absorption integral along a segment of a ray through a tetrahedron, for the
tetrahedra reference (vgraph.numerics.reference_tetra, rules 3 and 4 of its docstring): the
normalised transfer function as linear pieces over intensity, the segment split where its
linear scalar crosses them, each piece's optical depth in closed form and its colour by
integration by parts with one Gauss-Legendre quadrature, in batches of bounded memory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vgraph.errors import VGraphError
from vgraph.transfer_function import TransferFunction

MAX_OPACITY = 1.0 - 1e-7  # TF point opacities are clamped to this (finite extinction)
GAUSS_POINTS = 16
MAX_DEPTH_PER_INTERVAL = 4.0  # optical depth of one Gauss-Legendre sub-interval, at most
MAX_B_RATIO = 8.0  # (1 - a) varies by at most this factor over one sub-interval
MAX_SPLITS = 4096
SATURATED_DEPTH = 40.0  # optical depth past which 1 - exp(-Tau) is 1 in float64 (exp(-40) = 4e-18)
QUADRATURE_NODES = 1 << 20  # Gauss-Legendre nodes per batch, at most (bounded memory)
SEGMENT_PIECES = 1 << 19  # segments x TF pieces integrated at once, at most (bounded memory)

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(GAUSS_POINTS)
_NODES, _WEIGHTS = (_NODES + 1.0) / 2.0, _WEIGHTS / 2.0  # on [0, 1]


# --- the transfer function as pieces ------------------------------------------------------------
@dataclass(frozen=True)
class Pieces:
    """The TF as P + 1 pieces over intensity: [lo, hi] with RGBA va at lo and vb at hi, linear
    between; the first and the last piece are the constant extensions to -inf and +inf."""

    lo: np.ndarray  # (P + 1,)
    hi: np.ndarray
    va: np.ndarray  # (P + 1, 4)
    vb: np.ndarray

    @classmethod
    def of(cls, tf: TransferFunction) -> "Pieces":
        if tf.needs_volume:  # data units, percentiles or a shift in data units
            raise VGraphError("tetrahedra reference: the transfer function must be normalised "
                              "(use tf.for_volume(mesh))")
        table = np.asarray(tf.points, dtype=np.float64)
        table[:, 0] = np.maximum.accumulate(table[:, 0])
        table[:, 4] = np.minimum(table[:, 4], MAX_OPACITY)
        p, v = table[:, 0], table[:, 1:]
        lo = np.concatenate([[-np.inf], p])
        hi = np.concatenate([p, [np.inf]])
        va = np.concatenate([v[:1], v])
        vb = np.concatenate([v, v[-1:]])
        return cls(lo, hi, va, vb)


# --- one segment --------------------------------------------------------------------------------
def segment_integral(s_front, s_back, length, transfer_function: TransferFunction,
                     opacity_length: float) -> np.ndarray:
    """Premultiplied RGBA of a segment of ``length`` world units along which the normalised
    intensity goes linearly from ``s_front`` (where the ray enters) to ``s_back``, for a normalised
    transfer function whose opacities are per ``opacity_length`` (rule 4 of
    vgraph.numerics.reference_tetra). Arguments broadcast; returns shape + (4,) float64. Constant
    TF (c, a) over the segment: ``alpha = 1 - (1 - a) ** (length / L)``, ``rgb = c * alpha``."""
    if not (math.isfinite(opacity_length) and opacity_length > 0.0):
        raise VGraphError(f"tetrahedra reference: opacity_length must be positive, got {opacity_length}")
    s_front, s_back, length = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64)
                                                    for v in (s_front, s_back, length)))
    if np.any(length < 0.0) or not np.all(np.isfinite(length)):
        raise VGraphError("tetrahedra reference: segment lengths must be finite and >= 0")
    shape = s_front.shape
    colour, depth, _ = integrate(s_front.ravel(), s_back.ravel(), length.ravel(),
                                 Pieces.of(transfer_function), float(opacity_length))
    return np.concatenate([colour, -np.expm1(-depth)[:, None]], axis=1).reshape(*shape, 4)


def integrate(s_f, s_b, length, pieces: Pieces, L: float):
    """(premultiplied rgb (n, 3), optical depth (n,), fraction along the segment of the first
    point with opacity > 0 (n,), inf where none) of n segments."""
    n = len(s_f)
    chunk = max(1, SEGMENT_PIECES // len(pieces.lo))
    colour, depth, first = np.zeros((n, 3)), np.zeros(n), np.full(n, np.inf)
    for start in range(0, n, chunk):
        part = slice(start, start + chunk)
        colour[part], depth[part], first[part] = _integrate_part(s_f[part], s_b[part],
                                                                 length[part], pieces, L)
    return colour, depth, first


def _integrate_part(s_f, s_b, length, pieces: Pieces, L: float):
    ds = (s_b - s_f)[:, None]
    lo, hi = pieces.lo[None, :], pieces.hi[None, :]
    moving = ds != 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        xa = np.where(moving, (lo - s_f[:, None]) / ds, 0.0)
        xb = np.where(moving, (hi - s_f[:, None]) / ds, 0.0)
    x0 = np.clip(np.minimum(xa, xb), 0.0, 1.0)
    x1 = np.clip(np.maximum(xa, xb), 0.0, 1.0)
    # A segment of constant intensity lies in the one piece lo <= s < hi.
    holds = (lo <= s_f[:, None]) & (s_f[:, None] < hi)
    x0 = np.where(moving, x0, 0.0)
    x1 = np.where(moving, x1, np.where(holds, 1.0, 0.0))
    x1 = np.maximum(x1, x0)
    # Front-to-back order of the pieces: ascending intensity if it rises along the ray.
    falling = (ds < 0.0)[:, 0]
    x0[falling], x1[falling] = x0[falling, ::-1], x1[falling, ::-1]
    order = np.where(falling[:, None], np.arange(x0.shape[1])[::-1], np.arange(x0.shape[1]))
    piece_lo, piece_hi = pieces.lo[order], pieces.hi[order]
    va, vb = pieces.va[order], pieces.vb[order]

    h = (x1 - x0) * length[:, None]
    used = h > 0.0
    rows, cols = np.nonzero(used)
    s0 = s_f[rows] + ds[rows, 0] * x0[rows, cols]
    s1 = s_f[rows] + ds[rows, 0] * x1[rows, cols]
    c_lo, c_hi = piece_lo[rows, cols], piece_hi[rows, cols]
    width = c_hi - c_lo
    finite = np.isfinite(width) & (width > 0.0)
    safe_lo = np.where(np.isfinite(c_lo), c_lo, 0.0)
    safe_width = np.where(finite, width, 1.0)

    def value(s):
        f = np.where(finite, (np.clip(s, c_lo, c_hi) - safe_lo) / safe_width, 0.0)
        return va[rows, cols] + (vb[rows, cols] - va[rows, cols]) * f[:, None]

    rgba0, rgba1 = value(s0), value(s1)
    tau_piece, rgb_piece = _pieces_integral(h[rows, cols] / L, rgba0, rgba1)

    depth = np.zeros(x0.shape)
    depth[rows, cols] = tau_piece
    rgb = np.zeros(x0.shape + (3,))
    rgb[rows, cols] = rgb_piece
    before = np.cumsum(depth, axis=1) - depth
    colour = np.einsum("ij,ijk->ik", np.exp(-before), rgb)
    visible = depth > 0.0
    first = np.where(visible.any(axis=1),
                     x0[np.arange(len(x0)), np.argmax(visible, axis=1)], np.inf)
    return colour, depth.sum(axis=1), first


def _pieces_integral(K, rgba0, rgba1):
    """Optical depth and premultiplied rgb of pieces where RGBA is linear from rgba0 to rgba1,
    K = piece length / L (rule 4)."""
    a0, a1 = rgba0[:, 3], rgba1[:, 3]
    tau = np.maximum(-K * _mean_log_b(a0, a1, 1.0), 0.0)
    alpha = -np.expm1(-tau)
    c0, c1 = rgba0[:, :3], rgba1[:, :3]
    rgb = c1 * alpha[:, None]
    sloped = (tau > 0.0) & np.any(c1 != c0, axis=1)
    if np.any(sloped):
        mean_alpha = _mean_alpha(K[sloped], a0[sloped], a1[sloped])
        rgb[sloped] -= (c1[sloped] - c0[sloped]) * mean_alpha[:, None]
    return tau, rgb


def _mean_log_b(a0, a1, x):
    """Mean of ln(1 - a) over [0, x] for a linear from a0 (at 0) to a1 (at 1), closed form:
    ln b0 + phi(r x), phi(r) = (1 + r) ln(1 + r) / r - 1, r = (b1 - b0) / b0."""
    r = (a0 - a1) / (1.0 - a0) * x
    small = np.abs(r) < 1e-3
    safe = np.where(small, 1.0, r)
    phi = np.where(small, r * (0.5 + r * (-1.0 / 6.0 + r * (1.0 / 12.0 - r / 20.0))),
                   (1.0 + safe) * np.log1p(safe) / safe - 1.0)
    return np.log1p(-a0) + phi


def _mean_alpha(K, a0, a1):
    """int_0^1 (1 - exp(-Tau(x))) dx per piece, Tau(x) = -K x mean ln b over [0, x]: composite
    16-point Gauss-Legendre on sub-intervals of optical depth <= 4 and, where 1 - a varies by more
    than a factor 8, geometric in 1 - a. Past the point x_s where Tau reaches SATURATED_DEPTH the
    integrand is 1 to within exp(-40) = 4e-18 and is taken as 1, so the number of sub-intervals is
    bounded whatever the optical depth; pieces go through the quadrature in batches of at most
    QUADRATURE_NODES nodes (bounded memory)."""
    end = _saturation_point(K, a0, a1)
    mean = 1.0 - end  # the saturated rest [end, 1]
    at_end = np.where(end < 1.0, -np.log1p(-(a0 + (a1 - a0) * end)), -np.log1p(-a1))
    steepest = np.maximum(-np.log1p(-a0), at_end) * K * end
    m1 = np.clip(np.ceil(steepest / MAX_DEPTH_PER_INTERVAL), 1, MAX_SPLITS).astype(np.int64)
    # Nodes per piece, at most: m1 uniform intervals, each cut in up to 64 geometric ones.
    cost = np.cumsum(m1 * 64 * GAUSS_POINTS)
    start = 0
    while start < len(K):
        base = cost[start - 1] if start else 0
        stop = max(int(np.searchsorted(cost, base + QUADRATURE_NODES, side="right")), start + 1)
        part = slice(start, stop)
        mean[part] += _gauss_legendre(K[part], a0[part], a1[part], end[part], m1[part])
        start = stop
    return mean


def _saturation_point(K, a0, a1):
    """Per piece the x in (0, 1] where Tau(x) = SATURATED_DEPTH (1 where Tau(1) is less), by
    bisection: Tau grows with x."""
    end = np.ones(len(K))
    deep = np.flatnonzero(-K * _mean_log_b(a0, a1, 1.0) > SATURATED_DEPTH)
    if deep.size:
        k, p0, p1 = K[deep], a0[deep], a1[deep]
        lo, hi = np.zeros(deep.size), np.ones(deep.size)
        for _ in range(60):
            middle = 0.5 * (lo + hi)
            over = -k * middle * _mean_log_b(p0, p1, middle) > SATURATED_DEPTH
            hi, lo = np.where(over, middle, hi), np.where(over, lo, middle)
        end[deep] = hi
    return end


def _gauss_legendre(K, a0, a1, end, m1):
    """int_0^end (1 - exp(-Tau(x))) dx per piece on m1 uniform sub-intervals, each cut where b
    varies by more than MAX_B_RATIO (see _mean_alpha)."""
    n = len(K)
    piece, j, m = expand(m1)
    xa, xb = j / m * end[piece], (j + 1) / m * end[piece]
    b_a = 1.0 - (a0[piece] + (a1[piece] - a0[piece]) * xa)
    b_b = 1.0 - (a0[piece] + (a1[piece] - a0[piece]) * xb)
    ratio = np.maximum(b_a, b_b) / np.minimum(b_a, b_b)
    m2 = np.clip(np.ceil(np.log(ratio) / math.log(MAX_B_RATIO) - 1e-9), 1, 64).astype(np.int64)
    sub, k, m = expand(m2)
    piece = piece[sub]
    xa, xb, b_a, b_b = xa[sub], xb[sub], b_a[sub], b_b[sub]
    geometric = b_a != b_b
    with np.errstate(divide="ignore", invalid="ignore"):
        q = b_b / b_a
        frac_lo = np.where(geometric, (q ** (k / m) - 1.0) / (q - 1.0), k / m)
        frac_hi = np.where(geometric, (q ** ((k + 1) / m) - 1.0) / (q - 1.0), (k + 1) / m)
    lo = xa + (xb - xa) * frac_lo
    hi = xa + (xb - xa) * np.where(k + 1 == m, 1.0, frac_hi)
    x = lo[:, None] + (hi - lo)[:, None] * _NODES[None, :]
    p = piece[:, None]
    tau = np.maximum(-K[p] * x * _mean_log_b(a0[p], a1[p], x), 0.0)
    values = (-np.expm1(-tau)) @ _WEIGHTS * (hi - lo)
    return np.bincount(piece, weights=values, minlength=n)


def expand(counts):
    """For items with these counts: (item of each entry, index within its item, item's count)."""
    item = np.repeat(np.arange(len(counts)), counts)
    starts = np.cumsum(counts) - counts
    index = np.arange(len(item)) - starts[item]
    return item, index, counts[item]
