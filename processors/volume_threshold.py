"""VolumeThreshold: a volume to a mask (0 / 1) or to labels by value.

Conventions:
- ``lower`` and ``upper`` are normalised intensities over the input's value range, as the
  RayCaster's and IsoSurfaceExtractor's ``iso_level`` (link them to threshold where the surface is
  drawn): data value = low + level (high - low).
- ``method = manual``: mask = 1 where lower <= value <= upper; labels = 0 below lower, 1 from
  lower to upper, 2 above upper.
- ``method = otsu``: the levels come from the finite voxels by Otsu's method (Otsu 1979, as
  scikit-image computes it from a 256-bin histogram over the value range): mask = 1 at and above
  skimage.filters.threshold_otsu's level; labels = np.digitize(value,
  skimage.filters.threshold_multiotsu(classes)), 0 .. classes - 1.
- NaN voxels are in no interval: 0. The output is uint8 with the input's grid, flagged as labels
  (LabelRayCaster shows it); its value range is 0 .. the largest label.
"""

from __future__ import annotations

import numpy as np
from skimage.filters import threshold_multiotsu, threshold_otsu

from vgraph import FloatProperty, Inport, IntProperty, OptionProperty, Outport, Processor, PropertyError
from vgraph.volume import Volume
from vgraph.volume_filtering import samples_in_memory

SLAB_SLICES = 16  # z slices normalised at a time
OTSU_BINS = 256  # scikit-image's default histogram for Otsu's method


class VolumeThreshold(Processor):
    """A volume to a mask or labels by value ranges (manual levels or Otsu's method)."""

    category = "Volume filters"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    output = OptionProperty("mask", choices=["mask", "labels"],
                            doc="mask: 1 inside the levels, 0 elsewhere; labels: one label per class")
    method = OptionProperty("manual", choices=["manual", "otsu"],
                            doc="manual: lower and upper; otsu: levels from the histogram (Otsu 1979)")
    lower = FloatProperty(0.5, min=0.0, max=1.0, doc="manual: lowest value inside, normalised intensity")
    upper = FloatProperty(1.0, min=0.0, max=1.0, doc="manual: highest value inside, normalised intensity")
    classes = IntProperty(3, min=2, max=5, doc="otsu labels: number of classes (labels 0 .. classes - 1)")

    def inapplicable(self) -> set[str]:
        if self.method == "manual":
            return {"classes"}
        return {"lower", "upper"} | ({"classes"} if self.output == "mask" else set())

    def check(self) -> None:
        if self.method == "manual" and self.lower > self.upper:
            raise PropertyError(f"{self.id}.lower", f"lower ({self.lower:g}) must not be above upper ({self.upper:g})")

    def process(self, volume: Volume) -> Volume:
        samples_in_memory(volume, f"VolumeThreshold '{self.id}'")
        self.check()
        labels = self._manual(volume) if self.method == "manual" else self._otsu(volume).astype(np.uint8)
        top = 1 if self.output == "mask" else (2 if self.method == "manual" else self.classes - 1)
        return volume.with_data(labels, declared_range=(0.0, float(top)), holds_labels=True)

    def _manual(self, volume: Volume) -> np.ndarray:
        """Labels by lower and upper, compared in normalised intensity (as the user gave them: a
        level of 500 / 3926 then keeps the voxels of 500, which low + level (high - low), rounded,
        did not), slab by slab to bound the float64 temporaries."""
        labels = np.empty(volume.data.shape, dtype=np.uint8)
        for start in range(0, volume.data.shape[0], SLAB_SLICES):
            level = volume.normalized(volume.data[start:start + SLAB_SLICES])
            inside = (level >= self.lower) & (level <= self.upper)
            if self.output == "labels":
                inside = inside + 2 * (level > self.upper).astype(np.uint8)
            labels[start:start + SLAB_SLICES] = inside
        return labels

    def _otsu(self, volume: Volume) -> np.ndarray:
        """Labels by Otsu's levels, computed by scikit-image from the volume's histogram of
        OTSU_BINS bins over its value range (kept with the volume; scikit-image on the voxels of
        an integer volume would take one bin per integer: 130 s for 4 classes of a CT)."""
        if volume.constant_value is not None:
            raise PropertyError(f"{self.id}.method", f"Otsu's method needs more than one value; every "
                                f"finite voxel of {volume.source or 'the volume'} is {volume.constant_value:g}")
        counts, edges = volume.histogram(OTSU_BINS)
        histogram = (counts, (edges[:-1] + edges[1:]) / 2)
        if self.output == "mask":
            levels = np.array([threshold_otsu(hist=histogram)])
        else:
            levels = threshold_multiotsu(hist=histogram, classes=self.classes)
        low, high = volume.value_range
        labels = np.digitize(volume.data, bins=low + levels * (high - low))  # NaN sorts above all
        if volume.nonfinite_count:
            labels[np.isnan(volume.data)] = 0
        return labels
