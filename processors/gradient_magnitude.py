"""GradientMagnitude: |grad f| of a volume in value units per world unit.

Conventions:
- ``method = central``: central differences over the voxels' world distance (numpy.gradient
  with the spacing: (f[i+1] - f[i-1]) / (2 spacing) inside, one-sided differences at the faces).
- ``method = gaussian``: derivatives of a Gaussian of standard deviation ``sigma`` (world units,
  sigma / spacing voxels per axis, cut at 4 sigma, mirrored beyond the faces), each divided by
  its spacing: scipy.ndimage.gaussian_gradient_magnitude on an isotropic grid of spacing 1, and
  the derivative of a smoothed volume in world units on any grid. Smooths the noise that central
  differences amplify.
- The direction (an oriented grid) does not change a gradient's length.
- The output is float32 (float64 stays) on the input's grid; its value range is its own (not the
  input's: the units differ). NaN and Inf are replaced by the value range's ends first, with a
  warning. Label volumes are refused (a gradient of label numbers means nothing); so is a sigma
  whose kernel reaches further than the volume.
- A store larger than its memory budget is filtered chunk by chunk into a new store
  (vgraph.chunked_segmentation): tiles with halos of 1 voxel (central) or the Gaussian's reach,
  the same values.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from vgraph import Inport, OptionProperty, Outport, Processor, PropertyError, VectorProperty
from vgraph.chunked_filtering import filtered_store, is_chunked, kernel_plan
from vgraph.chunked_segmentation import overlapping
from vgraph.volume import Volume
from vgraph.volume_filtering import finite_values, mixed_type, samples_in_memory
from vgraph.volume_segmentation import check_reach

TRUNCATE = 4.0  # sigmas, as VolumeSmooth


class GradientMagnitude(Processor):
    """The length of a volume's gradient in world units: central differences or Gaussian derivatives."""

    category = "Volume filters"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    method = OptionProperty("central", choices=["central", "gaussian"],
                            doc="central differences, or derivatives of a Gaussian of sigma")
    sigma = VectorProperty((1.0, 1.0, 1.0), min=0.0,
                           doc="gaussian: standard deviation (x, y, z) in world units, each > 0")

    def inapplicable(self) -> set[str]:
        return {"sigma"} if self.method == "central" else set()

    def check(self) -> None:
        if self.method == "gaussian" and min(self.sigma) <= 0:
            raise PropertyError(f"{self.id}.sigma", f"each of x, y, z must be above 0, got {list(self.sigma)}")

    def process(self, volume: Volume) -> Volume:
        who = f"GradientMagnitude '{self.id}'"
        samples_in_memory(volume, who)
        self.check()
        if volume.holds_labels:
            raise PropertyError(f"{self.id}.method", f"{volume.source or 'the volume'} holds labels: a "
                                f"gradient of label numbers means nothing")
        spacing = np.array(volume.spacing)
        if self.method == "gaussian":
            sigma = np.array(self.sigma) / spacing
            check_reach(f"{self.id}.sigma", "kernel", np.ceil(TRUNCATE * sigma - 1e-9), volume)
        function = ((lambda d: central_magnitude(d, spacing)) if self.method == "central"
                    else (lambda d: gaussian_magnitude(d, spacing, sigma)))
        if is_chunked(volume):
            return self._stored(volume, who, function, sigma if self.method == "gaussian" else None)
        data = finite_values(volume, who)
        return volume.with_data(function(data).astype(data.dtype, copy=False), declared_range=None)

    def _stored(self, volume: Volume, who: str, function, sigma) -> Volume:
        """A store larger than its budget, slab by slab with halos of the differences' reach (1
        voxel) or the Gaussian's (vgraph.chunked_segmentation): the in-memory values."""
        reach = np.ones(3, dtype=int) if sigma is None else np.ceil(TRUNCATE * sigma[::-1]).astype(int)
        dtype = mixed_type(volume.dtype)
        plan = kernel_plan(volume, who, reach, dtype,
                           overlapping(lambda d: function(d).astype(dtype, copy=False), reach[1:], dtype))
        plan.declared_range = None  # its own range: the units are not the input's
        settings = {"type": "GradientMagnitude", "method": self.method, "sigma": list(self.sigma)}
        return filtered_store(volume, plan, who, settings)


def central_magnitude(data: np.ndarray, spacing: np.ndarray) -> np.ndarray:
    """|grad| by central differences in world units; ``spacing`` (x, y, z), ``data`` [z, y, x]."""
    # Python floats: a numpy float64 spacing would make numpy compute float32 data in float64 (3x slower)
    steps = [float(s) for s in spacing[::-1]]
    if min(data.shape) < 2:  # numpy.gradient needs two voxels along each axis
        squares = [np.gradient(data, s, axis=a) ** 2 for a, s in enumerate(steps) if data.shape[a] > 1]
        return np.sqrt(sum(squares)) if squares else np.zeros_like(data)
    return np.sqrt(sum(g * g for g in np.gradient(data, *steps)))


def gaussian_magnitude(data: np.ndarray, spacing: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """|grad| of the volume smoothed by ``sigma`` voxels (x, y, z) in world units (each derivative
    divided by its axis' spacing), through scipy.ndimage.generic_gradient_magnitude."""
    sigma_zyx, spacing_zyx = sigma[::-1], spacing[::-1]

    def derivative(values, axis, output, mode, cval):
        order = [0, 0, 0]
        order[axis] = 1
        result = ndimage.gaussian_filter(values, sigma_zyx, order, output, mode="reflect", truncate=TRUNCATE)
        result /= spacing_zyx[axis]
        return result

    return ndimage.generic_gradient_magnitude(data, derivative)
