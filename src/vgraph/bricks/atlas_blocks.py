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
- ``fine_maxima``: each slot's largest texture value per block of FINE^3 core voxels (the
  RayCaster's skipping blocks, over the same windows: a sample in block k filters voxels
  FINE k - 1 .. FINE (k + 1)), in the bricks' texture values; iso's frame-wide grid of a complete
  frame (vgraph.bricks.walk_grids.iso_grid) reads them. 0.3 ms a brick of 64^3 besides the ranges.
- ``of_slot``: what else is made from a slot's ranges (the walk grids' reduction of its brick
  within each cell it is drawn in, vgraph.bricks.walk_grids, and its blocks' distances within its
  cell under the frame's rule, vgraph.bricks.block_radii, under keys naming the brick), kept
  until another brick is recorded in the slot: a refining frame reduces only the bricks it newly
  draws somewhere, and finds only their distances. (A brick's ranges are those of its voxels, so
  what is kept for it is right for as long as it is in the slot; dropping it on a record bounds
  what is kept.)
"""

from __future__ import annotations

import numpy as np

from vgraph.bricks.cache import BLOCK, HALO, TextureFormat, block_ranges_of
from vgraph.gl_context import release_quietly

FINE = 4  # voxels per block edge of fine_maxima (the RayCaster's empty_space.BLOCK)


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
        self.fine_per_slot = tuple(-(-(n - 2 * HALO) // FINE) for n in slot_shape)  # (x, y, z)
        self.fine_maxima = None  # [slot, fz, fy, fx] in the bricks' texture dtype, made at the first record
        self.derived: dict = {}  # slot -> {key: value} (of_slot)

    def record(self, slot: int, data: np.ndarray) -> None:
        """The ranges of the brick now in ``slot`` (``data``: its voxels with the apron, in texture values)."""
        ranges = block_ranges_of(data, self.format)
        self.derived.pop(slot, None)  # (made from the brick that was there)
        self.ranges[slot] = np.nan
        nz, ny, nx = ranges.shape[:3]
        self.ranges[slot, :nz, :ny, :nx] = ranges
        maxima = fine_maxima_of(data)
        unknown = np.iinfo(maxima.dtype).max if maxima.dtype.kind in "ui" else np.inf  # never below a level
        if self.fine_maxima is None or self.fine_maxima.dtype != maxima.dtype:
            fx, fy, fz = self.fine_per_slot
            self.fine_maxima = np.full((len(self.ranges), fz, fy, fx), unknown, dtype=maxima.dtype)
        nz, ny, nx = maxima.shape
        self.fine_maxima[slot] = unknown  # (a smaller brick's blocks past its core)
        self.fine_maxima[slot, :nz, :ny, :nx] = maxima

    def of_slot(self, slot: int) -> dict:
        """The values made from the ranges of the brick now in ``slot`` (module docstring): a dict
        (key -> value) the maker fills, emptied when another brick is recorded there."""
        return self.derived.setdefault(slot, {})

    def normalised(self, values: np.ndarray) -> np.ndarray:
        """Texture values (fine_maxima's) as normalised intensities, float64 (as block_ranges_of)."""
        full = 65535.0 if self.format.gl_dtype == "nu2" else 1.0
        return np.asarray(values, dtype=np.float64) / full * self.format.scale + self.format.offset

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


def fine_maxima_of(data: np.ndarray, block: int = FINE) -> np.ndarray:
    """The largest texture value per block of ``block`` core voxels of a brick (``data``: with its
    halo), over the voxels its samples filter, block k - 1 .. block (k + 1) (block_ranges_of's
    windows, its maxima exactly); vectorised per axis (block_ranges_of's loop over the blocks took
    3 ms a brick of 64^3 at blocks of 4, this 0.3)."""
    reduced = data
    for axis in range(3):
        count = -(-(data.shape[axis] - 2 * HALO) // block)
        moved = np.moveaxis(reduced, axis, 0)
        need = block * count + 2 * HALO + 2
        if moved.shape[0] < need:  # a last block past the data: its window is clamped (edge values add nothing)
            moved = np.pad(moved, [(0, need - moved.shape[0])] + [(0, 0)] * (moved.ndim - 1), mode="edge")
        core = moved[HALO:HALO + block * count].reshape((count, block) + moved.shape[1:]).max(axis=1)
        margins = np.maximum(moved[HALO - 1:HALO - 1 + block * count:block],
                             moved[HALO + block:HALO + block + block * count:block])
        reduced = np.moveaxis(np.maximum(core, margins), 0, axis)
    return np.ascontiguousarray(reduced)


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
