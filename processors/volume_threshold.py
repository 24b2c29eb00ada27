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
- A store larger than its memory budget is thresholded slab by slab into a new store
  (vgraph.chunked_filtering); Otsu's levels then come from one pass over all its voxels (the
  same histogram as in memory; a store's own histogram is a summary level's).
"""

from __future__ import annotations

import numpy as np
from skimage.filters import threshold_multiotsu, threshold_otsu

from vgraph import FloatProperty, Inport, IntProperty, OptionProperty, Outport, Processor, PropertyError
from vgraph.chunked_filtering import filtered_store, is_chunked, level_histogram, voxel_plan
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
        top = 1 if self.output == "mask" else (2 if self.method == "manual" else self.classes - 1)
        if self.method == "manual":
            label = self._manual
        else:
            chunked = is_chunked(volume)
            label = self._otsu_labeller(volume, level_histogram(volume, OTSU_BINS) if chunked
                                        else volume.histogram(OTSU_BINS))
        if is_chunked(volume):
            return self._stored(volume, label, top)
        labels = np.empty(volume.data.shape, dtype=np.uint8)
        for start in range(0, volume.data.shape[0], SLAB_SLICES):  # bounds the float64 temporaries
            labels[start:start + SLAB_SLICES] = label(volume.data[start:start + SLAB_SLICES], volume)
        return volume.with_data(labels, declared_range=(0.0, float(top)), holds_labels=True)

    def _stored(self, volume: Volume, label, top: int) -> Volume:
        plan = voxel_plan(volume, (0, 0, 0), np.array(volume.dims) - 1, np.uint8,
                          lambda voxels: label(voxels, volume), (0.0, float(top)), holds_labels=True)
        settings = {"type": "VolumeThreshold", **{name: getattr(self, name) for name in
                                                  ("output", "method", "lower", "upper", "classes")}}
        return filtered_store(volume, plan, f"VolumeThreshold '{self.id}'", settings)

    def _manual(self, values: np.ndarray, volume: Volume) -> np.ndarray:
        """Labels of ``values`` by lower and upper, compared in normalised intensity (as the user
        gave them: a level of 500 / 3926 then keeps the voxels of 500, which low + level (high -
        low), rounded, did not)."""
        level = volume.normalized(values)
        inside = ((level >= self.lower) & (level <= self.upper)).astype(np.uint8)
        if self.output == "labels":
            inside += 2 * (level > self.upper).astype(np.uint8)
        return inside

    def _otsu_labeller(self, volume: Volume, histogram):
        """The labelling by Otsu's levels, computed by scikit-image from the volume's histogram of
        OTSU_BINS bins over its value range (scikit-image on the voxels of an integer volume
        would take one bin per integer: 130 s for 4 classes of a CT)."""
        if volume.constant_value is not None:
            raise PropertyError(f"{self.id}.method", f"Otsu's method needs more than one value; every "
                                f"finite voxel of {volume.source or 'the volume'} is {volume.constant_value:g}")
        counts, edges = histogram
        histogram = (counts, (edges[:-1] + edges[1:]) / 2)
        if self.output == "mask":
            levels = np.array([threshold_otsu(hist=histogram)])
        else:
            levels = threshold_multiotsu(hist=histogram, classes=self.classes)
        low, high = volume.value_range
        bins = low + levels * (high - low)

        def label(values: np.ndarray, _volume) -> np.ndarray:
            labels = np.digitize(values, bins=bins).astype(np.uint8)  # NaN sorts above all
            if values.dtype.kind == "f":
                labels[np.isnan(values)] = 0
            return labels
        return label
