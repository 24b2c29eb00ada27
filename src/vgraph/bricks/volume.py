"""BrickedVolume: a Volume whose voxels stay in a BrickSource (an OME-Zarr store on disk) until a
consumer asks for the whole array (docs/guide/large-data.md).

It flows through Volume ports like any volume. Its grid, value range and source come from the
pyramid's metadata without reading voxels; ``bricks`` is the pyramid, for renderers that read
bricks as they need them (the BrickedRayCaster). ``data`` reads level 0 whole on first use, but
only if it fits ``memory_budget_mb``; otherwise it raises MemoryBudgetError naming the size and
what to do, so processors that need the whole array (CubicSplineProcessor, writers, RayCaster's
texture) work for small stores and refuse large ones clearly.

Statistics that a plain Volume computes from its array come from the pyramid instead:
- ``finite_extremes`` (and so ``value_range``): recorded by vgraph convert at full resolution;
  for other stores those of the finest level small enough to read whole, else of a bounded
  sample of the coarsest level (BrickStore.data_range);
- ``percentiles`` and ``histogram``: from the finest level of at most SUMMARY_VOXELS voxels in
  SUMMARY_BRICKS bricks (the full array once it is loaded; a sample of that size of the coarsest
  level when even that is larger, pyramid.sample_blocks); the 0th and 100th percentiles are the
  full-resolution extremes;
- ``nonfinite_count``: recorded by vgraph convert; otherwise counted on that summary (a lower
  bound), or on the array once loaded.
"""

from __future__ import annotations

import math
from functools import cached_property
from types import SimpleNamespace

import numpy as np

from vgraph.bricks.pyramid import Level, brick_grid, sample_blocks
from vgraph.errors import VGraphError
from vgraph.memory import check_memory, format_bytes
from vgraph.rank_table import RankTable
from vgraph.value_range import blockwise_extremes, checked_range, range_of
from vgraph.volume import Volume
from vgraph.volume_grid import IDENTITY, check_box, checked_direction, checked_vec3
from vgraph.volume_texture import FLOAT32_SAFE, TEXTURE_FORMATS

DEFAULT_MEMORY_BUDGET_MB = 1024
SUMMARY_VOXELS = 2**22  # voxels read for percentiles and histograms: 4 M, a second at most
SUMMARY_BRICKS = 2**10  # ... in at most 1024 bricks (each is a chunk file to read)


class MemoryBudgetError(VGraphError):
    """The whole array of a BrickedVolume was asked for but exceeds its memory budget."""


class BrickedVolume(Volume):
    """A Volume over ``bricks`` (a BrickSource). ``spacing``, ``origin`` and ``declared_range``
    override the pyramid's (every level is regridded alike); ``direction`` (default: the
    source's, else the identity) turns every level alike."""

    def __init__(self, bricks, *, memory_budget_mb: float = DEFAULT_MEMORY_BUDGET_MB, spacing=None,
                 origin=None, declared_range=None, source: str | None = None,
                 time_steps: int | None = None, direction=None):
        self.source = source if source is not None else getattr(bricks, "source", "")
        where = f" from {self.source}" if self.source else ""
        first = bricks.levels[0]
        self.spacing = checked_vec3(first.spacing if spacing is None else spacing, "spacing", where, positive=True)
        self.origin = checked_vec3(first.origin if origin is None else origin, "origin", where)
        if (self.spacing, self.origin) != (first.spacing, first.origin):
            bricks = RegriddedSource(bricks, self.spacing, self.origin)
        self._bricks = bricks
        self.direction = checked_direction(getattr(bricks, "direction", IDENTITY) if direction is None
                                           else direction, where)
        self.holds_labels = bool(getattr(bricks, "holds_labels", False))
        check_box(self.dims, self.spacing, self.origin, where, self.direction)
        declared = declared_range if declared_range is not None else getattr(bricks, "declared_range", None)
        self.declared_range = checked_range(declared, f"volume{where}")
        self.is_spline_coefficients = False
        self.time_steps = int(time_steps or getattr(bricks, "time_steps", 1))
        self.memory_budget_mb = _checked_budget(memory_budget_mb, where)
        self._data = None

    @classmethod
    def open(cls, path, time_step: int = 0, channel: int = 0,
             memory_budget_mb: float = DEFAULT_MEMORY_BUDGET_MB) -> "BrickedVolume":
        """The OME-Zarr image at ``path`` (metadata only; no voxel is read)."""
        from vgraph.bricks.store import BrickStore  # imported when used: zarr takes 0.2 s
        store = BrickStore(path, time=time_step, channel=channel)
        return cls(store, memory_budget_mb=memory_budget_mb)

    # --- from the pyramid's metadata --------------------------------------------------------------
    @property
    def bricks(self):
        return self._bricks

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(self._bricks.dtype)

    @property
    def shape(self) -> tuple[int, int, int]:
        """[z, y, x] voxels at full resolution."""
        return tuple(self._bricks.levels[0].shape)

    @property
    def dims(self) -> tuple[int, int, int]:
        z, y, x = self.shape
        return (x, y, z)

    @property
    def nbytes(self) -> int:
        """Bytes of the whole array at full resolution."""
        return math.prod(self.shape) * self.dtype.itemsize

    @property
    def value_range(self) -> tuple[float, float]:
        if self.declared_range is not None:
            return self.declared_range
        extremes = self.finite_extremes
        return range_of(extremes) if extremes is not None else tuple(self._bricks.value_range)

    @property
    def finite_extremes(self):
        recorded = getattr(self._bricks, "data_range", None)
        if recorded is None and self._data is None:
            return None
        if recorded is None:
            return Volume.finite_extremes.func(self)
        return tuple(self.dtype.type(v) for v in recorded)

    @property
    def nonfinite_count(self) -> int:
        recorded = getattr(self._bricks, "nonfinite", None)
        if recorded is not None:
            return int(recorded)
        if self.dtype.kind != "f":
            return 0
        if self._data is not None:
            return int(self._data.size - np.count_nonzero(np.isfinite(self._data)))
        return sum(int(s.size - np.count_nonzero(np.isfinite(s))) for s in self._slabs())

    # --- the whole array, within the budget -------------------------------------------------------
    @property
    def fits_budget(self) -> bool:
        return self.nbytes <= self.memory_budget_mb * 2**20

    @property
    def data(self) -> np.ndarray:
        if self._data is None:
            self._data = self._load()
        return self._data

    def _load(self) -> np.ndarray:
        if not self.fits_budget:
            dims = " x ".join(map(str, self.dims))
            raise MemoryBudgetError(
                f"volume from {self.source}: the whole array ({dims} voxels of {self.dtype}, "
                f"{format_bytes(self.nbytes)} at full resolution) exceeds the memory budget of "
                f"{self.memory_budget_mb:g} MiB. Render it with the BrickedRayCaster (it reads "
                f"bricks as needed), raise the budget (VolumeSource.memory_budget), or convert "
                f"fewer voxels (crop or downsample before vgraph convert)")
        check_memory(self.source, self.nbytes)
        return np.ascontiguousarray(self._bricks.read(0, (0, 0, 0), self.shape))

    # --- statistics from a small level ------------------------------------------------------------
    def _summary_level(self) -> int:
        levels = self._bricks.levels
        brick = self._bricks.brick
        return next((k for k, lv in enumerate(levels) if math.prod(lv.shape) <= SUMMARY_VOXELS
                     and math.prod(brick_grid(lv.shape, brick)) <= SUMMARY_BRICKS), len(levels) - 1)

    def _slabs(self):
        if self._data is not None:
            yield from Volume._slabs(self)
            return
        for block in sample_blocks(self._bricks, self._summary_level(), SUMMARY_VOXELS, SUMMARY_BRICKS):
            yield block.reshape(-1)

    @cached_property
    def _ranks(self) -> RankTable:
        # the summary's own extremes too: another tool's recorded range is a coarse level's
        # (narrower than a finer summary level's), and a damaged store's may be anything
        recorded, seen = self.finite_extremes, self._summary_extremes()
        extremes = seen if recorded is None else recorded if seen is None else \
            (min(recorded[0], seen[0]), max(recorded[1], seen[1]))
        summary = SimpleNamespace(finite_extremes=extremes, data=SimpleNamespace(dtype=self.dtype),
                                  _slabs=self._slabs, nonfinite_count=int(self.dtype.kind == "f"))
        return RankTable.of(summary)

    def _summary_extremes(self):
        return blockwise_extremes(self._slabs())

    def percentiles(self, percents) -> np.ndarray:
        if self.finite_extremes is None and self._summary_extremes() is None:
            lo, hi = self.value_range
            return lo + np.asarray(percents, dtype=np.float64) / 100.0 * (hi - lo)
        return Volume.percentiles(self, percents)

    # --- textures: by dtype, without loading the array ---------------------------------------------
    def texture_scale_offset(self) -> tuple[float, float]:
        if self.texture_is_normalized:
            return 1.0, 0.0
        lo, hi = self.value_range
        full_scale = TEXTURE_FORMATS.get(self.dtype, (None, 1.0))[1]
        return full_scale / (hi - lo), -lo / (hi - lo)

    @property
    def texture_is_normalized(self) -> bool:
        if self.dtype in TEXTURE_FORMATS:
            return False
        lo, hi = self.value_range
        return max(abs(lo), abs(hi)) > FLOAT32_SAFE or hi - lo < 1.0 / FLOAT32_SAFE

    # --- copies -------------------------------------------------------------------------------------
    def with_overrides(self, spacing=None, origin=None, declared_range=None, direction=None) -> "BrickedVolume":
        """The same pyramid on another grid or with another value range (VolumeSource's
        properties); nothing is read."""
        base = self._bricks.inner if isinstance(self._bricks, RegriddedSource) else self._bricks
        volume = BrickedVolume(base, memory_budget_mb=self.memory_budget_mb,
                               spacing=spacing or self.spacing, origin=origin or self.origin,
                               declared_range=declared_range or self.declared_range,
                               source=self.source, time_steps=self.time_steps,
                               direction=self.direction if direction is None else direction)
        volume._data = self._data
        return volume

    def __repr__(self) -> str:
        return (f"BrickedVolume({self.source!r}, {' x '.join(map(str, self.dims))} {self.dtype}, "
                f"{len(self._bricks.levels)} levels, brick {tuple(self._bricks.brick)}, "
                f"budget {self.memory_budget_mb:g} MiB)")


class RegriddedSource:
    """A BrickSource with the same voxels on another grid: every level's world coordinates are
    mapped by the affine map that takes level 0's spacing and origin to the new ones."""

    def __init__(self, inner, spacing, origin):
        self.inner = inner
        first = inner.levels[0]
        factor = [new / old for new, old in zip(spacing, first.spacing)]
        self.levels = [Level(level.shape, tuple(s * f for s, f in zip(level.spacing, factor)),
                             tuple(o + (lo - fo) * f for o, lo, fo, f in
                                   zip(origin, level.origin, first.origin, factor)))
                       for level in inner.levels]

    def __getattr__(self, name):  # everything else (read, brick_ranges, brick, dtype, ...) as is
        return getattr(self.inner, name)


def _checked_budget(budget, where: str) -> float:
    if isinstance(budget, bool) or not isinstance(budget, (int, float)) or not budget > 0 \
            or not math.isfinite(budget):
        raise VGraphError(f"volume{where}: memory_budget_mb must be a positive number of MiB, "
                          f"got {budget!r}")
    return float(budget)
