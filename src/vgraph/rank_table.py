"""Order statistics of a volume's finite voxels from one pass over the data: the table behind
Volume.percentiles (transfer functions placed in percent, the robust window)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.value_range import from_unit, to_unit

# Bins of the histogram behind percentiles(): accurate to (max - min) / 65536, exact for integer
# data spanning fewer values (one bin per integer), and 512 KiB of counts whatever the volume.
PERCENTILE_BINS = 65536


@dataclass(frozen=True)
class RankTable:
    """Cumulative counts of a fine histogram of the finite voxels, from which the k-th smallest
    value (an order statistic) is found: exactly when every bin holds one integer value, else
    by spreading a bin's voxels evenly over its width (error below one bin)."""

    lo: float
    hi: float
    exact: bool        # one bin per integer value lo, lo + 1, ...
    cumulative: np.ndarray
    count: int         # finite voxels

    @classmethod
    def of(cls, volume) -> "RankTable":
        lo, hi = volume.finite_extremes
        data_type = volume.data.dtype
        exact = data_type.kind in "ui" and int(hi) - int(lo) < PERCENTILE_BINS or hi == lo
        bins = int(hi) - int(lo) + 1 if exact else PERCENTILE_BINS
        counts = np.zeros(bins, dtype=np.int64)
        for slab in volume._slabs():
            if exact and data_type == np.uint64:  # in its own type: uint64 beyond 2**63
                index = (slab - lo).astype(np.intp)
            elif exact and data_type.kind in "ui":  # int64: a narrower signed type would wrap
                index = slab.astype(np.int64) - int(lo)
            elif exact:  # a constant float volume: one bin
                index = np.zeros(np.count_nonzero(slab == lo), dtype=np.intp)
            else:
                index = _bin_index(slab[np.isfinite(slab)] if volume.nonfinite_count else slab,
                                   float(lo), float(hi))
            counts += np.bincount(index, minlength=bins)
        cumulative = np.cumsum(counts)
        return cls(float(lo), float(hi), bool(exact), cumulative, int(cumulative[-1]))

    def value_at(self, rank: np.ndarray) -> np.ndarray:
        """The rank-th smallest finite value (rank 0 .. count - 1, as floats holding integers)."""
        rank = np.asarray(rank, dtype=np.float64)
        bins = np.searchsorted(self.cumulative, rank, side="right")  # first bin with cum > rank
        if self.exact:
            return self.lo + bins.astype(np.float64)
        before = np.where(bins > 0, self.cumulative[np.maximum(bins - 1, 0)], 0)
        inside = self.cumulative[bins] - before
        fraction = (bins + (rank - before + 0.5) / inside) / PERCENTILE_BINS
        values = np.clip(from_unit(fraction, self.lo, self.hi), self.lo, self.hi)
        # the smallest and largest values are known exactly
        return np.where(rank <= 0, self.lo, np.where(rank >= self.count - 1, self.hi, values))


def _bin_index(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    unit = to_unit(values.astype(np.float64), lo, hi)
    return np.minimum((unit * PERCENTILE_BINS).astype(np.intp), PERCENTILE_BINS - 1)
