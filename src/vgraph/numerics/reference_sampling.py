"""The CPU reference ray caster's reconstruction (vgraph.numerics.reference_raycast, rules 4 and 6):
normalised intensities trilinearly at world points, clamp-to-edge, through the inverse of the
volume's affine; gradients at those points by central differences of the reconstructed field, or
precomputed at the voxels (quantised to the 16-bit steps the GL gradient texture holds) and
interpolated. The light volume, the shadow and classification references and the GL gradient
volume use the same arithmetic.
"""

from __future__ import annotations

import numpy as np

from vgraph.volume import Volume

GRADIENT_STEPS = 32767  # 16-bit steps of a gradient component on each side of 0 (rule 6)


class VolumeSampler:
    """Trilinear reconstruction of normalised intensity at world points, clamp-to-edge (rule 4),
    through the inverse of the volume's affine; gradients in world units (rule 6)."""

    def __init__(self, volume: Volume):
        data = np.asarray(volume.data, dtype=np.float64)
        if volume.nonfinite_count:
            lo, hi = volume.value_range
            data = np.nan_to_num(data, nan=lo, posinf=hi, neginf=lo)
        self.flat = volume.normalized(data).ravel()  # [z, y, x] order: x fastest
        self.dims = np.array(volume.dims)
        self.origin = np.asarray(volume.origin, dtype=np.float64)
        self.spacing = np.asarray(volume.spacing, dtype=np.float64)
        # None on the world axes: exactly the arithmetic from before volumes had directions
        self.direction = None if volume.is_axis_aligned else np.asarray(volume.direction, dtype=np.float64)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """(M, 3) world points (x, y, z) -> (M,) normalised intensities."""
        return self.interpolate(self.flat, points)

    def interpolate(self, table: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Trilinear reconstruction (rule 4) of per-voxel values ``table`` ((N,) or (N, C) in
        [z, y, x] order, x fastest) at (M, 3) world points."""
        offset = points - self.origin
        if self.direction is not None:
            offset = offset @ self.direction  # along the index axes (the direction is orthonormal)
        u = np.clip(offset / self.spacing, 0.0, self.dims - 1)
        base = np.minimum(np.floor(u).astype(np.int64), np.maximum(self.dims - 2, 0))
        frac = u - base
        nxt = np.minimum(base + 1, self.dims - 1)
        nx, ny = self.dims[0], self.dims[1]
        x0, y0, z0 = base.T
        x1, y1, z1 = nxt.T
        fx, fy, fz = frac.T

        if table.ndim == 2:
            fx, fy, fz = fx[:, None], fy[:, None], fz[:, None]

        def fetch(x, y, z):
            return table[(z * ny + y) * nx + x]

        c00 = _lerp(fetch(x0, y0, z0), fetch(x1, y0, z0), fx)
        c10 = _lerp(fetch(x0, y1, z0), fetch(x1, y1, z0), fx)
        c01 = _lerp(fetch(x0, y0, z1), fetch(x1, y0, z1), fx)
        c11 = _lerp(fetch(x0, y1, z1), fetch(x1, y1, z1), fx)
        return _lerp(_lerp(c00, c10, fy), _lerp(c01, c11, fy), fz)

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """(M, 3) central differences one voxel away along each index axis, per world unit, in
        world components."""
        grad = np.empty_like(points)
        for axis in range(3):
            offset = np.zeros(3)
            offset[axis] = self.spacing[axis]
            if self.direction is not None:
                offset = self.direction @ offset  # one voxel along index axis ``axis``
            grad[:, axis] = (self(points + offset) - self(points - offset)) / (2.0 * self.spacing[axis])
        return self.to_world(grad)

    def to_world(self, vectors: np.ndarray) -> np.ndarray:
        """Vectors (M, 3) along the index axes -> world components (untouched on the world axes)."""
        return vectors if self.direction is None else vectors @ self.direction.T

    def voxel_gradient(self, points: np.ndarray, quantized: bool = True) -> np.ndarray:
        """(M, 3) precomputed voxel gradients interpolated trilinearly at world points (rule 6),
        per world unit, in world components; the voxel table (along the index axes) is built on
        first use."""
        key = "_voxel_gradients_quantized" if quantized else "_voxel_gradients"
        table = self.__dict__.get(key)
        if table is None:
            values = self.flat.reshape(self.dims[::-1])
            table = central_differences(np.pad(values, 1, mode="edge"), self.spacing)
            if quantized:
                scale = gradient_scale(table)
                table = dequantized(quantized_gradients(table, scale), scale)
            table = self.__dict__[key] = table.reshape(-1, 3)
        return self.to_world(self.interpolate(table, points))


def central_differences(padded: np.ndarray, spacing) -> np.ndarray:
    """(nz, ny, nx, 3) float64 central differences (x, y, z components, per world unit) of the
    interior of ``padded``, an [z, y, x] array of normalised intensities with one voxel more on
    every side (edge values at the volume's faces)."""
    padded = np.asarray(padded, dtype=np.float64)
    hx, hy, hz = (float(h) for h in spacing)
    out = np.empty((*(n - 2 for n in padded.shape), 3))
    out[..., 0] = (padded[1:-1, 1:-1, 2:] - padded[1:-1, 1:-1, :-2]) / (2.0 * hx)
    out[..., 1] = (padded[1:-1, 2:, 1:-1] - padded[1:-1, :-2, 1:-1]) / (2.0 * hy)
    out[..., 2] = (padded[2:, 1:-1, 1:-1] - padded[:-2, 1:-1, 1:-1]) / (2.0 * hz)
    return out


def gradient_scale(gradients: np.ndarray) -> np.ndarray:
    """Per component the largest |g| (1 where all are 0): the factor of the 16-bit steps."""
    largest = np.abs(gradients.reshape(-1, 3)).max(axis=0)
    return np.where(largest > 0.0, largest, 1.0)


def quantized_gradients(gradients: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """int16 steps round(g * (32767 / scale)): what the gradient texture stores (rgb, offset by 32767)."""
    steps = gradients * (GRADIENT_STEPS / scale)
    return np.rint(steps, out=steps).astype(np.int16)


def dequantized(texels: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The gradients int16 texels stand for, in float64."""
    return texels.astype(np.float64) * (scale / GRADIENT_STEPS)


def _lerp(a, b, t):
    return a + (b - a) * t
