"""The ray integral across one tetrahedron and its pre-integrated table (Roettger, Kraus & Ertl
2000; Kraus, Qiao & Ebert 2004).

The optical model is the ray caster's in the continuum (emission-absorption with associated
colours): a resolved, normalised transfer function gives colour c(s) and opacity a(s) per sample
at rate 1, i.e. over the length L = mesh.opacity_length, hence the extinction
tau(s) = -ln(1 - a(s)) / L. Inside a tetrahedron the scalar is linear, so along a ray it goes
linearly from s_f (front) to s_b (back) over the thickness l, and

    alpha = 1 - exp(-l * mean_tau),   mean_tau = (1 / (s_b - s_f)) * integral_{s_f}^{s_b} tau(s) ds,
    C     = integral_0^l c(s(t)) tau(s(t)) exp(-integral_0^t tau) dt          (premultiplied).

mean_tau does not depend on l, and C / alpha depends on l only through the optical depth
D = l * mean_tau (the extinction profile along the segment is l times a fixed shape). So the table
is indexed by (s_f, s_b, alpha): channel a holds L * mean_tau (the same in every slice), rgb holds
C / alpha at alpha = k / (T - 1); the shader reads L * mean_tau, computes alpha from l, and reads
the colour at (s_f, s_b, alpha). For a constant TF the table is exact (rgb = c, a = -ln(1 - a)).

``segment_integral`` computes C and alpha for given segments (a composite of ``steps`` equal
pieces with the TF at their midpoints, i.e. the ray caster at step l / steps), vectorised.
"""

from __future__ import annotations

import numpy as np

from vgraph.transfer_function import TransferFunction

TABLE_SIZE = 128     # N: scalar nodes per axis (s_f, s_b at k / (N - 1))
ALPHA_SLICES = 32    # T: opacity nodes (alpha at k / (T - 1))
TABLE_STEPS = 64     # pieces of a segment when building the table
MAX_OPTICAL_DEPTH = 40.0  # -ln(1 - a) of a = 1 (an opaque TF entry); exp(-40) = 4e-18


def extinction(tf: TransferFunction, s) -> tuple[np.ndarray, np.ndarray]:
    """(rgb, L * tau) of the normalised TF at scalars s: colour and optical depth per L."""
    rgba = tf(s)
    depth = -np.log(np.clip(1.0 - rgba[..., 3], np.exp(-MAX_OPTICAL_DEPTH), 1.0))
    return rgba[..., :3], depth


def segment_integral(s_front, s_back, length, tf: TransferFunction, reference_length: float,
                     steps: int = 256) -> np.ndarray:
    """Premultiplied RGBA of segments (broadcast shapes) from s_front to s_back over ``length``
    world units, by ``steps`` pieces (exact for a TF constant on the segment)."""
    s_front, s_back, length = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64)
                                                    for v in (s_front, s_back, length)))
    x = (np.arange(steps) + 0.5) / steps
    s = s_front[..., None] + (s_back - s_front)[..., None] * x
    rgb, depth = extinction(tf, s)
    piece = depth * (length / (reference_length * steps))[..., None]
    return _composite(rgb, piece)


def _composite(rgb: np.ndarray, piece_depth: np.ndarray) -> np.ndarray:
    """Front-to-back composite of pieces (..., K) with colours (..., K, 3) and optical depths."""
    alpha = -np.expm1(-piece_depth)
    before = np.exp(-(np.cumsum(piece_depth, axis=-1) - piece_depth))  # transparency in front
    weight = alpha * before
    color = np.einsum("...k,...kc->...c", weight, rgb)
    total = -np.expm1(-piece_depth.sum(axis=-1))
    return np.concatenate([color, total[..., None]], axis=-1)


def mean_depth(tf: TransferFunction, s_front, s_back, fine: int = 16384) -> np.ndarray:
    """L * mean_tau over [s_front, s_back] (the TF's tau at s where they are equal), from the
    cumulative trapezoid integral of L * tau on ``fine`` intervals of [0, 1]."""
    grid = np.linspace(0.0, 1.0, fine + 1)
    _, depth = extinction(tf, grid)
    cumulative = np.concatenate([[0.0], np.cumsum((depth[1:] + depth[:-1]) * 0.5 / fine)])
    s_front, s_back = np.broadcast_arrays(np.asarray(s_front, dtype=np.float64),
                                          np.asarray(s_back, dtype=np.float64))
    width = s_back - s_front
    integral = np.interp(s_back, grid, cumulative) - np.interp(s_front, grid, cumulative)
    same = np.abs(width) < 1e-9
    return np.where(same, extinction(tf, s_front)[1], integral / np.where(same, 1.0, width))


def table(tf: TransferFunction, size: int = TABLE_SIZE, slices: int = ALPHA_SLICES,
          steps: int = TABLE_STEPS) -> np.ndarray:
    """The (slices, size, size, 4) float32 table [alpha, s_b, s_f] (x = s_f varies fastest, as a
    3D texture wants it) for a resolved, normalised TF; see the module docstring."""
    nodes = np.linspace(0.0, 1.0, size)
    s_front, s_back = nodes[None, :], nodes[:, None]  # [s_b, s_f]
    x = (np.arange(steps) + 0.5) / steps
    s = s_front[..., None] + (s_back - s_front)[..., None] * x  # [s_b, s_f, k]
    rgb, depth = extinction(tf, s)
    mean = mean_depth(tf, *np.broadcast_arrays(s_front, s_back))
    shape = depth / np.maximum(depth.sum(axis=-1, keepdims=True), 1e-300)  # profile, sums to 1
    flat = depth.sum(axis=-1) <= 0.0  # no extinction anywhere: any colour (alpha stays 0)
    shape[flat] = 1.0 / steps
    out = np.empty((slices, size, size, 4), dtype=np.float32)
    for k, alpha in enumerate(np.linspace(0.0, 1.0, slices)):
        # alpha 0 is the limit of thin segments (extinction-weighted mean colour); alpha 1 that
        # of opaque ones, approached with the largest optical depth.
        total = min(-np.log1p(-min(max(alpha, 1e-6), 1.0 - 1e-16)), MAX_OPTICAL_DEPTH)
        rgba = _composite(rgb, shape * total)
        out[k, ..., :3] = rgba[..., :3] / np.maximum(rgba[..., 3:4], 1e-300)
        out[k, ..., 3] = mean
    return out
