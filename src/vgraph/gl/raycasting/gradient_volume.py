"""Precomputed gradients (RayCaster ``derivatives = precomputed``): one texture fetch per shaded
sample instead of six.

The gradient is computed once per volume at the voxels, central differences of the normalised
intensities with the volume's edge values repeated beyond its faces (what the texture's
clamp-to-edge gives the on-the-fly central mode), in normalised intensity per world unit; the
texture is sampled trilinearly. Rule 6 of vgraph.numerics.reference_raycast states the model and
why, inside the box, it equals the on-the-fly central difference up to the 16-bit steps.

Storage: an RGBA16 (unsigned normalised) 3D texture, 8 bytes a voxel: rgb = 32767 + round(g_k *
32767 / s_k) with s_k = max |g_k| over the volume per axis (``scale``, a uniform); the shader
decodes texel * 65535 / 32767 - 1 (interpolation is linear, so decoding after the filter is the
same). Where the volume's own texture is R16 (8- and 16-bit data, 16-bit copies), a holds that
texture's texel (``holds_values``): a shaded sample then reads its value and its gradient in one
fetch (shaders/raycasting/gradients.glsl, ``shading_texel``), and a four-channel fetch costs
llvmpipe far less than a one-channel plus a four-channel one (docs/reports/performance.md). Otherwise a is 0
and the value comes from the volume's texture.

The numpy part works slab by slab (``SLAB_VOXELS``), twice (the scale, then the texels), so a
512^3 volume needs neither a float64 copy nor a host copy of the texture; the scale and the texture
are derived data (vgraph.derived), kept per volume (and context) and released with either.
"""

from __future__ import annotations

import sys

import moderngl
import numpy as np

from vgraph import derived
from vgraph.errors import VGraphError
from vgraph.numerics.reference_sampling import GRADIENT_STEPS, gradient_scale
# The voxel gradients live beside the CPU models, so the light volume classifies with the same ones.
from vgraph.numerics.voxel_gradients import padded_slab as _padded_slab
from vgraph.progress import steps
from vgraph.volume import Volume
from vgraph.volume_texture import r16_texels

SLAB_VOXELS = 2**22  # voxels per numpy slab: ~100 MB of float64 temporaries
PROGRESS_VOXELS = 32 * 2**20  # show a progress bar (stderr) above this many voxels

_INNER = slice(1, -1)
# Per axis x, y, z: (the neighbour ahead, the one behind) of every voxel of a padded slab.
_NEIGHBOURS = (((_INNER, _INNER, slice(2, None)), (_INNER, _INNER, slice(None, -2))),
               ((_INNER, slice(2, None), _INNER), (_INNER, slice(None, -2), _INNER)),
               ((slice(2, None), _INNER, _INNER), (slice(None, -2), _INNER, _INNER)))
TEXTURE = "gradient texture"  # the kinds of derived data (vgraph.derived) this module makes
SCALE = "gradient scale"


def gradient_texture(ctx: moderngl.Context, volume: Volume) -> tuple[moderngl.Texture3D, np.ndarray]:
    """The volume's gradient texture on ``ctx`` and its per-axis scale (float64 (3,), x y z):
    gradient = texel.rgb * scale. Built on first use, then cached (module docstring)."""
    scale = derived.value(volume, SCALE, lambda: _scale(volume))
    return derived.value(volume, TEXTURE, lambda: _upload(ctx, volume, scale), ctx=ctx), scale


def is_cached(volume: Volume) -> bool:
    """Whether a gradient texture was built for ``volume`` (on any context)."""
    return derived.holds(volume, TEXTURE)


def _slabs(volume: Volume, what: str):
    nz, ny, nx = volume.data.shape
    thickness = max(1, SLAB_VOXELS // (nx * ny))
    starts = range(0, nz, thickness)
    show = volume.data.size > PROGRESS_VOXELS  # on stderr; the GUI hears every one
    for z0 in steps(starts, f"gradients ({what})", show=show, unit="slab", file=sys.stderr):
        yield z0, min(z0 + thickness, nz)


def _scale(volume: Volume) -> np.ndarray:
    # The largest difference divided by 2h is the largest gradient exactly (division by a positive
    # number is monotone under rounding), without the slab's (..., 3) gradient array.
    largest = np.zeros(3)
    for z0, z1 in _slabs(volume, "range"):
        padded = _padded_slab(volume, z0, z1)
        for k, (ahead, behind) in enumerate(_NEIGHBOURS):
            difference = padded[ahead] - padded[behind]
            largest[k] = max(largest[k], difference.max() / (2.0 * volume.spacing[k]),
                             -(difference.min() / (2.0 * volume.spacing[k])))
    return gradient_scale(largest[None, :])


def holds_values(volume: Volume) -> bool:
    """Whether the gradient texture's alpha holds the volume texture's texels (module docstring)."""
    return volume.texture_is_r16


def _upload(ctx: moderngl.Context, volume: Volume, scale: np.ndarray) -> moderngl.Texture3D:
    nx, ny, nz = volume.dims
    limit = ctx.info["GL_MAX_3D_TEXTURE_SIZE"]
    if max(volume.dims) > limit:
        raise VGraphError(f"gradient volume: {nx} x {ny} x {nz} voxels exceed this GL's 3D texture "
                          f"limit of {limit} per axis")
    texture = ctx.texture3d((nx, ny, nz), 4, None, dtype="nu2", alignment=1)
    texture.repeat_x = texture.repeat_y = texture.repeat_z = False
    texels = None
    for z0, z1 in _slabs(volume, "texture"):
        if texels is None or texels.shape[0] != z1 - z0:
            texels = np.zeros((z1 - z0, ny, nx, 4), dtype=np.uint16)
        padded = _padded_slab(volume, z0, z1)
        # Component by component, the operations of central_differences and quantized_gradients
        # (same steps, tested) without their (..., 3) float64 arrays.
        for k, (ahead, behind) in enumerate(_NEIGHBOURS):
            q = (padded[ahead] - padded[behind]) / (2.0 * float(volume.spacing[k]))
            q *= GRADIENT_STEPS / scale[k]
            texels[..., k] = np.rint(q, out=q) + GRADIENT_STEPS
        if holds_values(volume):
            texels[..., 3] = r16_texels(volume.data[z0:z1])
        texture.write(texels, viewport=(0, 0, z0, nx, ny, z1 - z0), alignment=1)
    return texture
