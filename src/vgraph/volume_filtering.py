"""What the volume filters (processors VolumeCrop, VolumeResample, VolumeSmooth, VolumeThreshold)
share: how they take a volume in and how they hand one on.

- They work on volumes in memory. A BrickedVolume (a store) is read whole when it fits its
  memory budget; a larger one is filtered chunk by chunk into a new store
  (vgraph.chunked_filtering; VolumeCrop reads only its box when that fits).
- A filter that keeps the values' units keeps the input's value range (as the output's
  ``declared_range``): a transfer function or iso level placed on the input shows the same
  values on the output, however much the filter narrowed the values.
- Filters that mix or order voxels (Gaussian, median, linear and cubic interpolation) replace NaN
  and infinite voxels by the ends of the value range first (NaN and -Inf by the low end, +Inf by
  the high end), with a warning naming the processor and the count, as the CubicSplineProcessor
  does: a NaN would otherwise spread over the whole kernel (or, in a median, sort anywhere).
  Filters that only pick voxels (crop, nearest resampling) carry them as they are.
- Mixed values are float32 (float64 input stays float64): an integer volume smoothed or
  interpolated in its own type would be rounded.
"""

from __future__ import annotations

import warnings

import numpy as np

from vgraph.errors import VGraphError, VGraphWarning
from vgraph.volume import Volume


def samples_in_memory(volume: Volume, who: str) -> Volume:
    """The volume, checked to hold samples (not B-spline coefficients)."""
    if volume.is_spline_coefficients:
        raise VGraphError(f"{who} needs voxel samples but received B-spline coefficients: put it "
                          f"before the CubicSplineProcessor, or disable that")
    return volume


def mixed_type(dtype) -> np.dtype:
    """The type of values a filter mixes from voxels of ``dtype``."""
    return np.dtype(np.float64) if np.dtype(dtype) == np.float64 else np.dtype(np.float32)


def finite_values(volume: Volume, who: str) -> np.ndarray:
    """The voxels in mixed_type, NaN/Inf replaced by the value range's ends (module docstring)."""
    if volume.nonfinite_count:
        warn_nonfinite(volume, who)
        return finite_array(volume.data, volume)
    return volume.data.astype(mixed_type(volume.data.dtype), copy=False)


def warn_nonfinite(volume: Volume, who: str) -> None:
    lo, hi = volume.value_range
    warnings.warn(f"{who}: {volume.nonfinite_count} NaN/Inf voxels replaced by the value "
                  f"range's ends ({lo:g}, {hi:g}) before filtering", VGraphWarning, stacklevel=4)


def finite_array(data: np.ndarray, volume: Volume) -> np.ndarray:
    """``data`` (voxels of ``volume``, all or a part) in mixed_type, NaN/Inf replaced by the
    ends of the volume's value range (module docstring)."""
    mixed = data.astype(mixed_type(data.dtype), copy=False)
    if data.dtype.kind != "f":  # integers are all finite
        return mixed
    lo, hi = volume.value_range
    return np.nan_to_num(mixed, nan=lo, posinf=hi, neginf=lo)


def filtered(volume: Volume, data: np.ndarray, **changes) -> Volume:
    """A volume of ``data`` with the input's grid, flags and value range (module docstring)."""
    return volume.with_data(data, **({"declared_range": volume.value_range} | changes))
