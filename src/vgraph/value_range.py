"""The value-range rule volumes and meshes share (docs/explanations/conventions.md): a declared range must be
finite with low < high; otherwise the range is the data's finite min..max, and a constant (or
empty) data set still maps somewhere; values to and from the unit interval of a range."""

from __future__ import annotations

import numpy as np

from vgraph.errors import VGraphError


def checked_range(declared, what: str) -> tuple[float, float] | None:
    """``declared`` as (low, high) floats, or None; VGraphError naming ``what`` if impossible."""
    if declared is None:
        return None
    lo, hi = (float(v) for v in declared)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise VGraphError(f"{what}: value_range must be finite with low < high, got {declared}")
    return (lo, hi)


def range_of(extremes) -> tuple[float, float]:
    """The value range of data whose finite (min, max) are ``extremes`` (None: no finite value)."""
    if extremes is None:
        return (0.0, 1.0)
    lo, hi = (float(v) for v in extremes)
    if hi > lo:
        return (lo, hi)
    return (lo, lo + max(1.0, abs(lo) * 1e-6))  # a constant data set still maps somewhere


def blockwise_extremes(blocks) -> tuple | None:
    """(min, max) of the finite values of ``blocks`` (arrays, read one at a time: a mask of a big
    float volume would cost as much memory as the volume) as numpy scalars of their type (exact for
    64-bit integers), or None when no value is finite."""
    lo = hi = None
    for block in blocks:
        finite = block[np.isfinite(block)] if block.dtype.kind == "f" else block
        if finite.size:
            lo = finite.min() if lo is None else min(lo, finite.min())
            hi = finite.max() if hi is None else max(hi, finite.max())
    return None if lo is None else (lo, hi)


def to_unit(values, lo: float, hi: float):
    """(v - lo) / (hi - lo) in float64, also when hi - lo overflows (float64 data near 1.8e308):
    then computed on values divided by the larger magnitude."""
    with np.errstate(over="ignore"):
        span = hi - lo
    if np.isfinite(span):
        return (values - lo) / span
    scale = max(abs(lo), abs(hi))
    return (values / scale - lo / scale) / (hi / scale - lo / scale)


def from_unit(unit, lo: float, hi: float):
    """The inverse of to_unit: lo + unit (hi - lo), scaled the same way when hi - lo overflows."""
    with np.errstate(over="ignore"):
        span = hi - lo
    if np.isfinite(span):
        return lo + unit * span
    scale = max(abs(lo), abs(hi))
    return (lo / scale + unit * (hi / scale - lo / scale)) * scale
