"""1D transfer functions: piecewise-linear RGBA over normalised intensity.

JSON form: ``{"points": [[position, r, g, b, a], ...]}``, position in [0, 1] of the volume's value
range, colour in [0, 1], and ``a`` the opacity of one sample at sampling rate 1 (one sample per
voxel); renderers correct it for other step lengths. Below the first point and above the last the
end values hold. Sampled into a 4096-entry float LUT (Inácio 2009) for the GPU and the CPU reference.
``TransferFunction.save``/``load`` write and read that JSON as a file; ``PRESETS`` are named starting
points for CT, MRI and implicit-surface (SDF) volumes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from vgraph.atomic import write_text_atomic
from vgraph.errors import VGraphError

LUT_SIZE = 4096

Point = tuple[float, float, float, float, float]


class TransferFunction(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    points: list[Point] = Field(min_length=1)

    @field_validator("points", mode="before")
    @classmethod
    def _check_lengths(cls, points):
        # Said here in words: pydantic alone would report "points.0.4: Field required".
        for index, point in enumerate(points if isinstance(points, (list, tuple)) else []):
            if isinstance(point, (list, tuple)) and len(point) != 5:
                raise ValueError(f"point {index} needs 5 numbers [position, r, g, b, a], got {list(point)}")
        return points

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

    @classmethod
    def load(cls, path: str | Path) -> "TransferFunction":
        """Read ``{"points": [...]}``; VGraphError naming the file and the problem otherwise."""
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except OSError as error:
            raise VGraphError(f"{path}: cannot read the transfer function: {error.strerror or error}") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as error:
            raise VGraphError(f"{path}: not valid JSON: {error}") from None
        try:
            return cls.model_validate(data)
        except ValidationError as error:
            reasons = "; ".join(f"{'.'.join(map(str, e['loc'])) or '(top level)'}: {e['msg']}"
                                for e in error.errors())
            raise VGraphError(f"{path}: not a transfer function: {reasons}") from None

    def save(self, path: str | Path) -> None:
        """Write the JSON form atomically (a failed write leaves an existing file as it was)."""
        points = [[float(v) for v in point] for point in self.points]  # repr floats: exact round trip
        text = '{"points": [\n' + ",\n".join("  " + json.dumps(p) for p in points) + "\n]}\n"
        write_text_atomic(path, text)

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


def _tf(*points) -> TransferFunction:
    return TransferFunction(points=list(points))


# Named starting points, positions in normalised intensity. The CT ones follow Inácio 2009 fig. 4.4:
# similar colours, opacity makes the difference, and a dark tone just below the structure keeps an
# unshaded rendering from looking like a flat silhouette.
PRESETS: dict[str, TransferFunction] = {
    "grayscale ramp": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0, 1.0)),
    "bone (CT)": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (0.42, 0.25, 0.12, 0.08, 0.0),
                     (0.5, 0.55, 0.4, 0.3, 0.25), (0.7, 0.95, 0.9, 0.8, 0.8), (1.0, 1.0, 1.0, 1.0, 0.95)),
    "soft tissue (CT)": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (0.12, 0.35, 0.12, 0.08, 0.0),
                            (0.22, 0.85, 0.5, 0.4, 0.04), (0.38, 0.9, 0.65, 0.55, 0.04),
                            (0.48, 0.95, 0.9, 0.85, 0.5), (1.0, 1.0, 1.0, 1.0, 0.8)),
    "brain (MRI)": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (0.18, 0.2, 0.2, 0.35, 0.0),
                       (0.35, 0.55, 0.55, 0.8, 0.03), (0.6, 0.95, 0.8, 0.7, 0.15), (1.0, 1.0, 1.0, 0.9, 0.5)),
    "hot metal": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (0.33, 0.75, 0.0, 0.0, 0.1),
                     (0.66, 1.0, 0.8, 0.0, 0.4), (1.0, 1.0, 1.0, 1.0, 0.8)),
    "rainbow": _tf((0.0, 0.25, 0.0, 0.6, 0.0), (0.25, 0.0, 0.4, 1.0, 0.1), (0.5, 0.0, 0.8, 0.2, 0.2),
                   (0.75, 1.0, 0.8, 0.0, 0.4), (1.0, 0.9, 0.0, 0.0, 0.6)),
    # Implicit surfaces: an opaque shell around the default iso level 0.5, empty elsewhere.
    "iso shell (SDF)": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (0.46, 0.2, 0.5, 0.9, 0.0),
                           (0.5, 0.9, 0.95, 1.0, 0.9), (0.54, 0.2, 0.5, 0.9, 0.0), (1.0, 0.0, 0.0, 0.0, 0.0)),
}
