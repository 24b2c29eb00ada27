"""VolumeResample: a volume on a grid of another spacing or size, over the same box.

Conventions:
- ``mode = spacing``: the new spacing (x, y, z) in world units; each axis gets
  max(1, round(n * old spacing / new spacing)) voxels. ``mode = size``: the new voxel counts
  (x, y, z); the spacing becomes old spacing * n / new n, so the voxel cells cover the same box
  (scipy.ndimage.zoom's grid_mode, scikit-image's resize).
- The new grid is centred on the old one (same centre of the box of voxel centres) and keeps the
  direction, so every voxel is sampled at its world position: input index = (old extent / 2 -
  new extent / 2 + new index * new spacing) / old spacing along each index axis.
- ``interpolation``: nearest and linear sample with scipy.ndimage (order 0 and 1); near the edges,
  up to half a voxel outside the old voxel centres, they hold the edge voxel (as the renderers'
  clamped textures). cubic is the cubic B-spline (Cabral 2010, ch. 3): the coefficients from
  vgraph.numerics.bspline.prefilter, evaluated by scipy.ndimage with the prefilter's mirror
  boundary; it may overshoot the input's values near sharp edges.
- nearest keeps the type and the label flag; linear and cubic give float32 (float64 stays), NaN
  and Inf replaced first (vgraph.volume_filtering), and refuse label volumes (mixing labels
  makes new, wrong ones). The value range is the input's.
- A store larger than its memory budget is resampled slab by slab into a new store
  (vgraph.chunked_filtering), each slab from the input slices its samples reach: the same values
  for nearest and linear. cubic prefilters each slab's slices with 16 more on each side along z
  (the B-spline prefilter's recursion runs along whole axes; cut 16 slices away its error has
  fallen to about 0.268^16 = 7e-10 of the values): within 1e-6 of the largest |value| of the
  in-memory result (tests/test_chunked_segmentation.py).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from vgraph import Inport, OptionProperty, Outport, Processor, PropertyError, VectorProperty
from vgraph.chunked_filtering import filtered_store, is_chunked, resample_plan
from vgraph.numerics.bspline import prefilter
from vgraph.volume import Volume
from vgraph.volume_filtering import filtered, finite_values, mixed_type, samples_in_memory

ORDERS = {"nearest": 0, "linear": 1, "cubic": 3}
MAX_VOXELS = 2**31  # per volume: beyond this a typo (spacing 0.001) would ask for terabytes


class VolumeResample(Processor):
    """A volume resampled to another spacing or size (nearest, linear or cubic B-spline)."""

    category = "Volume filters"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    mode = OptionProperty("spacing", choices=["spacing", "size"],
                          doc="which one sets the new grid: spacing (world units) or size (voxels)")
    spacing = VectorProperty((1.0, 1.0, 1.0), min=0.0, doc="new spacing (x, y, z) in world units, each > 0")
    size = VectorProperty((64, 64, 64), integer=True, min=0, doc="new voxel counts (x, y, z), each >= 1")
    interpolation = OptionProperty("linear", choices=list(ORDERS),
                                   doc="nearest, linear (trilinear) or cubic (cubic B-spline)")

    def inapplicable(self) -> set[str]:
        return {"size"} if self.mode == "spacing" else {"spacing"}

    def check(self) -> None:
        values = self.spacing if self.mode == "spacing" else self.size
        if min(values) <= 0:
            raise PropertyError(f"{self.id}.{self.mode}", f"each of x, y, z must be above 0, got {list(values)}")

    def process(self, volume: Volume) -> Volume:
        who = f"VolumeResample '{self.id}'"
        samples_in_memory(volume, who)
        self.check()
        old_dims, old_spacing = np.array(volume.dims), np.array(volume.spacing)
        dims, spacing = self._grid(old_dims, old_spacing)
        # along each index axis: input index = start + output index * step
        step = spacing / old_spacing
        start = ((old_dims - 1) * old_spacing - (dims - 1) * spacing) / 2 / old_spacing
        origin = tuple(float(v) for v in volume.voxel_to_world(start))
        spacing = tuple(float(s) for s in spacing)
        shape = tuple(int(n) for n in dims[::-1])
        if is_chunked(volume):
            return self._stored(volume, who, shape, step[::-1], start[::-1], spacing, origin)
        data = self._sample(volume, who, shape, step[::-1], start[::-1])
        return filtered(volume, data, spacing=spacing, origin=origin)

    def _stored(self, volume: Volume, who: str, shape, step, start, spacing, origin) -> Volume:
        """A store larger than its budget, resampled slab by slab into a new store."""
        order = ORDERS[self.interpolation]
        if order and volume.holds_labels:
            self._refuse_labels()
        plan = resample_plan(volume, who, shape, step, start, order, spacing, origin)
        settings = {"type": "VolumeResample", "shape": list(shape), "spacing": list(spacing),
                    "interpolation": self.interpolation}
        return filtered_store(volume, plan, who, settings)

    def _refuse_labels(self) -> None:
        raise PropertyError(f"{self.id}.interpolation", f"{self.interpolation} interpolation mixes "
                            f"label values into labels that are not there: use nearest for a label volume")

    def _grid(self, old_dims: np.ndarray, old_spacing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The new voxel counts and spacing (x, y, z)."""
        if self.mode == "spacing":
            spacing = np.array(self.spacing, dtype=np.float64)
            dims = np.maximum(1, np.round(old_dims * old_spacing / spacing)).astype(np.int64)
        else:
            dims = np.array(self.size, dtype=np.int64)
            spacing = old_spacing * old_dims / dims
        if np.prod(dims) > MAX_VOXELS:
            raise PropertyError(f"{self.id}.{self.mode}", f"the new grid would hold {' x '.join(map(str, dims))} "
                                f"voxels, more than {MAX_VOXELS} in one volume")
        return dims, spacing

    def _sample(self, volume: Volume, who: str, shape, step, start) -> np.ndarray:
        """The input sampled at start + index * step ([z, y, x] order) with the interpolation."""
        order = ORDERS[self.interpolation]
        if order == 0:
            return ndimage.affine_transform(volume.data, step, start, output_shape=shape, order=0, mode="nearest")
        if volume.holds_labels:
            self._refuse_labels()
        data = finite_values(volume, who)
        if order == 1:
            return ndimage.affine_transform(data, step, start, output_shape=shape, order=1, mode="nearest")
        coefficients = prefilter(data).astype(mixed_type(data.dtype), copy=False)
        return ndimage.affine_transform(coefficients, step, start, output_shape=shape, order=3, mode="mirror",
                                        prefilter=False)
