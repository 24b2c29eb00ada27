"""VolumeMath: two volumes voxel by voxel: add, subtract, multiply, min, max, or mask.

Conventions:
- ``first`` and ``second`` must lie on one grid (dims, spacing, origin and direction, within
  vgraph.volume_segmentation.GRID_TOLERANCE of the voxel size); otherwise ``grid = same`` is a
  GridMismatchError naming ``grid`` and how the grids differ, and ``grid = resample`` samples the
  second at the first's voxel centres in world space (nearest for a label volume, linear
  otherwise; 0 beyond the second's voxel cells; vgraph.volume_segmentation.sampled_on_grid).
- add, subtract (first - second), multiply: float32 (float64 if either is), no overflow of small
  integer types; the value range is the result's own. NaN propagates (numpy).
- min, max: numpy.minimum / maximum in the type both fit (numpy's promotion); labels stay labels
  when both are.
- mask: the first's voxels where the second is not 0, ``outside`` elsewhere (the type, value
  range and label flag of the first; ``outside`` must fit its type).
- The output lies on the first's grid.
"""

from __future__ import annotations

import numpy as np

from vgraph import FloatProperty, Inport, OptionProperty, Outport, Processor
from vgraph.volume import Volume
from vgraph.volume_filtering import filtered, mixed_type, samples_in_memory
from vgraph.volume_segmentation import checked_fill, require_same_grid, sampled_on_grid

ARITHMETIC = {"add": np.add, "subtract": np.subtract, "multiply": np.multiply}
EXTREMES = {"min": np.minimum, "max": np.maximum}
OPERATIONS = (*ARITHMETIC, *EXTREMES, "mask")


class VolumeMath(Processor):
    """Two volumes combined voxel by voxel (add, subtract, multiply, min, max, mask)."""

    category = "Volume filters"
    inports = [Inport("first", Volume), Inport("second", Volume)]
    outports = [Outport("volume", Volume)]
    operation = OptionProperty("add", choices=list(OPERATIONS),
                               doc="add, subtract (first - second), multiply, min, max, or mask (first "
                                   "where second is not 0)")
    grid = OptionProperty("same", choices=["same", "resample"],
                          doc="same: the two grids must be one; resample: the second is sampled on the first's")
    outside = FloatProperty(0.0, doc="mask: the value where the second is 0")

    def inapplicable(self) -> set[str]:
        return set() if self.operation == "mask" else {"outside"}

    def process(self, first: Volume, second: Volume) -> Volume:
        for volume in (first, second):
            samples_in_memory(volume, f"VolumeMath '{self.id}'")
        other = self._on_first_grid(first, second)
        if self.operation in ARITHMETIC:
            dtype = np.result_type(mixed_type(first.data.dtype), mixed_type(other.dtype))
            data = ARITHMETIC[self.operation](first.data, other, dtype=dtype)
            return first.with_data(data, declared_range=None, holds_labels=False)
        if self.operation in EXTREMES:
            data = EXTREMES[self.operation](first.data, other)
            return first.with_data(data, declared_range=None, holds_labels=first.holds_labels and second.holds_labels)
        outside = checked_fill(self.outside, first.data.dtype, f"{self.id}.outside")
        return filtered(first, np.where(other != 0, first.data, outside))

    def _on_first_grid(self, first: Volume, second: Volume) -> np.ndarray:
        """The second's voxels on the first's grid: as they are, or resampled when asked."""
        if self.grid == "same":
            require_same_grid(f"{self.id}.grid", (f"{self.id}.first", f"{self.id}.second"), first, second,
                              "resample one onto the other (VolumeResample), or set grid = resample")
            return second.data
        return sampled_on_grid(second, first, order=0 if second.holds_labels else 1)

