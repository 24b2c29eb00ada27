"""Classification by value and gradient magnitude in the CPU reference ray caster (rule 5 of
vgraph.numerics.reference_raycast, extended): gradient opacity (vgraph.gradient_opacity) and 2D
transfer functions (vgraph.transfer_function_2d; Kniss et al. 2002). The GL ray casters copy this
model (vgraph.gl.raycasting.gradient_classification); tests compare the two images.

Model, for a sample at world point p with normalised intensity v (rule 4):

1. Gradient: the precomputed voxel gradients of rule 6 (central differences of the normalised
   voxel values, per world unit, quantised to 16-bit steps as the GL texture stores them),
   reconstructed trilinearly at p: G(p). Whether or not the sample is shaded.
2. Gradient fraction: ``f = |G(p)| / G_max``, clamped to [0, 1], with G_max the largest magnitude
   of the unquantised voxel gradients (0 everywhere when G_max is 0: a constant volume).
3. Colour: with a 2D TF, its premultiplied ``lut()`` (LUT_SIZE^2 entries) looked up bilinearly at
   ``x = v * (n - 1)``, ``y = f * (n - 1)``, both clamped to the table (= a GL 2D texture with
   linear filtering and clamp-to-edge at ``(x + 0.5) / n``), rgb then divided by the alpha read
   (0 where it is 0); otherwise the 1D TF of rule 5.
4. Gradient opacity: alpha times the curve's ``lut()`` (1024 entries) at f, linear between
   entries, clamped. Colour is unchanged.

Then opacity correction, shading and compositing as before (rules 6-7). Only dvr classifies so;
MIP classifies a maximum, which has no gradient.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from vgraph.gradient_opacity import GradientOpacity
from vgraph.numerics.reference_raycast import lookup
from vgraph.numerics.reference_sampling import central_differences
from vgraph.transfer_function_2d import TransferFunction2D

Classify = Callable[[np.ndarray, np.ndarray], np.ndarray]  # (points (M, 3), values (M,)) -> (M, 4)


@dataclass(frozen=True)
class GradientClassification:
    """What replaces or modifies the 1D TF's classification (module docstring); both None: none."""

    gradient_opacity: GradientOpacity | None = None
    transfer_function_2d: TransferFunction2D | None = None

    @property
    def is_off(self) -> bool:
        return self.gradient_opacity is None and self.transfer_function_2d is None

    def classifier(self, sampler, lut: np.ndarray) -> Classify:
        """classify(points, values) -> RGBA for ``sampler`` (a reference_raycast.VolumeSampler)
        and the 1D TF's ``lut``."""
        inverse = _inverse(largest_gradient_magnitude(sampler))
        factors = None if self.gradient_opacity is None else self.gradient_opacity.lut().astype(np.float64)
        table = None if self.transfer_function_2d is None else self.transfer_function_2d.lut().astype(np.float64)

        def classify(points: np.ndarray, values: np.ndarray) -> np.ndarray:
            fraction = np.linalg.norm(sampler.voxel_gradient(points), axis=1) * inverse  # rules 1-2
            rgba = lookup(lut, values) if table is None else unpremultiplied(bilinear(table, values, fraction))
            if factors is not None:
                rgba[:, 3] *= lookup(factors[:, None], fraction)[:, 0]
            return rgba
        return classify


def largest_gradient_magnitude(sampler) -> float:
    """G_max of rule 2: the largest |central difference| at the voxels (unquantised)."""
    values = sampler.flat.reshape(sampler.dims[::-1])
    table = central_differences(np.pad(values, 1, mode="edge"), sampler.spacing)
    return float(np.sqrt((table ** 2).sum(axis=-1)).max())


def _inverse(largest: float) -> float:
    return 1.0 / largest if largest > 0.0 else 0.0


def unpremultiplied(rgba: np.ndarray) -> np.ndarray:
    """(M, 4) premultiplied RGBA -> straight RGBA; rgb 0 where alpha is 0."""
    alpha = rgba[:, 3:4]
    rgba[:, :3] = np.divide(rgba[:, :3], alpha, out=np.zeros_like(rgba[:, :3]), where=alpha > 0.0)
    return rgba


def bilinear(table: np.ndarray, values: np.ndarray, fraction: np.ndarray) -> np.ndarray:
    """RGBA from an (n, n, 4) [gradient, value] table, bilinear, clamped (rule 3)."""
    n = table.shape[0]
    x = np.clip(values, 0.0, 1.0) * (n - 1)
    y = np.clip(fraction, 0.0, 1.0) * (n - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), n - 2)
    y0 = np.minimum(np.floor(y).astype(np.int64), n - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    low = table[y0, x0] * (1.0 - fx) + table[y0, x0 + 1] * fx
    high = table[y0 + 1, x0] * (1.0 - fx) + table[y0 + 1, x0 + 1] * fx
    return low * (1.0 - fy) + high * fy
