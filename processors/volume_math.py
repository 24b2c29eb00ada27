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
- Either input a store larger than its memory budget: the output is a new store, slab by slab
  (vgraph.chunked_segmentation), the same values; ``grid = resample`` then needs the second in
  memory (a second over its budget is a named error).
"""

from __future__ import annotations

import numpy as np

from vgraph import FloatProperty, Inport, OptionProperty, Outport, Processor, PropertyError
from vgraph.chunked_filtering import filtered_store, is_chunked
from vgraph.chunked_segmentation import elementwise_plan, input_key, on_slab_grid, rows_of, voxel_type
from vgraph.volume import Volume
from vgraph.volume_filtering import mixed_type, samples_in_memory
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
        if is_chunked(first) or is_chunked(second):
            return self._stored(first, second)
        combine, dtype, declared, labels = self._combination(first, second)
        return first.with_data(combine(first.data, self._on_first_grid(first, second)), declared_range=declared,
                               holds_labels=labels)

    def _combination(self, first: Volume, second: Volume):
        """(combine(first's voxels, second's on its grid), the output type, declared range, label flag)."""
        if self.operation in ARITHMETIC:
            dtype = np.result_type(mixed_type(voxel_type(first)), mixed_type(self._second_type(first, second)))
            return (lambda a, b: ARITHMETIC[self.operation](a, b, dtype=dtype)), dtype, None, False
        if self.operation in EXTREMES:
            dtype = np.result_type(voxel_type(first), self._second_type(first, second))
            return EXTREMES[self.operation], dtype, None, first.holds_labels and second.holds_labels
        outside = checked_fill(self.outside, voxel_type(first), f"{self.id}.outside")
        return (lambda a, b: np.where(b != 0, a, outside)), voxel_type(first), first.value_range, first.holds_labels

    def _second_type(self, first: Volume, second: Volume) -> np.dtype:
        """The type of the second's voxels on the first's grid (linear resampling mixes them)."""
        if self.grid == "resample" and not second.holds_labels:
            return mixed_type(voxel_type(second))
        return voxel_type(second)

    def _on_first_grid(self, first: Volume, second: Volume) -> np.ndarray:
        """The second's voxels on the first's grid: as they are, or resampled when asked."""
        if self.grid == "same":
            self._require_same_grid(first, second)
            return second.data
        return sampled_on_grid(second, first, order=0 if second.holds_labels else 1)

    def _require_same_grid(self, first: Volume, second: Volume) -> None:
        require_same_grid(f"{self.id}.grid", (f"{self.id}.first", f"{self.id}.second"), first, second,
                          "resample one onto the other (VolumeResample), or set grid = resample")

    def _stored(self, first: Volume, second: Volume) -> Volume:
        """Either input a store larger than its budget: the output a store, slab by slab from the
        same slabs of both (vgraph.chunked_segmentation)."""
        who = f"VolumeMath '{self.id}'"
        if self.grid == "same":
            self._require_same_grid(first, second)
            other = lambda z0, z1: rows_of(second, z0, z1)  # noqa: E731
        elif is_chunked(second):
            raise PropertyError(f"{self.id}.grid", f"grid = resample samples the second volume whole, and "
                                f"{second.source or 'it'} is a store larger than its memory budget: resample "
                                f"it onto the first's grid (VolumeResample), then use grid = same")
        else:
            other = on_slab_grid(second, first, order=0 if second.holds_labels else 1)
        combine, dtype, declared, labels = self._combination(first, second)
        anchor = first if is_chunked(first) else second
        plan = elementwise_plan(anchor, first, [lambda z0, z1: rows_of(first, z0, z1), other], combine, dtype,
                                declared, labels)
        settings = {"type": "VolumeMath", "operation": self.operation, "grid": self.grid, "outside": self.outside,
                    "first": input_key(first), "second": input_key(second)}
        return filtered_store(anchor, plan, who, settings)
