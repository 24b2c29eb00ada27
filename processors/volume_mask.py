"""VolumeMask: a volume's voxels inside chosen labels of a label volume, a fixed value elsewhere.

Conventions:
- ``labels`` is the list of label values to keep, written "1, 3, 7" (commas or spaces); empty:
  every label but 0. A voxel is kept where the label volume holds one of them, else it becomes
  ``outside``.
- The label volume must lie on the volume's grid (dims, spacing, origin, direction): otherwise a
  GridMismatchError naming ``labels`` (resample the labels with VolumeResample, nearest).
- The output has the volume's type, grid, value range and label flag; ``outside`` must fit the
  type (-1 into uint8 is refused, naming ``outside``).
- Either input a store larger than its memory budget: the output is a new store, slab by slab
  (vgraph.chunked_segmentation), the same values.
"""

from __future__ import annotations

import re

import numpy as np

from vgraph import FloatProperty, Inport, Outport, Processor, PropertyError, StringProperty
from vgraph.chunked_filtering import filtered_store, is_chunked
from vgraph.chunked_segmentation import elementwise_plan, input_key, rows_of, voxel_type
from vgraph.volume import Volume
from vgraph.volume_filtering import filtered, samples_in_memory
from vgraph.volume_segmentation import checked_fill, label_values, require_same_grid


class VolumeMask(Processor):
    """Keeps a volume's voxels inside chosen labels, a fixed value elsewhere."""

    category = "Volume filters"
    inports = [Inport("volume", Volume), Inport("labels", Volume)]
    outports = [Outport("volume", Volume)]
    keep = StringProperty("", doc='label values to keep, e.g. "1, 3"; empty: every label but 0')
    outside = FloatProperty(0.0, doc="the value of the voxels outside the kept labels")

    def check(self) -> None:
        self.kept_labels()

    def kept_labels(self) -> list[int] | None:
        """The label values of ``keep`` (None: every label but 0)."""
        words = [w for w in re.split(r"[,\s]+", self.keep.strip()) if w]
        try:
            return [int(w) for w in words] or None
        except ValueError:
            raise PropertyError(f"{self.id}.keep", f"{self.keep!r} is not a list of whole numbers "
                                f'(e.g. "1, 3")') from None

    def process(self, volume: Volume, labels: Volume) -> Volume:
        who = f"VolumeMask '{self.id}'"
        samples_in_memory(volume, who)
        samples_in_memory(labels, who)
        kept = self.kept_labels()
        require_same_grid(f"{self.id}.labels", (f"{self.id}.volume", f"{self.id}.labels"), volume, labels,
                          "resample the labels onto the volume (VolumeResample, nearest)")
        outside = checked_fill(self.outside, voxel_type(volume), f"{self.id}.outside")

        def masked(values: np.ndarray, label_voxels: np.ndarray) -> np.ndarray:
            label_voxels = label_values(labels, who, label_voxels)
            inside = label_voxels != 0 if kept is None else np.isin(label_voxels, kept)
            return np.where(inside, values, outside)
        if is_chunked(volume) or is_chunked(labels):  # slab by slab (vgraph.chunked_segmentation)
            anchor = volume if is_chunked(volume) else labels  # sets the bricks and the budget
            plan = elementwise_plan(anchor, volume,
                                    [lambda z0, z1: rows_of(volume, z0, z1), lambda z0, z1: rows_of(labels, z0, z1)],
                                    masked, voxel_type(volume), volume.value_range, volume.holds_labels)
            settings = {"type": "VolumeMask", "keep": kept, "outside": self.outside,
                        "volume": input_key(volume), "labels": input_key(labels)}
            return filtered_store(anchor, plan, who, settings)
        return filtered(volume, masked(volume.data, labels.data))
