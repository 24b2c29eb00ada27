"""Chunked filtering: the volume filters on a store larger than its memory budget, chunk by chunk,
into a new store (docs/guide/volume-filters.md, "Stores larger than memory").

Conventions:
- A filter takes this path when its input is a BrickedVolume whose whole array exceeds its memory
  budget (``is_chunked``); a store that fits is read whole and filtered in memory, as before.
- The output is a new OME-Zarr store in vgraph's layout (levels, per-brick ranges), written slab
  by slab (one brick row of the output along z at a time) by vgraph convert's own writer
  (StoreWriter, write_levels: the same pyramid, the same atomic folder, the same progress bar), and
  handed on as a BrickedVolume of it with the input's memory budget, so the BrickedRayCaster draws
  it and the next filter takes it in chunks again. A store of labels or a mask carries the label
  flag as NGFF's "image-label" (StoreWriter), so whatever opens it later sees labels, and its
  coarser levels hold the most frequent label of each 2 x 2 x 2 group (pyramid.halve_labels), not
  a mean. Its bricks are the input's (vgraph convert's default, 64, where the input's are not even
  sizes).
- Filters with a kernel (VolumeSmooth) read each slab's slices and the kernel's reach more on
  each side (along z), cut them into tiles of whole bricks (at least TILE voxels along y and x)
  and run dask-image over them: its map_overlap gives each tile a halo of the kernel's reach
  (scipy's radius, ceil(truncate sigma) or half the median box), and the filter's own boundary
  mode (reflect) applies only where a tile's face is the volume's; the extra slices are cut away
  after. So the result equals the in-memory filter everywhere (tests/test_chunked_filters.py).
  Filters without a kernel (threshold, crop, resample) read each slab's voxels (and, resampling,
  the slices its interpolation reaches) straight from the store.
- Where: ``output`` when given (a folder ending in .zarr); otherwise the cache folder,
  $VGRAPH_CACHE, else $XDG_CACHE_HOME/vgraph, else ~/.cache/vgraph, as
  filtered/<input name>.<key>.zarr, the key a hash of the input (its path, its metadata's
  modification time, the grid and range it is given) and the filter's settings: the same filter
  on the same store opens the finished store instead of filtering again. Nothing cleans the cache.
- Memory: what a slab needs at once (``working_bytes``: its input slices with halos, their
  mixed-type copies, the tiles with halos, the output slab, the pyramid's pending slabs and
  halving) is checked against the input's budget before anything is read; above it is a
  MemoryBudgetError saying what to do.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from vgraph.bricks.pyramid import Level, level_count, next_level
from vgraph.bricks.store_writer import StoreWriter
from vgraph.bricks.volume import BrickedVolume, MemoryBudgetError
from vgraph.errors import OutputFileError, VGraphError
from vgraph.io.convert import HALVING_PIECE_VOXELS as HALVING_PIECE
from vgraph.io.convert import DEFAULT_BRICK, atomic_folder, checked_brick, is_zarr_store, write_levels
from vgraph.memory import format_bytes
from vgraph.value_range import range_of
from vgraph.volume import Volume
from vgraph.volume_filtering import finite_array, mixed_type, warn_nonfinite

CACHE_VARIABLE = "VGRAPH_CACHE"
KEY_VERSION = 2  # part of the cache key: bump when a filter's results change (2: the label flag)
# slices prefiltered beyond a slab's each side for the cubic B-spline (resample_plan): the
# coefficients' error from cutting the recursion there is about 0.268^16 = 7e-10 of the values
SPLINE_HALO = 16
TILE = 128  # voxels: the least rows and columns of a tile (tile_size); halos of 8 add 27 %


def is_chunked(volume: Volume) -> bool:
    """Whether a filter must take ``volume`` chunk by chunk: a store larger than its budget."""
    return getattr(volume, "bricks", None) is not None and not volume.fits_budget


@dataclass
class SlabPlan:
    """What a chunked filter writes: the output's grid and how to compute its slices [z0, z1)."""
    shape: tuple[int, int, int]                 # [z, y, x]
    dtype: np.dtype
    spacing: tuple[float, float, float]
    origin: tuple[float, float, float]
    declared_range: tuple[float, float]
    compute: Callable[[int, int], np.ndarray]   # (z0, z1) -> the output's slices z0 .. z1 - 1
    input_voxels: int                           # input voxels a slab of one brick row reads at once
    holds_labels: bool = False
    source: str = ""                            # the input store, for the progress bar
    temporary_bytes: int = 0                    # what the computation holds besides the input

    def slab(self, z0: int, z1: int) -> np.ndarray:  # what write_levels calls
        return self.compute(z0, z1)


def output_brick(volume: BrickedVolume) -> tuple[int, int, int]:
    try:
        return checked_brick(tuple(int(b) for b in volume.bricks.brick))
    except VGraphError:  # another tool's odd chunks: halving needs even bricks
        return (DEFAULT_BRICK,) * 3


def working_bytes(volume: BrickedVolume, plan: SlabPlan) -> int:
    """Bytes one slab needs at once: the input rows it reads in their type and mixed, the
    computation's temporaries, the output slab (twice: computed, and as write_levels holds it),
    the coarser levels' pending slabs and the float64 pieces the halving works in."""
    bz = output_brick(volume)[2]
    mixed = mixed_type(volume.dtype).itemsize
    voxels = bz * plan.shape[1] * plan.shape[2]
    halving = 2 * min(voxels, HALVING_PIECE) * 8
    return plan.input_voxels * (volume.dtype.itemsize + mixed) + plan.temporary_bytes \
        + 3 * voxels * plan.dtype.itemsize + halving


def check_working_memory(volume: BrickedVolume, plan: SlabPlan, who: str) -> None:
    needed, budget = working_bytes(volume, plan), volume.memory_budget_mb * 2**20
    if needed > budget:
        raise MemoryBudgetError(
            f"{who}: filtering {volume.source or 'the store'} chunk by chunk needs about "
            f"{format_bytes(needed)} at once (a row of bricks with its halo), more than its memory "
            f"budget of {volume.memory_budget_mb:g} MiB: raise the budget (VolumeSource.memory_budget) "
            f"or convert the store with smaller bricks (vgraph convert --brick)")


def filtered_store(volume: BrickedVolume, plan: SlabPlan, who: str, settings: dict,
                   output=None, progress: bool = True) -> BrickedVolume:
    """The store ``plan`` describes, written to ``output`` (else the cache folder, reused when a
    finished store with the same key is there), as a BrickedVolume with the input's budget."""
    check_working_memory(volume, plan, who)
    if output is None:
        path, stamped = cache_path(volume, settings)
        if stamped and is_zarr_store(path):
            return opened(path, volume)
    else:
        path = checked_output(Path(output))
    brick = output_brick(volume)
    levels = [Level(plan.shape, plan.spacing, plan.origin)]
    while len(levels) < level_count(plan.shape, brick):
        levels.append(next_level(levels[-1]))
    with atomic_folder(path) as folder:
        writer = StoreWriter(folder, levels, plan.dtype, brick, holds_labels=plan.holds_labels)
        stats = write_levels(plan, writer, brick, progress, False, doing=who)
        value_range = plan.declared_range or range_of(stats.data_range)
        writer.finish(value_range, plan.declared_range, stats.data_range, stats.nonfinite,
                      name=path.name, direction=volume.direction)
    return opened(path, volume)


def opened(path: Path, volume: BrickedVolume) -> BrickedVolume:
    # the label flag is the store's own ("image-label", StoreWriter): what opens it again sees it
    return BrickedVolume.open(path, memory_budget_mb=volume.memory_budget_mb)


def checked_output(path: Path) -> Path:
    if path.suffix.lower() != ".zarr":
        raise OutputFileError(path, "a filtered store's name must end in .zarr")
    if path.exists() and not is_zarr_store(path):
        raise OutputFileError(path, "exists and is not a zarr store: not replaced")
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


# --- the cache ----------------------------------------------------------------------------------
def cache_folder() -> Path:
    """$VGRAPH_CACHE, else $XDG_CACHE_HOME/vgraph, else ~/.cache/vgraph."""
    if os.environ.get(CACHE_VARIABLE):
        return Path(os.environ[CACHE_VARIABLE]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "vgraph"


def cache_path(volume: BrickedVolume, settings: dict) -> tuple[Path, bool]:
    """Where the cache keeps this filter's output of ``volume``, and whether the key holds the
    input's modification time (a store without a metadata file on disk is filtered every time)."""
    source = Path(volume.source or "store")
    metadata = source / "zarr.json"
    stamp = metadata.stat().st_mtime_ns if volume.source and metadata.is_file() else None
    # without a stamp the input may have changed unseen: a fresh name, never a stale reuse (and
    # never a store replaced under a volume still reading it)
    described = {"version": KEY_VERSION, "input": str(source.resolve()) if stamp else volume.source,
                 "stamp": stamp if stamp else uuid.uuid4().hex, "spacing": volume.spacing, "origin": volume.origin,
                 "range": volume.value_range, "direction": volume.direction, "filter": settings}
    key = hashlib.sha256(json.dumps(described, sort_keys=True, default=str).encode()).hexdigest()[:16]
    folder = cache_folder() / "filtered"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OutputFileError(folder, f"the cache folder for filtered stores cannot be made "
                                      f"({error.strerror or error}): set {CACHE_VARIABLE}") from None
    return folder / f"{source.stem or 'store'}.{key}.zarr", stamp is not None


# --- kernels: dask-image over level 0 -----------------------------------------------------------
def kernel_plan(volume: BrickedVolume, who: str, reach_zyx, dtype, kernel) -> SlabPlan:
    """A plan whose slabs are ``kernel`` (a dask-image filter of a dask array, [z, y, x]) of the
    store's level 0, NaN/Inf replaced first; ``reach_zyx``: the kernel's reach in voxels. The
    kernel filters values of ``dtype``: mixed_type, or the input's own (the median)."""
    import dask.array as da  # imported when used, as zarr: dask takes a second to import

    if volume.nonfinite_count:
        warn_nonfinite(volume, who)
    depth, rows_y, cols_x = volume.shape
    reach = int(reach_zyx[0])
    tile = (-1, *tile_size(volume))

    def compute(z0: int, z1: int) -> np.ndarray:
        # The slab's slices and ``reach`` more each side, read at once (zarr reads the bricks
        # concurrently), cut into tiles that dask-image filters with halos of the kernel's reach
        # along y and x; the extra slices are cut away after (the kernel reflects at their cut,
        # which is not the volume's face, unless it is).
        lo, hi = max(0, z0 - reach), min(depth, z1 + reach)
        values = kernel_values(volume.bricks.read(0, (lo, 0, 0), (hi, rows_y, cols_x)), volume, dtype)
        # named here: dask would otherwise hash the voxels to name the array
        tiles = da.from_array(values, chunks=tile, name=f"slab-{uuid.uuid4().hex}")
        return np.ascontiguousarray(kernel(tiles)[z0 - lo:z1 - lo].compute(scheduler="threads"))

    bz = output_brick(volume)[2]
    region = (bz + 2 * reach) * rows_y * cols_x
    # each tile is held with its halo and filtered: the region again, grown by the halos
    halos = math.prod((t + 2 * int(r)) / t for t, r in zip(tile[1:], reach_zyx[1:]))
    return SlabPlan(volume.shape, np.dtype(dtype), volume.spacing, volume.origin, volume.value_range,
                    compute, region, source=volume.source,
                    temporary_bytes=int(2 * halos * region * np.dtype(dtype).itemsize))


def tile_size(volume: BrickedVolume) -> tuple[int, int]:
    """Rows and columns of the tiles a slab is filtered in: whole bricks, at least TILE voxels
    (smaller tiles cost more in halos and in dask's tasks than they save)."""
    return tuple(b * math.ceil(TILE / b) for b in output_brick(volume)[1::-1])


def kernel_values(block: np.ndarray, volume: BrickedVolume, dtype) -> np.ndarray:
    """A block as the kernel takes it: in ``dtype``, NaN/Inf replaced (integers kept as they are
    when the kernel takes their own type: float32 would round large ones)."""
    if block.dtype.kind != "f" and block.dtype == dtype:
        return block
    return finite_array(block, volume).astype(dtype, copy=False)


def gaussian_plan(volume: BrickedVolume, who: str, sigma_zyx, truncate: float) -> SlabPlan:
    from dask_image.ndfilters import gaussian_filter
    reach = np.ceil(np.asarray(sigma_zyx) * truncate).astype(int)
    return kernel_plan(volume, who, reach, mixed_type(volume.dtype),
                       lambda values: gaussian_filter(values, sigma_zyx, truncate=truncate, mode="reflect"))


def median_plan(volume: BrickedVolume, who: str, size_zyx) -> SlabPlan:
    from dask_image.ndfilters import median_filter
    reach = np.asarray(size_zyx) // 2
    return kernel_plan(volume, who, reach, volume.dtype,
                       lambda values: median_filter(values, size=tuple(int(n) for n in size_zyx),
                                                    mode="reflect"))


# --- slabs without a kernel ---------------------------------------------------------------------
def voxel_plan(volume: BrickedVolume, low, high, dtype, per_slab, declared_range, **grid) -> SlabPlan:
    """A plan whose slab z0 .. z1 is ``per_slab`` of the input's voxels low + (z0 .. z1) along z and
    low .. high along y and x (index boxes (i, j, k), both ends kept): threshold and crop."""
    low, high = np.asarray(low, int), np.asarray(high, int)
    shape = tuple(int(n) for n in (high - low + 1)[::-1])

    def compute(z0: int, z1: int) -> np.ndarray:
        voxels = volume.bricks.read(0, (low[2] + z0, low[1], low[0]), (low[2] + z1, high[1] + 1, high[0] + 1))
        return np.ascontiguousarray(per_slab(voxels), dtype=dtype)

    return SlabPlan(shape, np.dtype(dtype), grid.get("spacing", volume.spacing),
                    grid.get("origin", volume.origin), declared_range, compute,
                    output_brick(volume)[2] * shape[1] * shape[2], holds_labels=grid.get("holds_labels", False),
                    source=volume.source)


def level_histogram(volume: BrickedVolume, bins: int):
    """Volume.histogram over every voxel of level 0, a brick row at a time (a BrickedVolume's own
    histogram is of a summary level)."""
    from types import SimpleNamespace
    z, y, x = volume.shape
    rows = output_brick(volume)[2]

    def slabs():
        for z0 in range(0, z, rows):
            yield volume.bricks.read(0, (z0, 0, 0), (min(z, z0 + rows), y, x)).reshape(-1)

    full = SimpleNamespace(_histograms={}, value_range=volume.value_range, _slabs=slabs,
                           normalized=volume.normalized)
    return Volume.histogram(full, bins)


def resample_plan(volume: BrickedVolume, who: str, shape_zyx, step_zyx, start_zyx, order: int,
                  spacing, origin) -> SlabPlan:
    """A plan whose slab is scipy.ndimage.affine_transform (order 0 or 1, mode nearest) of the
    input rows that the slab's samples reach: input index = start + output index * step. Order 3
    (the cubic B-spline) prefilters those rows and SPLINE_HALO more each side (the prefilter's
    recursion reaches along the whole z axis; its error at the cut falls as 0.268^distance), then
    samples the coefficients as VolumeResample does in memory (mode mirror)."""
    from scipy import ndimage
    depth, rows_y, cols_x = volume.shape
    step, start = np.asarray(step_zyx, float), np.asarray(start_zyx, float)
    halo = SPLINE_HALO if order == 3 else 0
    if order and volume.nonfinite_count:
        warn_nonfinite(volume, who)

    def compute(z0: int, z1: int) -> np.ndarray:
        first = start[0] + z0 * step[0]
        last = start[0] + (z1 - 1) * step[0]
        lo = max(0, int(math.floor(first)) - 1 - halo)
        hi = min(depth, int(math.ceil(last)) + 2 + halo)
        voxels = volume.bricks.read(0, (lo, 0, 0), (hi, rows_y, cols_x))
        if order:
            voxels = finite_array(voxels, volume)
        offset = start + np.array([z0 * step[0] - lo, 0.0, 0.0])
        if order == 3:
            from vgraph.numerics.bspline import prefilter
            coefficients = prefilter(voxels).astype(voxels.dtype, copy=False)
            return ndimage.affine_transform(coefficients, step, offset, output_shape=(z1 - z0, *shape_zyx[1:]),
                                            order=3, mode="mirror", prefilter=False)
        return ndimage.affine_transform(voxels, step, offset, output_shape=(z1 - z0, *shape_zyx[1:]),
                                        order=order, mode="nearest")

    bz = output_brick(volume)[2]
    rows = int(math.ceil(bz * step[0])) + 3 + 2 * halo
    dtype = volume.dtype if order == 0 else mixed_type(volume.dtype)
    # the prefilter works in float64 and hands float32 on
    spline = rows * rows_y * cols_x * 12 if order == 3 else 0
    return SlabPlan(tuple(int(n) for n in shape_zyx), np.dtype(dtype), spacing, origin,
                    volume.value_range, compute, rows * rows_y * cols_x,
                    holds_labels=volume.holds_labels and order == 0, source=volume.source,
                    temporary_bytes=spline)
