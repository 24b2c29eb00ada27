"""CubicSplineProcessor (Cabral 2010, ch. 3.1-3.2 and 5.2): samples -> cubic B-spline coefficients."""

import warnings

import numpy as np

from vgraph import BoolProperty, Inport, Outport, Processor, VGraphError
from vgraph.numerics.bspline import prefilter
from vgraph.progress import Steps
from vgraph.volume import Volume

PROGRESS_FROM_VOXELS = 128 ** 3  # smaller volumes filter in well under a second


class CubicSplineProcessor(Processor):
    """Converts a volume to cubic B-spline coefficients (float32; mirror boundary)."""

    category = "Volume"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    enabled = BoolProperty(True, doc="off: pass the samples through unchanged")

    def process(self, volume: Volume) -> Volume:
        if not self.enabled:
            return volume
        if volume.is_spline_coefficients:
            raise VGraphError("the input already holds B-spline coefficients: remove one of the two "
                              "CubicSplineProcessors")
        if volume.texture_is_normalized:
            # float32 coefficients cannot hold these values: filter the normalised intensities
            # (the prefilter is linear, so that is the same spline in other units).
            volume = volume.with_data(volume.normalized(volume.data), declared_range=(0.0, 1.0))
        return volume.with_data(self._coefficients(volume), is_spline_coefficients=True,
                                declared_range=volume.value_range)

    def _coefficients(self, volume: Volume) -> np.ndarray:
        data = volume.data
        if volume.nonfinite_count:
            # The recursive filter would smear a single NaN along whole lines of the volume.
            lo, hi = volume.value_range
            warnings.warn(f"{self.id}: {volume.nonfinite_count} NaN/Inf voxels replaced by the "
                          f"value range's ends before filtering", stacklevel=2)
            data = np.nan_to_num(data.astype(np.float32), nan=lo, posinf=hi, neginf=lo)
        with Steps(100, "B-spline prefilter", unit="%",
                   show=False if data.size < PROGRESS_FROM_VOXELS else None) as bar:
            return prefilter(data, progress=lambda done: bar.set(round(done * 100)))
