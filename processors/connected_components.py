"""ConnectedComponents: the connected parts of a mask or label volume as a label volume, largest first.

Conventions:
- The foreground is every voxel that is not 0 (a mask, or labels: touching voxels of different
  labels are one part). ``connectivity`` 6 (faces), 18 (faces and edges) or 26 (faces, edges and
  corners): scipy.ndimage.label with generate_binary_structure(3, 1 / 2 / 3). Neighbours are
  neighbours in the voxel grid, whatever the spacing.
- Labels 1 .. n number the components from the largest down (a tie: the one met first in
  memory order); 0 is the background. ``min_size`` (cubic world units) drops smaller
  components into the background before numbering.
- The output (vgraph.volume_segmentation.ComponentLabels) is flagged as labels, the
  LabelRayCaster shows it; it is uint8, uint16 or uint32, whichever holds n. Its
  ``voxel_counts`` and ``world_volumes`` give each label's size (voxels; voxel count x the
  voxel's volume). More components than the LabelRayCaster can show (MAX_SHOWN_LABELS) is an
  error naming ``min_size``.
- A volume of intensities (floats that are not whole numbers, not flagged as labels) is refused:
  threshold it first (VolumeThreshold).
- A store larger than its memory budget is labelled chunk by chunk into a new label store
  (vgraph.chunked_segmentation: dask-image's labelling across tiles, the tiles' labels in a
  scratch store): the same labels, numbering and sizes (a BrickedVolume with ``voxel_counts``,
  ``world_volumes``, ``component_count``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from vgraph import FloatProperty, Inport, IntProperty, Outport, Processor, PropertyError
from vgraph.chunked_filtering import is_chunked
from vgraph.chunked_segmentation import component_store
from vgraph.volume import Volume
from vgraph.volume_filtering import samples_in_memory
from vgraph.volume_segmentation import ComponentLabels, components_by_size, label_values
from vgraph import volume_segmentation

CONNECTIVITY = {6: 1, 18: 2, 26: 3}  # neighbours -> generate_binary_structure's rank


class ConnectedComponents(Processor):
    """The connected parts of a mask or labels, numbered from the largest down, with their sizes."""

    category = "Volume filters"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    connectivity = IntProperty(26, min=6, max=26, choices=tuple(CONNECTIVITY),
                               doc="neighbours that connect: 6 (faces), 18 (and edges) or 26 (and corners)")
    min_size = FloatProperty(0.0, min=0.0, doc="smaller components (cubic world units) become background")

    def process(self, volume: Volume) -> Volume:
        who = f"ConnectedComponents '{self.id}'"
        samples_in_memory(volume, who)
        structure = ndimage.generate_binary_structure(3, CONNECTIVITY[self.connectivity])
        voxel = float(np.prod(volume.spacing))
        # a component of exactly min_size is kept, whatever the rounding of voxels x voxel volume
        min_voxels = math.ceil(self.min_size / voxel - 1e-9)
        if is_chunked(volume):
            settings = {"type": "ConnectedComponents", "connectivity": self.connectivity, "min_size": self.min_size}
            return component_store(volume, who, lambda block: label_values(volume, who, block) != 0, structure,
                                   min_voxels, lambda kept, found: self._check_count(kept, found, volume), settings)
        foreground = label_values(volume, who) != 0
        labels, count = ndimage.label(foreground, structure=structure)
        labels, sizes = components_by_size(labels, count, min_voxels)
        self._check_count(sizes.size, count, volume)
        return ComponentLabels(labels, spacing=volume.spacing, origin=volume.origin, direction=volume.direction,
                               source=volume.source, time_steps=volume.time_steps, holds_labels=True,
                               declared_range=(0.0, float(max(1, sizes.size))), voxel_counts=sizes)

    def _check_count(self, kept: int, found: int, volume: Volume) -> None:
        limit = volume_segmentation.MAX_SHOWN_LABELS
        if kept > limit:
            raise PropertyError(f"{self.id}.min_size", f"{kept} components of {volume.source or 'the volume'} "
                                f"(of {found} found) are more labels than the LabelRayCaster can show "
                                f"({limit}): raise min_size")
