"""Shadow rays: the transmittance of a directional light at any points, marched on the CPU; the
reference the light volume (vgraph.numerics.light_volume) and the ray casters' shadows are
measured against.

Model: from each point a ray towards the light (``light_direction``, world) through the volume
reconstructed as the CPU ray caster does (rule 4 of vgraph.numerics.reference_raycast: trilinear,
clamp-to-edge), classified per sample (rule 5: the LUT's alpha at the interpolated intensity; the
light volume classifies the voxels instead), extinction ``sigma = -ln(1 - a) / min(spacing)`` (a at
most 1 - 1e-6, as the light volume), integrated by the trapezoid rule with ``step`` world units
(default min(spacing) / 4) until the ray leaves the box of voxel centres; the last step is cut at
the box. ``T = exp(-integral)``. Points outside the box get T = 1.

``shadowed(light_volume)`` is the other shadow term of the CPU ray caster's ``shadow`` argument:
the light volume sampled trilinearly at the samples, as the GL ray caster samples it.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from vgraph.numerics.light_volume import MAX_ALPHA, index_light
from vgraph.numerics.reference_raycast import VolumeSampler, lookup
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

Shadow = Callable[[np.ndarray], np.ndarray]  # (M, 3) world points -> (M,) transmittance


def shadow_rays(volume: Volume, transfer_function: TransferFunction, light_direction,
                step: float | None = None) -> Shadow:
    """The transmittance at world points by marching shadow rays (module docstring)."""
    sampler = VolumeSampler(volume)
    lut_alpha = transfer_function.for_volume(volume).lut().astype(np.float64)[:, 3:4]
    h = float(min(volume.spacing))
    step = h / 4.0 if step is None else float(step)
    light_index = index_light(volume, light_direction)  # along the index axes
    light_world = light_index if volume.is_axis_aligned else np.asarray(volume.direction) @ light_index
    spacing = np.asarray(volume.spacing, dtype=np.float64)
    top = (np.asarray(volume.dims) - 1) * spacing  # the box in index-axis world units

    def sigma(points):
        alpha = lookup(lut_alpha, sampler(points))[:, 0]
        return -np.log1p(-np.minimum(alpha, MAX_ALPHA)) / h

    def transmittance(points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        local = volume.world_to_voxel(points) * spacing  # index axes, world units, box [0, top]
        reach = _distance_to_box(local, light_index, top)
        depth = np.zeros(len(points))
        inside = np.flatnonzero(reach > 0.0)
        previous = sigma(points[inside]) if inside.size else np.zeros(0)
        travelled = np.zeros(inside.size)
        while inside.size:
            length = np.minimum(step, reach[inside] - travelled)
            travelled += length
            here = sigma(points[inside] + travelled[:, None] * light_world)
            depth[inside] += 0.5 * length * (previous + here)
            going = travelled < reach[inside] - 1e-12
            inside, previous, travelled = inside[going], here[going], travelled[going]
        return np.exp(-depth)

    return transmittance


def _distance_to_box(local: np.ndarray, light: np.ndarray, top: np.ndarray) -> np.ndarray:
    """World distance from each point (index axes, world units) along ``light`` to where it leaves
    the box [0, top]; 0 for points outside the box."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ahead = np.where(light > 0, (top - local) / light, np.where(light < 0, -local / light, np.inf))
    reach = ahead.min(axis=1)
    outside = np.any((local < -1e-9 * (1 + top)) | (local > top * (1 + 1e-9) + 1e-9), axis=1)
    return np.where(outside, 0.0, np.maximum(reach, 0.0))


def shadowed(light_volume: Volume) -> Shadow:
    """The transmittance of a light volume (16-bit codes of T) interpolated trilinearly at world
    points, clamp-to-edge (what the GL ray caster's light-volume texture gives)."""
    sampler = VolumeSampler(light_volume)
    return sampler
