"""Gradient opacity: a 1D opacity curve over gradient magnitude that multiplies a transfer
function's opacity (ParaView's and 3D Slicer's "Gradient Opacity"; Kniss et al. 2002 on why the
gradient magnitude separates boundaries from homogeneous regions).

JSON form: ``{"points": [[gradient, opacity], ...]}``, piecewise linear, the end values held beyond
the first and last point. ``gradient`` is a *gradient fraction* in [0, 1]: the sample's gradient
magnitude divided by the volume's largest (central differences of the normalised intensities at the
voxels; vgraph.numerics.reference_classification states the model), so one curve fits any volume as
a normalised TF does. ``opacity`` in [0, 1] multiplies the TF's alpha. A curve rising from 0 hides
homogeneous regions and keeps the boundaries between materials.

A gradient-opacity property also accepts a preset's name (``PRESETS``).
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

LUT_SIZE = 1024  # entries of the curve's look-up table (entry i at gradient fraction i / 1023)

Point = tuple[float, float]


class GradientOpacity(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    points: list[Point] = Field(min_length=1)

    @field_validator("points", mode="before")
    @classmethod
    def _check_lengths(cls, points):
        # In words: pydantic alone would say "points.0.1: Field required".
        for index, point in enumerate(points if isinstance(points, (list, tuple)) else []):
            if isinstance(point, (list, tuple)) and len(point) != 2:
                raise ValueError(f"point {index} needs 2 numbers [gradient, opacity], got {list(point)}")
        return points

    @model_validator(mode="after")
    def _check_points(self) -> "GradientOpacity":
        for index, (gradient, opacity) in enumerate(self.points):
            if not (np.isfinite(gradient) and 0.0 <= gradient <= 1.0):
                raise ValueError(f"point {index}: the gradient fraction must lie in [0, 1], got {gradient}")
            if not (np.isfinite(opacity) and 0.0 <= opacity <= 1.0):
                raise ValueError(f"point {index}: the opacity factor must lie in [0, 1], got {opacity}")
        positions = [p[0] for p in self.points]
        if positions != sorted(positions):
            raise ValueError(f"point gradients must be non-decreasing, got {positions}")
        return self

    def __call__(self, fraction) -> np.ndarray:
        """The opacity factor at gradient fractions (any shape), clamped to [0, 1]."""
        table = np.asarray(self.points, dtype=np.float64)
        x = np.clip(np.asarray(fraction, dtype=np.float64), 0.0, 1.0)
        return np.interp(x, table[:, 0], table[:, 1])

    def lut(self, size: int = LUT_SIZE) -> np.ndarray:
        """(size,) float32; entry i is the factor at gradient fraction i / (size - 1)."""
        return self(np.linspace(0.0, 1.0, size)).astype(np.float32)


PRESETS: dict[str, GradientOpacity] = {
    # Homogeneous regions fade out, boundaries keep their opacity.
    "boundaries": GradientOpacity(points=[(0.0, 0.0), (0.15, 1.0), (1.0, 1.0)]),
    # Only the strongest edges (bone against air in CT, a surface of an implicit function).
    "strong-edges": GradientOpacity(points=[(0.0, 0.0), (0.3, 0.0), (0.6, 1.0), (1.0, 1.0)]),
}


def preset(value):
    """A preset's model for its name; any other value unchanged (for the property's validation)."""
    if isinstance(value, str):
        if value not in PRESETS:
            raise ValueError(f"{value!r} is not a gradient-opacity preset ({', '.join(PRESETS)})")
        return PRESETS[value]
    return value
