"""VolumeCrop: the part of a volume inside a box, in world units or voxel indices.

Conventions:
- ``units = world``: ``crop_box`` is (x_min, y_min, z_min, x_max, y_max, z_max) in world units,
  the same property as EntryExitPoints' crop box (link them to crop the data where the view was
  cropped). The voxels whose centres lie in the box are kept. On an oriented volume (a turned
  direction) the index box around the box's 8 corners is kept, as IsoSurfaceExtractor's region.
- ``units = voxels``: ``voxel_box`` is (i_min, j_min, k_min, i_max, j_max, k_max), voxel indices
  along x, y, z, both ends kept.
- Either box is clipped to the volume; a box that holds no voxel is an error naming the property.
  Empty (None): the whole volume.
- Of a store (a BrickedVolume) only the box's voxels are read, if they fit its memory budget: a
  region of a store larger than memory can be cut out and filtered in memory. A box larger than
  the budget is copied slab by slab into a new store (vgraph.chunked_filtering).
- The voxels keep their world positions: the output's origin is the world position of the first
  kept voxel; spacing, direction, type, value range and label flag are the input's
  (vgraph.volume_filtering).
"""

from __future__ import annotations

import numpy as np

from vgraph import Inport, OptionProperty, Outport, Processor, PropertyError, VectorProperty
from vgraph.chunked_filtering import filtered_store, voxel_plan
from vgraph.clipping import CropBoxProperty
from vgraph.volume import Volume
from vgraph.volume_filtering import filtered, samples_in_memory

_ROUNDING = 1e-9  # a centre on the box's face, a rounding off, is inside


class VolumeCrop(Processor):
    """The voxels of a volume inside a box (world or voxel units), at their world positions."""

    category = "Volume filters"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    units = OptionProperty("world", choices=["world", "voxels"],
                           doc="which box applies: crop_box (world units) or voxel_box (indices)")
    crop_box = CropBoxProperty(doc="(x_min, y_min, z_min, x_max, y_max, z_max) in world units: voxels "
                                   "whose centres lie inside are kept; empty: the whole volume")
    voxel_box = VectorProperty(None, size=6, integer=True, min=0, optional=True,
                               doc="(i_min, j_min, k_min, i_max, j_max, k_max) voxel indices, both "
                                   "ends kept; empty: the whole volume")

    def inapplicable(self) -> set[str]:
        return {"voxel_box"} if self.units == "world" else {"crop_box"}

    def check(self) -> None:
        box = self.voxel_box
        if box is not None and any(box[axis] > box[axis + 3] for axis in range(3)):
            raise PropertyError(f"{self.id}.voxel_box", f"each min must be at most its max, got {list(box)}")

    def process(self, volume: Volume) -> Volume:
        samples_in_memory(volume, f"VolumeCrop '{self.id}'")
        self.check()
        low, high = self._index_box(volume)
        origin = tuple(float(v) for v in volume.voxel_to_world(low))
        if volume.bricks is None:
            # a copy: a view would keep the whole input alive for a small crop of it
            return filtered(volume, volume.data[low[2]:high[2] + 1, low[1]:high[1] + 1,
                                                low[0]:high[0] + 1].copy(), origin=origin)
        size = int(np.prod(high - low + 1)) * np.dtype(volume.dtype).itemsize
        if size > volume.memory_budget_mb * 2**20:  # a box of a store larger than its budget
            return self._stored(volume, low, high, origin)
        # of a store only the box's voxels are read
        return filtered(volume, np.ascontiguousarray(volume.bricks.read(0, low[::-1], (high + 1)[::-1])),
                        origin=origin)

    def _stored(self, volume: Volume, low: np.ndarray, high: np.ndarray, origin) -> Volume:
        """The box copied slab by slab into a new store (vgraph.chunked_filtering)."""
        plan = voxel_plan(volume, low, high, volume.dtype, lambda voxels: voxels, volume.value_range,
                          origin=origin, holds_labels=volume.holds_labels)
        settings = {"type": "VolumeCrop", "low": low.tolist(), "high": high.tolist()}
        return filtered_store(volume, plan, f"VolumeCrop '{self.id}'", settings)

    def _index_box(self, volume: Volume) -> tuple[np.ndarray, np.ndarray]:
        """First and last kept voxel index (i, j, k), clipped to the volume."""
        dims = np.array(volume.dims)
        if self.units == "world":
            name, box = "crop_box", self.crop_box
            low, high = (np.zeros(3, int), dims - 1) if box is None else world_index_box(volume, box)
        else:
            name, box = "voxel_box", self.voxel_box
            low, high = (np.zeros(3, int), dims - 1) if box is None else (np.array(box[:3]), np.array(box[3:]))
        low, high = np.maximum(low, 0), np.minimum(high, dims - 1)
        if np.any(high < low):
            first, last = volume.voxel_to_world((0, 0, 0)), volume.voxel_to_world(dims - 1)
            raise PropertyError(f"{self.id}.{name}", f"the box {list(box)} holds no voxel of the volume "
                                f"(voxels 0 .. {(dims - 1).tolist()}, centres {first.tolist()} .. "
                                f"{last.tolist()} in world units)")
        return low, high


def world_index_box(volume: Volume, box) -> tuple[np.ndarray, np.ndarray]:
    """First and last voxel index (i, j, k) of the index box around a world box (x_min, ...,
    z_max): the voxels whose centres lie inside it when the volume is axis-aligned or its axes
    only swapped or mirrored. Not clipped."""
    corners = np.array([[box[axis + 3 * bit] for axis, bit in enumerate(bits)]
                        for bits in np.ndindex(2, 2, 2)], dtype=np.float64)
    index = volume.world_to_voxel(corners)
    low = np.ceil(index.min(axis=0) - _ROUNDING).astype(int)
    high = np.floor(index.max(axis=0) + _ROUNDING).astype(int)
    return low, high
