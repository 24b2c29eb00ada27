"""Principal curvatures of iso-surfaces from gradient and Hessian (Kindlmann et al. 2003).

Conventions
- Inputs are in world units: gradient (..., 3) as (df/dx, df/dy, df/dz), Hessian (..., 3, 3) in the
  same (x, y, z) order. Curvatures come out in 1/world-unit.
- Sign (docs/explanations/conventions.md): the object's interior has HIGHER values than its exterior (CT convention). The
  outward normal is n = -g/|g|, and a sphere of radius r has k1 = k2 = +1/r; a cylinder of radius R
  has k1 = 1/R, k2 = 0; a saddle has k1 > 0 > k2. Flip the field (f -> -f) for data whose interior
  is darker.
- Formulas (Cabral 2010 sec. 3.6): P = I - n n^T, G = -P H P / |g| (the geometry tensor; the seed's
  GLSL listing drops the minus sign, its text keeps it), T = trace G, F = |G|_Frobenius,
  k1,2 = (T +- sqrt(2F^2 - T^2)) / 2 with k1 >= k2, K = k1 k2 (Gaussian), H = (k1 + k2) / 2 (mean).
  The Hessian is symmetrised first, (H + H^T) / 2, so finite-difference Hessians are fine.
- Curvedness C = sqrt((k1^2 + k2^2) / 2) (Koenderink). Shape index
  S = (2/pi) * atan2(k1 + k2, k1 - k2), in [-1, 1]: +1 convex umbilic (sphere seen from outside),
  +0.5 ridge (cylinder), 0 symmetric saddle, -0.5 valley, -1 concave umbilic (cup); 0 where the
  surface is flat (k1 = k2 = 0). With our sign convention "convex" means bulging outwards.
- Guards, so that no NaN or Inf ever comes out: where |g| <= min_gradient (no iso-surface direction),
  where any input is NaN/Inf, or where the result would overflow, everything is 0 and
  ``defined`` is False. Rounding can make 2F^2 - T^2 slightly negative at umbilics; it is clamped
  to 0 (that point stays defined).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DEFAULT_MIN_GRADIENT = 1e-12  # |grad f| at or below this (in data units per world unit): undefined


@dataclass(frozen=True)
class Curvature:
    """Curvature measures, each of the input's leading shape; see the module docstring."""

    k1: np.ndarray
    k2: np.ndarray
    gaussian: np.ndarray
    mean: np.ndarray
    curvedness: np.ndarray
    shape_index: np.ndarray
    defined: np.ndarray  # bool

    @property
    def K(self) -> np.ndarray:  # noqa: N802 - the usual symbol
        return self.gaussian

    @property
    def H(self) -> np.ndarray:  # noqa: N802 - the usual symbol
        return self.mean

    def as_dict(self) -> dict[str, np.ndarray]:
        return {"k1": self.k1, "k2": self.k2, "K": self.gaussian, "H": self.mean,
                "curvedness": self.curvedness, "shape_index": self.shape_index,
                "defined": self.defined}


def kindlmann(gradient, hessian, min_gradient: float = DEFAULT_MIN_GRADIENT) -> Curvature:
    """Kindlmann curvature (k1, k2, K, H, curvedness, shape index) from gradient and Hessian.

    gradient: (..., 3); hessian: (..., 3, 3); both in world units, (x, y, z) order. Vectorised
    over the leading dimensions; computed in float64.
    """
    g = np.asarray(gradient, dtype=np.float64)
    h = np.asarray(hessian, dtype=np.float64)
    if g.shape[-1:] != (3,) or h.shape[-2:] != (3, 3) or g.shape[:-1] != h.shape[:-2]:
        raise ValueError(f"kindlmann: need gradient (..., 3) and hessian (..., 3, 3) with the same "
                         f"leading shape, got {g.shape} and {h.shape}")
    shape = g.shape[:-1]
    g = g.reshape(-1, 3)
    h = h.reshape(-1, 3, 3)
    finite = np.all(np.isfinite(g), axis=1) & np.all(np.isfinite(h), axis=(1, 2))
    # Replace unusable inputs by harmless ones so the vector maths stays warning-free; they are
    # masked out at the end.
    g = np.where(finite[:, None], g, 0.0)
    h = np.where(finite[:, None, None], h, 0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        length = np.sqrt(np.einsum("ni,ni->n", g, g))
    defined = finite & np.isfinite(length) & (length > min_gradient)
    safe_length = np.where(defined, length, 1.0)

    normal = -g / safe_length[:, None]  # outward when the interior is brighter
    projector = np.eye(3) - normal[:, :, None] * normal[:, None, :]
    symmetric = 0.5 * (h + np.swapaxes(h, 1, 2))
    with np.errstate(over="ignore", invalid="ignore"):
        geometry = -(projector @ symmetric @ projector) / safe_length[:, None, None]
        trace = np.trace(geometry, axis1=1, axis2=2)
        frobenius_sq = np.einsum("nij,nij->n", geometry, geometry)
        root = np.sqrt(np.maximum(2.0 * frobenius_sq - trace * trace, 0.0))  # umbilic guard
        k1 = 0.5 * (trace + root)
        k2 = 0.5 * (trace - root)
        gaussian = k1 * k2
        mean = 0.5 * (k1 + k2)
        curvedness = np.sqrt(0.5 * (k1 * k1 + k2 * k2))
    results = [k1, k2, gaussian, mean, curvedness]
    defined &= np.logical_and.reduce([np.isfinite(r) for r in results])
    k1, k2, gaussian, mean, curvedness = (np.where(defined, r, 0.0).reshape(shape) for r in results)
    return Curvature(k1, k2, gaussian, mean, curvedness, shape_index(k1, k2), defined.reshape(shape))


def shape_index(k1, k2) -> np.ndarray:
    """Shape index (2/pi) atan2(k1 + k2, k1 - k2) for k1 >= k2 (see the module docstring).

    atan2(0, 0) = 0, so flat points get 0; umbilics give exactly +1 or -1.
    """
    k1 = np.asarray(k1, dtype=np.float64)
    k2 = np.asarray(k2, dtype=np.float64)
    with np.errstate(over="ignore"):  # huge finite curvatures: atan2 of an infinity is still finite
        return (2.0 / np.pi) * np.arctan2(k1 + k2, k1 - k2)
