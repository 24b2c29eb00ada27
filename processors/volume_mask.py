"""VolumeMask: a volume's voxels inside chosen labels of a label volume, a fixed value elsewhere.

Conventions:
- ``labels`` is the list of label values to keep, written "1, 3, 7" (commas or spaces); empty:
  every label but 0. A voxel is kept where the label volume holds one of them, else it becomes
  ``outside``.
- The label volume must lie on the volume's grid (dims, spacing, origin, direction): otherwise a
  GridMismatchError naming ``labels`` (resample the labels with VolumeResample, nearest).
- The output has the volume's type, grid, value range and label flag; ``outside`` must fit the
  type (-1 into uint8 is refused, naming ``outside``).
"""

from __future__ import annotations

import re

import numpy as np

from vgraph import FloatProperty, Inport, Outport, Processor, PropertyError, StringProperty
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
        values = label_values(labels, who)
        inside = values != 0 if kept is None else np.isin(values, kept)
        outside = checked_fill(self.outside, volume.data.dtype, f"{self.id}.outside")
        return filtered(volume, np.where(inside, volume.data, outside))
