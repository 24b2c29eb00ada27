"""VolumeSmooth: a Gaussian or median filter with its size in world units.

Conventions:
- ``sigma`` (x, y, z) is the Gaussian's standard deviation in world units per axis: along each
  index axis sigma / spacing voxels (scipy.ndimage.gaussian_filter, cut at 4 sigma), so an
  anisotropic volume is smoothed alike in every world direction. 0 leaves an axis as it is.
- ``size`` (x, y, z) is the width of the median's box in world units per axis: along each index
  axis the odd number of voxels nearest size / spacing (a tie goes up; odd, so that the box is
  centred; at least 1; scipy.ndimage.median_filter).
- Beyond the volume's faces both mirror the voxels (scipy's 'reflect': half-sample symmetric).
- A kernel wider than the volume along an axis (4 sigma or half the median box beyond the number
  of voxels) is an error naming the property: it would mostly average mirrored copies.
- The Gaussian gives float32 (float64 stays), NaN/Inf replaced first; the median keeps the type
  and ignores no voxel, so NaN/Inf are replaced first too (its order of NaN is undefined). The
  value range and label flag are the input's; a label volume is refused (vgraph.volume_filtering).
- A store larger than its memory budget is filtered chunk by chunk with dask-image (each brick
  with a halo of the kernel's reach) into a new store (vgraph.chunked_filtering): the same values.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from vgraph import Inport, OptionProperty, Outport, Processor, PropertyError, VectorProperty
from vgraph.chunked_filtering import filtered_store, gaussian_plan, is_chunked, median_plan
from vgraph.volume import Volume
from vgraph.volume_filtering import filtered, finite_values, samples_in_memory

TRUNCATE = 4.0  # sigmas: scipy's default, where the Gaussian has fallen below 3.4e-4 of its peak
AXES = "xyz"


class VolumeSmooth(Processor):
    """A volume smoothed by a Gaussian or a median, sizes in world units per axis."""

    category = "Volume filters"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    filter = OptionProperty("gaussian", choices=["gaussian", "median"], doc="gaussian or median")
    sigma = VectorProperty((1.0, 1.0, 1.0), min=0.0,
                           doc="Gaussian standard deviation (x, y, z) in world units; 0: that axis unfiltered")
    size = VectorProperty((3.0, 3.0, 3.0), min=0.0,
                          doc="median box width (x, y, z) in world units: the odd voxel count nearest size / spacing")

    def inapplicable(self) -> set[str]:
        return {"size"} if self.filter == "gaussian" else {"sigma"}

    def process(self, volume: Volume) -> Volume:
        who = f"VolumeSmooth '{self.id}'"
        samples_in_memory(volume, who)
        if volume.holds_labels:
            raise PropertyError(f"{self.id}.filter", f"{self.filter} filtering mixes label values of "
                                f"{volume.source or 'the volume'}: smooth the intensities before labelling")
        spacing = np.array(volume.spacing)
        if self.filter == "gaussian":
            sigma = np.array(self.sigma) / spacing
            self._check_width("sigma", np.ceil(TRUNCATE * sigma - 1e-9), volume)
            if is_chunked(volume):
                return self._stored(volume, gaussian_plan(volume, who, tuple(sigma[::-1]), TRUNCATE))
            data = finite_values(volume, who)
            return filtered(volume, ndimage.gaussian_filter(data, sigma[::-1], truncate=TRUNCATE, mode="reflect"))
        radius = median_radius(self.size, spacing)
        self._check_width("size", radius, volume)
        if is_chunked(volume):
            return self._stored(volume, median_plan(volume, who, tuple(2 * radius[::-1] + 1)))
        data = finite_values(volume, who) if volume.nonfinite_count else volume.data
        return filtered(volume, ndimage.median_filter(data, size=tuple(2 * radius[::-1] + 1), mode="reflect"))

    def _stored(self, volume, plan):
        settings = {"type": "VolumeSmooth", "filter": self.filter,
                    "size": list(self.sigma if self.filter == "gaussian" else self.size)}
        return filtered_store(volume, plan, f"VolumeSmooth '{self.id}'", settings)

    def _check_width(self, name: str, radius: np.ndarray, volume: Volume) -> None:
        """Refuse a kernel reaching beyond the volume (module docstring); ``radius`` in voxels (x, y, z)."""
        for axis, (r, n) in enumerate(zip(radius, volume.dims)):
            if r > n:
                raise PropertyError(f"{self.id}.{name}", f"the kernel reaches {int(r)} voxels along "
                                    f"{AXES[axis]}, more than the volume's {n} voxels there "
                                    f"({getattr(self, name)[axis]:g} world units at spacing "
                                    f"{volume.spacing[axis]:g}): use a smaller {name}")


def median_radius(size, spacing) -> np.ndarray:
    """Half-width in voxels (x, y, z) of the median box ``size`` world units wide: the odd number
    of voxels nearest size / spacing is 2 floor(size / (2 spacing)) + 1 (a tie goes up)."""
    return np.floor(np.asarray(size, dtype=np.float64) / (2 * np.asarray(spacing)) + 1e-9).astype(int)
