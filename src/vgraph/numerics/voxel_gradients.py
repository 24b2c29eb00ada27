"""Voxel gradients of a volume, slab by slab: central differences of the normalised intensities
with the edge values repeated beyond the faces (rule 6 of vgraph.numerics.reference_raycast), in
normalised intensity per world unit. The GL gradient volume (vgraph.gl.raycasting.gradient_volume)
stores them; the light volume (vgraph.numerics.light_volume) classifies with their gradient
fractions, so its shadows fall where the ray casters' gradient classification draws.
"""

from __future__ import annotations

import numpy as np

from vgraph.numerics.reference_sampling import central_differences, dequantized, gradient_scale, quantized_gradients
from vgraph.volume import Volume

SLAB_VOXELS = 2**22  # voxels per numpy slab: ~100 MB of float64 temporaries


def slab_gradients(volume: Volume, z0: int, z1: int, rows=None) -> np.ndarray:
    """float64 (z1 - z0, ny, nx, 3) voxel gradients of slices [z0, z1), identical to those of the
    whole volume (the slab reads one slice more on each side where there is one). ``rows(a, b)``
    reads stored slices [a, b) (a store's level 0 brick by brick); by default ``volume.data``."""
    return central_differences(padded_slab(volume, z0, z1, rows), volume.spacing)


def padded_slab(volume: Volume, z0: int, z1: int, rows=None) -> np.ndarray:
    """Normalised float64 slices [z0 - 1, z1 + 1) and one voxel more around x and y: neighbours
    where the volume has them, edge values beyond its faces (``rows`` as in slab_gradients)."""
    nz = volume.shape[0] if rows is not None else volume.data.shape[0]
    below, above = max(z0 - 1, 0), min(z1 + 1, nz)
    values = rows(below, above) if rows is not None else volume.data[below:above]
    if volume.nonfinite_count:  # as the volume texture stores them (vgraph.volume)
        lo, hi = volume.value_range
        values = np.nan_to_num(values.astype(np.float64), nan=lo, posinf=hi, neginf=lo)
    values = volume.normalized(values)
    pad_z = (1 if below == z0 else 0, 1 if above == z1 else 0)  # edge values only at the faces
    return np.pad(values, (pad_z, (1, 1), (1, 1)), mode="edge")


def slab_ranges(volume: Volume):
    """(z0, z1) of the slabs of SLAB_VOXELS voxels at most (one slice at least)."""
    nz, ny, nx = volume.data.shape
    thickness = max(1, SLAB_VOXELS // (nx * ny))
    return [(z0, min(z0 + thickness, nz)) for z0 in range(0, nz, thickness)]


def gradient_fractions(volume: Volume) -> np.ndarray:
    """float32 [z, y, x] gradient fraction of every voxel as the ray casters classify it (rules
    1-2 of vgraph.numerics.reference_classification): the magnitude of its gradient quantised to
    the GL texture's 16-bit steps, divided by the largest unquantised magnitude (the value
    vgraph.gl.raycasting.gradient_classification.largest_magnitude binds), clamped to 1; 0
    everywhere in a constant volume. Two passes over the slabs: the scale and the largest, then
    the fractions."""
    components, largest = np.zeros(3), 0.0
    for z0, z1 in slab_ranges(volume):
        gradients = slab_gradients(volume, z0, z1)
        components = np.maximum(components, np.abs(gradients.reshape(-1, 3)).max(axis=0))
        largest = max(largest, float(np.sqrt((gradients ** 2).sum(axis=-1)).max()))
    scale = gradient_scale(components[None, :])
    inverse = 1.0 / largest if largest > 0.0 else 0.0
    out = np.empty(volume.data.shape, dtype=np.float32)
    for z0, z1 in slab_ranges(volume):
        steps = dequantized(quantized_gradients(slab_gradients(volume, z0, z1), scale), scale)
        out[z0:z1] = np.minimum(np.sqrt((steps ** 2).sum(axis=-1)) * inverse, 1.0)
    return out
