"""A volume's values as the texels of a GL 3D texture (Volume.texture): the format by dtype (R16
normalised for 8 and 16 bit, uint8 as value * 257; R32F otherwise), normalised intensities where
float32 cannot carry the values, the 16-bit codes of Volume.at_precision's copy, and the upload
with its refusals (the GL's size limit, out of memory). The conventions: vgraph.volume's
docstring ("Textures hold the stored values ...", ``at_precision``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vgraph.errors import VGraphError
from vgraph.memory import OutOfMemoryError, format_bytes, out_of_memory
from vgraph.value_range import to_unit

if TYPE_CHECKING:  # the type of the argument; vgraph.volume imports this module
    from vgraph.volume import Volume

# Texture formats by dtype: (moderngl dtype, full-scale value of a normalised sample). uint8 is
# uploaded as R16 holding value * 257 (so a sample is still value / 255): llvmpipe, like many GPUs,
# filters 8-bit textures with 8-bit weights, errors up to 0.007, while R16 filters exactly enough
# and was measured no slower.
TEXTURE_FORMATS = {np.dtype(np.uint8): ("nu2", 255.0), np.dtype(np.uint16): ("nu2", 65535.0)}
# float32 keeps ~7 digits from 1.2e-38 to 3.4e38; values and ranges inside these bounds leave room
# for the shaders' arithmetic (scale, offset, differences) without overflow or subnormals.
FLOAT32_SAFE = 1e30
SLAB_VOXELS = 2**22  # working in float64 slab by slab bounds the temporary memory
SIXTEEN_BIT_CODES = 65535.0  # the largest code of a 16-bit copy: normalised intensity = q / 65535


def upload_texture(volume: Volume, ctx):
    """The volume's 3D texture on ``ctx`` (Volume.texture keeps it): refused by name past the GL's
    size limit, and out of memory as OutOfMemoryError (vgraph.memory)."""
    limit = ctx.info["GL_MAX_3D_TEXTURE_SIZE"]
    if max(volume.dims) > limit:
        where = f" from {volume.source}" if volume.source else ""
        raise VGraphError(f"volume{where}: {' x '.join(map(str, volume.dims))} voxels is larger than "
                          f"this GL's 3D texture limit of {limit} per axis (GL_MAX_3D_TEXTURE_SIZE); "
                          f"render it with the RayCaster or BrickedRayCaster (brick by brick), or "
                          f"crop or downsample it")
    gl_dtype, _ = TEXTURE_FORMATS.get(volume.data.dtype, ("f4", 1.0))
    texel_bytes = 2 if volume.texture_is_r16 else 4
    size = int(np.prod(volume.dims, dtype=np.int64)) * texel_bytes
    what = (f"making the {' x '.join(map(str, volume.dims))} {'R16' if texel_bytes == 2 else 'R32F'} "
            f"3D texture of the volume{f' from {volume.source}' if volume.source else ''}")
    try:
        values = np.ascontiguousarray(texels(volume, gl_dtype))
        ctx.error  # reading clears it: an older error is not this upload's
        texture = ctx.texture3d(volume.dims, 1, values, dtype=gl_dtype, alignment=1)
    except MemoryError as error:
        raise out_of_memory(error, what, size) from error
    if ctx.error == "GL_OUT_OF_MEMORY":  # llvmpipe holds at most 1 GiB per texture
        texture.release()
        raise OutOfMemoryError(f"out of memory: the GL could not allocate {format_bytes(size)} "
                               f"(GL_OUT_OF_MEMORY) while {what}: render it brick by brick "
                               f"(the BrickedRayCaster, or vgraph convert into a store: "
                               f"docs/guide/large-data.md), or crop or downsample it", size)
    texture.repeat_x = texture.repeat_y = texture.repeat_z = False
    return texture


def texels(volume: Volume, gl_dtype: str) -> np.ndarray:
    """The texture's values: R16 texels, normalised or clamped float32, or the data."""
    data = volume.data
    if volume.texture_is_r16:
        return r16_texels(data)
    if volume.texture_is_normalized:
        return normalized_float32(volume)
    if gl_dtype == "f4":
        data = data.astype(np.float32, copy=False)
        if volume.nonfinite_count:
            lo, hi = volume.value_range
            data = np.nan_to_num(data, nan=lo, posinf=hi, neginf=lo)
    return data


def normalized_float32(volume: Volume) -> np.ndarray:
    """(value - lo) / (hi - lo) in float64, stored as float32; NaN -> 0, +-Inf -> 1 / 0."""
    lo, hi = volume.value_range
    flat = volume.data.reshape(-1)
    out = np.empty(flat.size, dtype=np.float32)
    for start in range(0, flat.size, SLAB_VOXELS):
        slab = (flat[start:start + SLAB_VOXELS].astype(np.float64) - lo) / (hi - lo)
        out[start:start + SLAB_VOXELS] = np.nan_to_num(slab, nan=0.0, posinf=1.0, neginf=0.0)
    return out.reshape(volume.data.shape)


def r16_texels(data: np.ndarray) -> np.ndarray:
    """The R16 texels of 8- or 16-bit voxels: uint16 as they are, uint8 as value * 257 (the same
    normalised value, TEXTURE_FORMATS)."""
    if data.dtype == np.uint8:
        return data.astype(np.uint16) * np.uint16(257)
    return data


def sixteen_bit_codes(volume: Volume) -> np.ndarray:
    """The 16-bit codes of the volume's copy (Volume.at_precision): q = round(65535 * normalised
    intensity) as uint16, [z, y, x]; NaN -> 0, +-Inf -> the ends, values outside the range clamped."""
    lo, hi = volume.value_range
    flat = volume.data.reshape(-1)
    codes = np.empty(flat.size, dtype=np.uint16)
    # In float64 (float32 would put codes near a half off by one), slab by slab in one
    # reused buffer: fresh 8-byte temporaries of a whole volume cost more than the arithmetic.
    with np.errstate(over="ignore"):
        span = hi - lo  # inf for float64 data near +-1.8e308: then to_unit's scaled form
    buffer = np.empty(min(flat.size, SLAB_VOXELS), dtype=np.float64)
    for start in range(0, flat.size, SLAB_VOXELS):
        slab = flat[start:start + SLAB_VOXELS]
        unit = buffer[:slab.size]
        np.copyto(unit, slab, casting="unsafe")
        if np.isfinite(span):
            unit -= lo
            unit *= SIXTEEN_BIT_CODES / span
        else:
            unit[...] = to_unit(unit, lo, hi) * SIXTEEN_BIT_CODES
        if volume.nonfinite_count:  # as the full texture: NaN -> lo, +-Inf -> the ends
            np.nan_to_num(unit, copy=False, nan=0.0, posinf=SIXTEEN_BIT_CODES, neginf=0.0)
        np.clip(unit, 0.0, SIXTEEN_BIT_CODES, out=unit)
        codes[start:start + SLAB_VOXELS] = np.rint(unit, out=unit)
    return codes.reshape(volume.data.shape)
