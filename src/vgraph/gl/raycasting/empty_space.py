"""Empty-space skipping (docs/explanations/conventions.md) and what a ray caster should show.

Skipping works on blocks of ``block``^3 voxels: block b (per axis) holds the samples whose voxel
coordinate u = t * dims - 0.5 has floor(u) in [b * block, (b + 1) * block); its range is the min and
max normalised intensity over voxels [b * block - 1, (b + 1) * block + 1], which covers every voxel
such a sample's trilinear (or nearest) reconstruction can touch, with one voxel to spare for
rounding. A block is occupied when some intensity in its range can contribute (TF opacity > 0, or
reaching the iso level); empty blocks store their chessboard distance to the nearest occupied block,
so a ray can jump over whole empty regions (skip_radii).

Block sizes: ``BLOCK`` = 4 where rays jump over empty regions (dvr, first_hit, iso, the curvature
and label ray casters); ``WALK_BLOCK`` = 8 where a ray visits every block on its way (MIP's walk
over the block maxima) and for the ray-bounds boxes. Jumps cost little since march.glsl makes them
in a loop of their own, so smaller blocks pay: they fit the visible parts tighter (bonsai 18 %
occupied instead of 24 %); a walk pays per block (docs/reports/performance.md has the measurements). The
8^3 ranges are the 4^3 ones reduced in pairs, exactly (the windows of two neighbouring blocks
cover that of their union).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from types import MappingProxyType

import moderngl
import numpy as np
from scipy import ndimage

from vgraph import derived
from vgraph.volume import Volume

BLOCK = 4  # voxels per empty-space block along each axis, where rays jump (module docstring)
WALK_BLOCK = 2 * BLOCK  # where rays walk block by block, and for the ray-bounds boxes
MIN_EMPTY_FRACTION = 0.1  # below this share of empty blocks, skipping costs more than it saves
LEVEL_EPSILON = 1e-6  # normalised: block ranges this close to the level count as crossing it
BLOCK_RANGES = "block ranges"  # the kind of derived data (vgraph.derived) of block_ranges


def block_ranges(volume: Volume, block: int = BLOCK) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) normalised intensity per block of ``block`` (BLOCK or WALK_BLOCK) voxels, float32
    arrays [bz, by, bx] (module docstring), computed once per volume (vgraph.derived). Non-finite
    voxels count as the texture upload stores them."""
    return derived.value(volume, BLOCK_RANGES, lambda: _block_ranges(volume))[block]


def _block_ranges(volume: Volume) -> dict:
    """{BLOCK: (min, max), WALK_BLOCK: (min, max)} of block_ranges."""
    data = volume.data
    if volume.nonfinite_count:
        lo, hi = volume.value_range
        data = np.nan_to_num(data, nan=lo, posinf=hi, neginf=lo)  # a copy, same dtype
    low, high = data, data
    for axis in range(3):
        low = window_reduced(low, axis, np.minimum)
        high = window_reduced(high, axis, np.maximum)
    fine = (volume.normalized(low).astype(np.float32), volume.normalized(high).astype(np.float32))
    return {BLOCK: fine, WALK_BLOCK: (pairs_reduced(fine[0], np.minimum), pairs_reduced(fine[1], np.maximum))}


def window_reduced(array: np.ndarray, axis: int, reducer) -> np.ndarray:
    """Reduce ``axis`` to BLOCK blocks: block b covers indices [b*BLOCK - 1, (b+1)*BLOCK + 1], clamped
    (clamp-to-edge adds nothing new). Works on views, so a large volume is not copied."""
    moved = np.moveaxis(array, axis, 0)
    n = moved.shape[0]
    blocks = -(-n // BLOCK)
    parts = [reducer.reduce(moved[max(b * BLOCK - 1, 0):min((b + 1) * BLOCK + 2, n)], axis=0)
             for b in range(blocks)]
    return np.moveaxis(np.stack(parts), 0, axis)


def pairs_reduced(blocks: np.ndarray, reducer) -> np.ndarray:
    """Blocks twice as large: ``reducer`` over pairs along each axis (a last odd block alone)."""
    for axis in range(3):
        blocks = reducer.reduceat(blocks, np.arange(0, blocks.shape[axis], 2), axis=axis)
    return blocks


def occupied_blocks(block_min: np.ndarray, block_max: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """True for blocks where some intensity in the block's range has LUT opacity > 0 (the LUT entry
    range is widened by one entry on each side for the texture filter's rounding)."""
    last = len(alpha) - 1
    lo = np.clip(np.floor(np.clip(block_min, 0.0, 1.0) * last).astype(np.int64) - 1, 0, last)
    hi = np.clip(np.ceil(np.clip(block_max, 0.0, 1.0) * last).astype(np.int64) + 1, 0, last)
    count = np.concatenate([[0], np.cumsum(alpha > 0.0)])
    return count[hi + 1] - count[lo] > 0


def skip_radii(occupied: np.ndarray) -> np.ndarray:
    """float32 per block: 0 where occupied, else k >= 1 such that all blocks within Chebyshev
    distance k - 1 are empty (k = the chessboard distance to the nearest occupied block; the
    whole grid's size where none is occupied)."""
    if occupied.all():
        return np.zeros(occupied.shape, dtype=np.float32)
    if not occupied.any():
        return np.full(occupied.shape, float(max(occupied.shape)), dtype=np.float32)
    return ndimage.distance_transform_cdt(~occupied, metric="chessboard").astype(np.float32)


def radii_if_worthwhile(occupied: np.ndarray) -> np.ndarray | None:
    """skip_radii, or None when under MIN_EMPTY_FRACTION of the blocks are empty: every sample would
    pay for the block look-up and hardly any would be saved."""
    return skip_radii(occupied) if 1.0 - occupied.mean() >= MIN_EMPTY_FRACTION else None


class SkipBlocks:
    """The R32F texture of per-block values for SKIP_EMPTY_SPACE (shaders/raycasting/empty_space.glsl),
    rebuilt only when the volume or what the values depend on changes. For B-spline coefficients
    the block ranges bound the spline too: it is a convex combination of its 4^3 coefficients
    (weights >= 0, summing to 1), which the ranges' one-voxel margin just covers; where float
    rounding puts a sample in the neighbouring block, the coefficient outside the margin has
    weight ~1e-19."""

    def __init__(self):
        self._texture = None
        self._key = None
        self._values_exist = False
        self.key = None  # what the current values were built from (RayBounds rebuilds with it)
        self.values = None  # the current block values (None: skipping does not pay)

    def texture(self, ctx: moderngl.Context, volume: Volume, depends, values, block: int = BLOCK):
        """``values(block_min, block_max)`` -> float array per block of ``block`` voxels (skip
        radii, or the maxima for MIP), or None when skipping does not pay; ``depends`` is what
        ``values`` depends on. Returns the texture, or None."""
        key = (ctx, volume, depends, block)
        if self._key is None or not all(a is b or a == b for a, b in zip(key, self._key)):
            self._key = self.key = key
            block_values = self.values = values(*block_ranges(volume, block))
            self._values_exist = block_values is not None
            if self._values_exist:
                self._upload(ctx, block_values)
        return self._texture if self._values_exist else None

    def _upload(self, ctx: moderngl.Context, values: np.ndarray) -> None:
        size = values.shape[::-1]
        if self._texture is None or self._texture.ctx is not ctx or self._texture.size != size:
            if self._texture is not None and self._texture.ctx is ctx:
                self._texture.release()
            self._texture = ctx.texture3d(size, 1, dtype="f4")
        self._texture.write(np.ascontiguousarray(values, dtype=np.float32).tobytes())


def block_grid_uniforms(volume: Volume, block: int = BLOCK) -> Mapping[str, object]:
    """Texture coordinates -> block coordinates q = t * scale + offset (floor(q) = block index)."""
    return _block_grid(volume.dims, block)


@functools.lru_cache(maxsize=16)
def _block_grid(dims: tuple[int, int, int], block: int) -> Mapping[str, object]:
    # Asked every frame; read-only, since the processors of a frame share it.
    scale = np.array(dims, dtype=np.float64) / block
    return MappingProxyType({"block_scale": tuple(scale), "block_offset": (-0.5 / block,) * 3,
                             "block_count": tuple(int(-(-d // block)) for d in dims)})


def level_occupancy(level: float):
    """Blocks that may hold a crossing of ``level``: their range of normalised values straddles it
    (min < level + eps and max >= level - eps). Blocks wholly on one side cannot, and neighbouring
    blocks share a voxel margin, so a region of such blocks never hides a crossing."""
    return lambda low, high: (low < level + LEVEL_EPSILON) & (high >= level - LEVEL_EPSILON)


# --- what a ray caster should show -----------------------------------------------------------------
def visible_under(volume: Volume, transfer_function) -> str | None:
    """Which share of the finite voxels the transfer function gives any opacity, in words; None if
    none. Voxel by voxel, classified as the shaders classify (the LUT interpolated linearly,
    clamped at its ends): a histogram bin that merely touches an opaque entry claimed a constant
    volume at intensity 0 "100 % visible" under a TF that starts rising just after 0."""
    alpha = transfer_function.for_volume(volume).lut()[:, 3].astype(np.float64)
    entries = np.linspace(0.0, 1.0, len(alpha))
    share = volume.share_of_voxels(lambda intensity: np.interp(intensity, entries, alpha) > 0.0)
    if share == 0.0:
        return None
    return f"{share:.0%} of the voxels are visible under the transfer function" if share >= 0.005 \
        else "under 1% of the voxels are visible under the transfer function"


def crossed_by(volume: Volume, level: float) -> str | None:
    """Whether the volume's values cross the normalised ``level`` (an iso-surface exists)."""
    low, high = block_ranges(volume)
    return f"the volume's values cross the iso level {level:g}" if low.min() < level < high.max() else None

