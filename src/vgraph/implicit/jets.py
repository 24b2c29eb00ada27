"""Second-order jets: a scalar field's value, gradient and Hessian carried together through the
chain and product rules, so that every implicit function is written once and differentiated exactly
(forward-mode differentiation, no finite differences). Value-only jets (g = h = None) cost plain
numpy and broadcast over grids, which is what sampling uses.
"""

from __future__ import annotations

import math

import numpy as np

TINY = 1e-100  # below this a singular base (|p|^2, rho^2, ...) counts as "on the singular set"


def outer(a, b):
    return a[..., :, None] * b[..., None, :]


class Jet:
    """A scalar field's value v, gradient g (..., 3) and Hessian h (..., 3, 3) at many points.
    g and h are None for value-only evaluation (sampling), which then costs plain numpy."""

    __slots__ = ("v", "g", "h")

    def __init__(self, v, g=None, h=None):
        self.v, self.g, self.h = v, g, h

    def __add__(self, other):
        if not isinstance(other, Jet):
            return Jet(self.v + other, self.g, self.h)
        if self.g is None:
            return Jet(self.v + other.v)
        return Jet(self.v + other.v, self.g + other.g, self.h + other.h)

    __radd__ = __add__

    def __neg__(self):
        return self * -1.0

    def __sub__(self, other):
        return self + (-other)

    def __rsub__(self, other):
        return (-self) + other

    def __mul__(self, other):
        if not isinstance(other, Jet):
            return Jet(self.v * other, None if self.g is None else self.g * other,
                        None if self.h is None else self.h * other)
        v = self.v * other.v
        if self.g is None:
            return Jet(v)
        a, b = self.v[..., None], other.v[..., None]
        g = self.g * b + other.g * a
        h = (self.h * b[..., None] + other.h * a[..., None]
             + outer(self.g, other.g) + outer(other.g, self.g))
        return Jet(v, g, h)

    __rmul__ = __mul__

    def __truediv__(self, constant: float):
        return self * (1.0 / constant)

    def apply(self, f0, f1, f2):
        """phi(self) for a scalar phi given with its first and second derivatives."""
        v = f0(self.v)
        if self.g is None:
            return Jet(v)
        d1, d2 = f1(self.v), f2(self.v)
        return Jet(v, d1[..., None] * self.g,
                    d2[..., None, None] * outer(self.g, self.g) + d1[..., None, None] * self.h)


def power(a: Jet, e: float) -> Jet:
    """a**e for a >= 0 (e.g. sqrt); derivatives are 0 where a is below TINY (the singular set)."""
    def deriv(coef, k):
        def d(t):
            safe = t > TINY
            return np.where(safe, coef * np.power(np.where(safe, t, 1.0), e - k), 0.0)
        return d
    return a.apply(lambda t: np.power(np.maximum(t, 0.0), e), deriv(e, 1), deriv(e * (e - 1), 2))


def sqrt(a: Jet) -> Jet:
    return power(a, 0.5)


def int_power(a: Jet, n: int) -> Jet:
    return a.apply(lambda t: t**n, lambda t: n * t ** (n - 1), lambda t: n * (n - 1) * t ** (n - 2))


def sin(a: Jet) -> Jet:
    return a.apply(np.sin, np.cos, lambda t: -np.sin(t))


def cos(a: Jet) -> Jet:
    return a.apply(np.cos, lambda t: -np.sin(t), lambda t: -np.cos(t))


def sech2(t):
    """1/cosh^2 via exp of a non-positive argument: no overflow for any finite t."""
    e = np.exp(-2.0 * np.abs(t))
    return 4.0 * e / (1.0 + e) ** 2


def tanh(a: Jet) -> Jet:
    return a.apply(np.tanh, sech2, lambda t: -2.0 * np.tanh(t) * sech2(t))


def cos_half_pi_sqrt(w: Jet) -> Jet:
    """cos(pi/2 sqrt(w)) as a smooth function of w >= 0, so Marschner-Lobb is exact on its axis."""
    q = math.pi**2 / 8.0

    def t_of(w_):
        return 0.5 * math.pi * np.sqrt(np.maximum(w_, 0.0))

    def d2(w_):
        t = t_of(w_)
        ts = np.where(t < 0.05, 1.0, t)  # (t cos t - sin t) / t^3 cancels badly near 0: series
        direct = (ts * np.cos(ts) - np.sin(ts)) / ts**3
        series = -1.0 / 3.0 + t**2 / 30.0 - t**4 / 840.0
        return -q * q * np.where(t < 0.05, series, direct)
    return w.apply(lambda w_: np.cos(t_of(w_)), lambda w_: -q * np.sinc(t_of(w_) / math.pi), d2)


def smooth_max(a: Jet, b: Jet, k: float) -> Jet:
    """k log(exp(a/k) + exp(b/k)), evaluated with the larger argument factored out."""
    top = np.maximum(a.v, b.v)
    ea, eb = np.exp((a.v - top) / k), np.exp((b.v - top) / k)
    total = ea + eb
    v = top + k * np.log(total)
    if a.g is None:
        return Jet(v)
    wa, wb = ea / total, eb / total
    dg = a.g - b.g
    g = wa[..., None] * a.g + wb[..., None] * b.g
    h = (wa[..., None, None] * a.h + wb[..., None, None] * b.h
         + (wa * wb / k)[..., None, None] * outer(dg, dg))
    return Jet(v, g, h)


def coordinate_jets(p: np.ndarray) -> tuple[Jet, Jet, Jet]:
    n = p.shape[0]
    zero_h = np.broadcast_to(np.zeros((3, 3)), (n, 3, 3))
    return tuple(Jet(p[:, i], np.broadcast_to(np.eye(3)[i], (n, 3)), zero_h) for i in range(3))


def as_points(p) -> np.ndarray:
    pts = np.asarray(p, dtype=np.float64)
    if pts.ndim == 1:
        pts = pts[None, :]
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3) in (x, y, z) order, got {np.shape(p)}")
    return pts
