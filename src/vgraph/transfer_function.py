"""1D transfer functions: piecewise-linear RGBA over normalised intensity.

JSON form: ``{"points": [[position, r, g, b, a], ...]}``, position in [0, 1] of the volume's value
range, colour in [0, 1], and ``a`` the opacity of one sample at sampling rate 1 (one sample per
voxel); renderers correct it for other step lengths. Below the first point and above the last the
end values hold. Sampled into a 4096-entry float LUT (seed 000) for the GPU and the CPU reference.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

LUT_SIZE = 4096

Point = tuple[float, float, float, float, float]


class TransferFunction(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    points: list[Point] = Field(min_length=1)

    @field_validator("points")
    @classmethod
    def _check_points(cls, points: list[Point]) -> list[Point]:
        for index, point in enumerate(points):
            if not all(np.isfinite(point)):
                raise ValueError(f"point {index} has a non-finite number: {list(point)}")
            if not all(0.0 <= v <= 1.0 for v in point):
                raise ValueError(f"point {index} must have position, r, g, b, a in [0, 1]: {list(point)}")
        positions = [p[0] for p in points]
        if positions != sorted(positions):
            raise ValueError(f"point positions must be non-decreasing, got {positions}")
        return points

    @classmethod
    def ramp(cls, low: float, high: float, color=(1.0, 1.0, 1.0), opacity: float = 1.0):
        """Transparent below ``low``, rising linearly to ``opacity`` at ``high``."""
        r, g, b = color
        return cls(points=[(low, r, g, b, 0.0), (high, r, g, b, opacity)])

    def lut(self, size: int = LUT_SIZE) -> np.ndarray:
        """(size, 4) float32 RGBA; entry i is the TF at normalised intensity i / (size - 1)."""
        table = np.asarray(self.points, dtype=np.float64)
        x = np.linspace(0.0, 1.0, size)
        # np.interp needs strictly increasing positions; a step (two points at one position) is
        # kept by nudging the second one up by an amount far below one LUT entry.
        positions = table[:, 0] + np.arange(len(table)) * 1e-12
        channels = [np.interp(x, positions, table[:, c]) for c in range(1, 5)]
        return np.stack(channels, axis=1).astype(np.float32)

    def __call__(self, intensity) -> np.ndarray:
        """Exact RGBA at normalised intensities (any shape) -> shape + (4,)."""
        table = np.asarray(self.points, dtype=np.float64)
        positions = table[:, 0] + np.arange(len(table)) * 1e-12
        x = np.clip(np.asarray(intensity, dtype=np.float64), 0.0, 1.0)
        return np.stack([np.interp(x, positions, table[:, c]) for c in range(1, 5)], axis=-1)
