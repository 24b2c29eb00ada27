"""Empty-space skipping inside the brick atlas's bricks (the single-pass bricked ray caster, issue
#33): the ranges of every slot's blocks of BLOCK^3 core voxels and, per frame, which of them a ray
may jump over under the frame's transfer function or iso level.

Conventions:
- A slot's blocks are those of the brick cache's skipping (vgraph.bricks.cache.block_ranges_of):
  block k of a brick holds the samples at core coordinates [BLOCK k - 1/2, BLOCK (k + 1) - 1/2) and
  its range (normalised min and max) covers every voxel those samples filter. Every slot has
  ``per_slot`` blocks per axis (those of the largest brick); a smaller brick's blocks past its
  core, and every free slot, are unknown: never skipped.
- ``laid_out`` lays per-block values out as the atlas lays out its slots: slot s's blocks start
  at texel ``slot_index(s) * per_slot`` of one 3D texture (vgraph.bricks.block_radii's radii), so
  the shader finds a sample's block from its atlas texel alone (bricks/paged_sampling.glsl).
"""

from __future__ import annotations

import numpy as np

from vgraph.bricks.cache import BLOCK, HALO, TextureFormat, block_ranges_of
from vgraph.gl_context import release_quietly


class AtlasBlocks:
    """The block ranges of an atlas's slots and their flag texture (module docstring)."""

    def __init__(self, slot_shape, slot_grid, fmt: TextureFormat, gl: dict):
        self.per_slot = tuple(-(-(n - 2 * HALO) // BLOCK) for n in slot_shape)  # (x, y, z)
        self.slot_grid = tuple(slot_grid)
        self.format = fmt
        gx, gy, gz = self.slot_grid
        bx, by, bz = self.per_slot
        # [slot, bz, by, bx, (min, max)]; NaN: unknown (never skipped)
        self.ranges = np.full((gx * gy * gz, bz, by, bx, 2), np.nan, dtype=np.float32)
        self.gl = gl  # the atlas's GL objects: the flags go with them ("block_flags")

    def record(self, slot: int, data: np.ndarray) -> None:
        """The ranges of the brick now in ``slot`` (``data``: its voxels with the apron, in texture values)."""
        ranges = block_ranges_of(data, self.format)
        self.ranges[slot] = np.nan
        nz, ny, nx = ranges.shape[:3]
        self.ranges[slot, :nz, :ny, :nx] = ranges

    def skippable(self, skippable) -> np.ndarray:
        """bool [slot, bz, by, bx]: True where ``skippable(low, high)`` (bool arrays of the blocks'
        normalised ranges) says no sample in the block adds anything; unknown blocks False
        (vgraph.bricks.block_radii turns them into the shader's radii)."""
        low, high = self.ranges[..., 0], self.ranges[..., 1]
        known = np.isfinite(low) & np.isfinite(high)
        skip = np.zeros(low.shape, dtype=bool)
        skip[known] = skippable(low[known], high[known])
        return skip

    def maxima(self, whole: np.ndarray) -> np.ndarray:
        """float32 [z, y, x] laid out as the slots: each block's largest normalised intensity, 1e30
        where unknown or in a slot not drawn wholly from its brick (``whole``, bool per slot;
        vgraph.bricks.block_radii): a mip ray skips a block not above its running maximum, never these."""
        maxima = np.where(whole[:, None, None, None], self.ranges[..., 1], np.nan)
        return self.laid_out(np.nan_to_num(maxima, nan=1e30))

    def laid_out(self, values: np.ndarray) -> np.ndarray:
        """Per-block values [slot, bz, by, bx] as the atlas lays out its slots, float32 [z, y, x]."""
        gx, gy, gz = self.slot_grid
        bx, by, bz = self.per_slot
        grid = values.reshape(gz, gy, gx, bz, by, bx).transpose(0, 3, 1, 4, 2, 5)
        return np.ascontiguousarray(grid.reshape(gz * bz, gy * by, gx * bx), dtype=np.float32)

    def upload(self, ctx, flags: np.ndarray):
        """The flags as a 3D texture, R32F, or with ``flags`` [z, y, x, c] one of c float channels."""
        return kept_texture(self.gl, "block_flags", ctx, flags)


def kept_texture(gl: dict, name: str, ctx, values: np.ndarray):
    """``values`` float32 [z, y, x] (or [z, y, x, c]) written to the 3D texture ``gl[name]``, made
    anew only when its size, channels or context change (the atlas's per-frame grids)."""
    size, components = (values.shape[2], values.shape[1], values.shape[0]), (values.shape[3] if values.ndim == 4 else 1)
    texture = gl.get(name)
    if texture is None or texture.ctx is not ctx or texture.size != size or texture.components != components:
        release_quietly({name: gl.pop(name, None) or {}})
        texture = gl[name] = ctx.texture3d(size, components, dtype="f4")
    texture.write(np.ascontiguousarray(values, dtype=np.float32).tobytes())
    return texture
