"""Partial pre-integration (Moreland & Angel 2004): a table that does not depend on the transfer
function, exact for a TF whose colour and extinction are linear between its points; the TF is
split into such pieces and a ray's segment through a tetrahedron is integrated piece by piece.

Across one piece the scalar, hence colour c and extinction tau, go linearly along the ray from the
piece's front (u = 0) to its back (u = 1). With D_f = l tau_f and D_b = l tau_b (l the piece's
length), the optical depth to u is T(u) = D_f u + (D_b - D_f) u^2 / 2, the transparency
zeta = exp(-(D_f + D_b) / 2), and integration by parts gives the premultiplied colour

    C = integral_0^1 c(u) T'(u) exp(-T(u)) du = c_f (1 - Psi) + c_b (Psi - zeta),
    Psi(D_f, D_b) = integral_0^1 exp(-T(u)) du.

The table holds Phi = 1 - Psi = integral_0^1 (1 - exp(-T(u))) du, the piece's mean opacity, at
gamma = D / (1 + D) on [0, 1]^2 (so every depth from 0 to infinity has a place; ``phi_table``), so
that C = c_f Phi + c_b (alpha - Phi) with alpha = 1 - zeta keeps small opacities in float32
(1 - Psi would round to 0 below 6e-8); below PHI_SERIES_DEPTH the shader takes Phi from its series
(``phi_series``), where the table's bilinear read is relatively coarse. The shader
(shaders/tetrahedra/segment_partial.glsl) composites the pieces front to back, summing their
optical depths (the segment's alpha is 1 - exp(-sum), computed stably).

vgraph's TF is linear in opacity a, and its extinction tau = -ln(1 - a) / L is not linear where a
changes: ``knots`` adds points inside each of the TF's linear pieces, geometric in 1 - a, until
the linear interpolation of L tau is within ``KNOT_TOLERANCE`` of -ln(1 - a) (about 28 pieces
per factor e in 1 - a). Colour stays linear in the scalar on every piece, exactly. A piece where
a does not change needs no knots, however stiff the TF.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from vgraph.transfer_function import TransferFunction

PSI_SIZE = 512          # the table's nodes per axis (gamma at k / (PSI_SIZE - 1))
PHI_SERIES_DEPTH = 1.0 / 64.0  # below, in D_f and D_b, Phi from its series (relative error < 3e-5)
KNOT_TOLERANCE = 1e-4   # max error of L tau interpolated linearly between knots
MAX_KNOTS = 4096        # the knot textures' width; a TF needing more gets a coarser tolerance
MAX_OPACITY = 1.0 - 1e-7  # as vgraph.numerics.reference_tetra: finite extinction at a = 1
_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(16)
_GAUSS_NODES, _GAUSS_WEIGHTS = (_GAUSS_NODES + 1.0) / 2.0, _GAUSS_WEIGHTS / 2.0


def phi(depth_front, depth_back) -> np.ndarray:
    """Phi(D_f, D_b) = integral_0^1 (1 - exp(-T(u))) du = 1 - Psi (module docstring), float64,
    broadcast: the same quadrature with -expm1, exact in relative terms at small depths too."""
    return _quadrature(depth_front, depth_back, lambda t: -np.expm1(-t), tail=1.0)


def phi_series(depth_front, depth_back) -> np.ndarray:
    """Phi by its series for small depths: integral of T - T^2 / 2 (what the shader computes below
    PHI_SERIES_DEPTH; the next term is below D^3 / 24)."""
    d_f, d_b = (np.asarray(v, dtype=np.float64) for v in (depth_front, depth_back))
    first = d_f / 3.0 + d_b / 6.0
    slope = d_b - d_f
    second = d_f * d_f / 3.0 + d_f * slope / 4.0 + slope * slope / 20.0
    return first - 0.5 * second


def psi(depth_front, depth_back) -> np.ndarray:
    """Psi(D_f, D_b) = integral_0^1 exp(-T(u)) du (module docstring), float64, broadcast.

    Composite 16-point Gauss-Legendre on 16 intervals over [0, u_end], where T(u_end) >= 60 or
    u_end = 1: beyond, exp(-T) < 1e-26. T >= D_f u and T >= (D_b - D_f) u^2 / 2 when tau rises,
    T >= u (D_f + D_b) / 2 when it falls (T concave), which bound u_end."""
    return _quadrature(depth_front, depth_back, lambda t: np.exp(-t), tail=0.0)


def _quadrature(depth_front, depth_back, integrand, tail: float) -> np.ndarray:
    """integral_0^1 integrand(T(u)) du, with integrand(T) = ``tail`` past u_end (see psi)."""
    d_f, d_b = np.broadcast_arrays(np.asarray(depth_front, np.float64), np.asarray(depth_back, np.float64))
    half_slope = 0.5 * (d_b - d_f)
    with np.errstate(divide="ignore"):
        rising = np.minimum(60.0 / d_f, np.sqrt(60.0 / np.maximum(half_slope, 0.0)))
        falling = 60.0 / (0.5 * (d_f + d_b))
    u_end = np.minimum(1.0, np.where(half_slope >= 0.0, rising, falling))
    intervals = 16
    x = (np.arange(intervals)[:, None] + _GAUSS_NODES[None, :]).ravel() / intervals  # (256,)
    weights = np.tile(_GAUSS_WEIGHTS, intervals) / intervals
    u = u_end[..., None] * x
    t = d_f[..., None] * u + half_slope[..., None] * u * u
    return (integrand(t) @ weights) * u_end + tail * (1.0 - u_end)


@functools.cache
def phi_table(size: int = PSI_SIZE) -> np.ndarray:
    """(size, size) float32 Phi at gamma_f = i / (size - 1) (x, fastest) and gamma_b = j / (size - 1)
    (y), D = gamma / (1 - gamma); the last row and column (D infinite) are 1. Computed once per
    process (2 s; it depends on nothing) and read-only."""
    gamma = np.linspace(0.0, 1.0, size)
    with np.errstate(divide="ignore"):
        depth = np.where(gamma < 1.0, gamma / np.maximum(1.0 - gamma, 1e-300), np.inf)
    table = np.ones((size, size))
    finite = depth[:-1]
    for j, d_b in enumerate(finite):  # rows keep memory small (size x 256 nodes)
        table[j, :-1] = phi(finite, d_b)
    table = table.astype(np.float32)
    table.flags.writeable = False
    return table


def knots(tf: TransferFunction, tolerance: float = KNOT_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """(positions (n,), values (n, 4): rgb and L tau) of a normalised TF's pieces, with knots added
    where its extinction is not linear (module docstring). Two points at one position (a step) stay
    two knots at one position. Coarsens the tolerance (x 4 at a time) until n <= MAX_KNOTS."""
    table = np.asarray(tf.points, dtype=np.float64)
    table[:, 0] = np.maximum.accumulate(table[:, 0])
    table[:, 4] = np.clip(table[:, 4], 0.0, MAX_OPACITY)
    while True:
        positions, values = _refined(table, tolerance)
        if len(positions) <= MAX_KNOTS:
            return positions, values
        tolerance *= 4.0


def _refined(table: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    # A chord of -ln(b) over b in [b q, b] (geometric steps q) is off by about (1 - q)^2 / (8 q^2).
    step = math.log1p(math.sqrt(8.0 * tolerance))
    positions, values = [table[0, 0]], [table[0, 1:]]
    for start, end in zip(table[:-1], table[1:]):
        b0, b1 = 1.0 - start[4], 1.0 - end[4]
        count = max(1, math.ceil(abs(math.log(b1 / b0)) / step - 1e-9))
        if count > 1:
            b = b0 * (b1 / b0) ** (np.arange(1, count) / count)  # geometric in 1 - a
            fraction = (b0 - b) / (b0 - b1)
            positions.extend(start[0] + fraction * (end[0] - start[0]))
            values.extend(start[1:] + fraction[:, None] * (end[1:] - start[1:]))
        positions.append(end[0])
        values.append(end[1:])
    positions = np.asarray(positions)
    rgba = np.asarray(values)
    extinction = -np.log1p(-rgba[:, 3])
    return positions, np.concatenate([rgba[:, :3], extinction[:, None]], axis=1)


def segment_integral(s_front, s_back, length, tf: TransferFunction, reference_length: float,
                     tolerance: float = KNOT_TOLERANCE) -> np.ndarray:
    """Premultiplied RGBA of segments (1D arrays) as the shader integrates them, with Psi computed,
    not read from the table: the knots' error alone (tests)."""
    positions, values = knots(tf, tolerance)
    s_front, s_back, length = (np.asarray(v, dtype=np.float64) for v in (s_front, s_back, length))
    low, high = positions[0], positions[-1]
    s_front, s_back = np.clip(s_front, low, high), np.clip(s_back, low, high)
    ds = s_back - s_front
    # Every knot splits the segment where the scalar crosses it; pieces in front-to-back order.
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = np.where(ds[:, None] != 0.0, (positions[None, :] - s_front[:, None]) / ds[:, None], 2.0)
    cross = np.where((cross > 0.0) & (cross < 1.0), cross, 2.0)
    splits = np.sort(np.concatenate([np.zeros((len(ds), 1)), cross, np.ones((len(ds), 1))], axis=1), axis=1)
    splits = np.minimum(splits, 1.0)
    colour, total = np.zeros((len(ds), 3)), np.zeros(len(ds))
    for k in range(splits.shape[1] - 1):
        x0, x1 = splits[:, k], splits[:, k + 1]
        mid = s_front + ds * 0.5 * (x0 + x1)
        piece = np.clip(np.searchsorted(positions, mid, side="right") - 1, 0, len(positions) - 2)
        v0 = _on_piece(positions, values, piece, s_front + ds * x0)
        v1 = _on_piece(positions, values, piece, s_front + ds * x1)
        scale = (x1 - x0) * length / reference_length
        d_f, d_b = v0[:, 3] * scale, v1[:, 3] * scale
        depth = 0.5 * (d_f + d_b)
        mean_opacity = phi(d_f, d_b)
        piece = v0[:, :3] * mean_opacity[:, None] + v1[:, :3] * (-np.expm1(-depth) - mean_opacity)[:, None]
        colour += np.exp(-total)[:, None] * piece
        total += depth
    return np.concatenate([colour, -np.expm1(-total)[:, None]], axis=1)


def _on_piece(positions, values, piece, s):
    """Values at scalars s, linear on the given pieces (piece i: knots i and i + 1)."""
    lo, hi = positions[piece], positions[piece + 1]
    width = hi - lo
    f = np.where(width > 0.0, (s - lo) / np.where(width > 0.0, width, 1.0), 0.0)
    return values[piece] + (values[piece + 1] - values[piece]) * np.clip(f, 0.0, 1.0)[:, None]
