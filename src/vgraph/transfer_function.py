"""1D transfer functions: piecewise-linear RGBA over a volume's values.

JSON form: ``{"space": "normalized", "points": [[position, r, g, b, a], ...]}``, colour in [0, 1]
and ``a`` the opacity of one sample at sampling rate 1 (one sample per voxel); renderers correct it
for other step lengths. ``space`` says what a position means (Inviwo's relative and absolute TFs,
ParaView's data-range presets):

- ``normalized`` (the default, and the only one a file may omit ``space`` for): a fraction in
  [0, 1] of the volume's value range (Volume.value_range: min..max, a declared range or the
  VolumeSource window), so one TF fits any data scaled alike;
- ``data``: a value in the volume's own units (Hounsfield units for CT), so "bone at 300 HU"
  means that on every CT;
- ``percentile``: a percentage in [0, 100] of the volume's finite voxels (Volume.percentiles),
  for data without absolute units such as MRI.

``tf_shift`` and ``tf_scale`` (data units; defaults 0 and 1, written to JSON only when set) move
the points without editing them, as 3D Slicer's preset Shift slider: a point whose position is the
data value x sits at ``x * tf_scale + tf_shift``. The pivot of the scale is the data value 0, not the
TF's centre, so the pair is exactly a linear change of units: a preset in Hounsfield units fits
data stored as ``HU * slope + intercept`` with ``tf_scale=slope, tf_shift=intercept``, and 0 (water
in CT, no signal in MRI) stays where it is; the TF's centre would differ from preset to preset.
Normalised and percentile positions are turned into data values first (through the volume's value
range or percentiles), so the shift means the same in every space.

The short form ``{"preset": NAME_OR_FILE, "tf_shift": 150}`` is that preset (or TF file) moved;
it is stored, and saved, as the TF itself with its shift.

Below the first point and above the last the end values hold. Renderers work on
``for_volume(volume)``: the same TF with normalised positions for that volume's value range,
clipped to [0, 1], sampled into a 4096-entry float LUT (Inácio 2009). ``PRESETS`` are named starting
points; a transfer-function property also accepts a preset's name or a TF file's path as its value
(``properties.TransferFunctionProperty``). ``save``/``load`` write and read the JSON form.
"""

from __future__ import annotations

import json
import os
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import (BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator,
                      model_serializer, model_validator)

from vgraph.atomic import write_text_atomic
from vgraph.errors import VGraphError
from vgraph.file_names import expanded, file_name_problem, shown
from vgraph.json_limits import MAX_NESTING, nesting_depth

LUT_SIZE = 4096
MAX_MOVE = 1e30     # |tf_shift| and tf_scale: a data position (at most 1e30) moved stays finite
MOVE_DEFAULTS = {"tf_shift": 0.0, "tf_scale": 1.0}
MAX_FILE_BYTES = 16 * 2**20  # 300 000 points; the shipped presets are a few hundred bytes

Point = tuple[float, float, float, float, float]


Space = Literal["normalized", "data", "percentile"]
POSITION_LIMITS = {"normalized": (0.0, 1.0), "percentile": (0.0, 100.0), "data": (-1e30, 1e30)}


class TransferFunction(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    space: Space = "normalized"
    points: list[Point] = Field(min_length=1)
    # Bounded so that a data position (at most 1e30) moved stays a finite float64.
    tf_shift: float = Field(0.0, ge=-MAX_MOVE, le=MAX_MOVE, allow_inf_nan=False)
    tf_scale: float = Field(1.0, gt=0.0, le=MAX_MOVE, allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _preset_moved(cls, data, info: ValidationInfo):
        # {"preset": ..., "tf_shift": ...}: the short form a network file or --set may give.
        if isinstance(data, dict) and "preset" in data:
            return moved_preset(data, (info.context or {}).get("base_dir"))
        return data

    @field_validator("tf_shift", "tf_scale", mode="before")
    @classmethod
    def _not_bool(cls, value):
        if isinstance(value, bool):
            raise ValueError("expected a number, not a boolean")
        return value

    @model_serializer(mode="wrap")
    def _without_default_moves(self, handler):
        # Files saved before the shift existed, and TFs that do not use it, keep their exact form.
        data = handler(self)
        for name, default in MOVE_DEFAULTS.items():
            if data.get(name) == default:
                del data[name]
        return data

    @property
    def is_moved(self) -> bool:
        """Whether tf_shift or tf_scale differs from its default."""
        return self.tf_shift != 0.0 or self.tf_scale != 1.0

    def moved(self, values) -> np.ndarray:
        """Data values of the points -> where they sit: ``x * tf_scale + tf_shift``."""
        return np.asarray(values, dtype=np.float64) * self.tf_scale + self.tf_shift

    def unmoved(self, values) -> np.ndarray:
        """The inverse of ``moved``: where a point must be written to sit at these data values."""
        return (np.asarray(values, dtype=np.float64) - self.tf_shift) / self.tf_scale

    @field_validator("points", mode="before")
    @classmethod
    def _check_lengths(cls, points):
        # Said here in words: pydantic alone would report "points.0.4: Field required".
        for index, point in enumerate(points if isinstance(points, (list, tuple)) else []):
            if isinstance(point, (list, tuple)) and len(point) != 5:
                raise ValueError(f"point {index} needs 5 numbers [position, r, g, b, a], got {list(point)}")
        return points

    @model_validator(mode="after")
    def _check_points(self) -> "TransferFunction":
        low, high = POSITION_LIMITS[self.space]
        for index, point in enumerate(self.points):
            if not all(np.isfinite(point)):
                raise ValueError(f"point {index} has a non-finite number: {list(point)}")
            if not all(0.0 <= v <= 1.0 for v in point[1:]):
                raise ValueError(f"point {index} must have r, g, b, a in [0, 1]: {list(point)}")
            if not low <= point[0] <= high:
                raise ValueError(f"point {index}: a {self.space} position must lie in "
                                 f"[{low:g}, {high:g}], got {point[0]}")
        positions = [p[0] for p in self.points]
        if positions != sorted(positions):
            raise ValueError(f"point positions must be non-decreasing, got {positions}")
        return self

    def for_volume(self, volume) -> "TransferFunction":
        """This TF with normalised positions for ``volume``'s value range (itself if normalised):
        data values and percentiles are mapped through the range, and the part outside [0, 1] is
        cut off with the TF's values at 0 and 1 as new end points."""
        if self.space == "percentile":
            positions = np.array([p[0] for p in self.points])
            return self._placed(np.asarray(volume.percentiles(positions), dtype=np.float64),
                                volume.value_range)
        return self.over_range(*volume.value_range)

    def over_range(self, low: float, high: float) -> "TransferFunction":
        """This TF with normalised positions for the value range [low, high] (itself if normalised
        and not moved); ValueError for percentiles, which need the volume's values."""
        if self.space == "normalized" and not self.is_moved:
            return self
        if self.space == "percentile":
            raise ValueError("a transfer function in percentiles needs the volume's values: "
                             "use tf.for_volume(volume)")
        positions = np.array([p[0] for p in self.points])
        if self.space == "normalized":
            positions = low + positions * (high - low)
        return self._placed(positions, (low, high))

    def _placed(self, values: np.ndarray, value_range) -> "TransferFunction":
        """The normalised TF with our points at these data values, moved by tf_shift/tf_scale."""
        low, high = value_range
        if self.is_moved:  # unmoved TFs skip the arithmetic: their LUTs stay the same bit for bit
            values = self.moved(values)
        return self.normalized_at((values - low) / (high - low))

    def normalized_at(self, positions) -> "TransferFunction":
        """A normalised TF with our points' colours at these normalised positions (one per point,
        non-decreasing, any real number), cut to [0, 1]."""
        table = np.asarray(self.points, dtype=np.float64)
        table[:, 0] = np.maximum.accumulate(np.asarray(positions, dtype=np.float64))  # rounding must not unsort them
        ends = _interpolate(table, np.array([0.0, 1.0]))
        inside = table[(table[:, 0] > 0.0) & (table[:, 0] < 1.0)]
        points = [(0.0, *ends[0]), *map(tuple, inside), (1.0, *ends[1])]
        return TransferFunction(points=[tuple(float(v) for v in p) for p in points])

    @classmethod
    def ramp(cls, low: float, high: float, color=(1.0, 1.0, 1.0), opacity: float = 1.0):
        """Transparent below ``low``, rising linearly to ``opacity`` at ``high``."""
        r, g, b = color
        return cls(points=[(low, r, g, b, 0.0), (high, r, g, b, opacity)])

    @classmethod
    def load(cls, path: str | Path) -> "TransferFunction":
        """Read the JSON form; VGraphError naming the file and the problem otherwise. Only a
        regular file of at most MAX_FILE_BYTES, nested at most MAX_NESTING deep, is read."""
        path = Path(path)
        too_deep = VGraphError(f"{path}: nested more than {MAX_NESTING} levels deep")
        try:
            data = json.loads(_read_bounded(path))
        except OSError as error:
            raise VGraphError(f"{path}: cannot read the transfer function: {error.strerror or error}") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as error:
            raise VGraphError(f"{path}: not valid JSON: {error}") from None
        except RecursionError:  # deeper than Python's stack, so far deeper than the limit
            raise too_deep from None
        if nesting_depth(data) > MAX_NESTING:
            raise too_deep
        try:
            return cls.model_validate(data)
        except ValidationError as error:
            reasons = "; ".join(f"{'.'.join(map(str, e['loc'])) or '(top level)'}: {e['msg']}"
                                for e in error.errors())
            raise VGraphError(f"{path}: not a transfer function: {reasons}") from None

    def save(self, path: str | Path) -> None:
        """Write the JSON form atomically (a failed write leaves an existing file as it was)."""
        points = [[float(v) for v in point] for point in self.points]  # repr floats: exact round trip
        space = "" if self.space == "normalized" else f'"space": "{self.space}", '
        moves = "".join(f', "{name}": {float(getattr(self, name))!r}' for name, default in MOVE_DEFAULTS.items()
                        if getattr(self, name) != default)
        text = ("{" + space + '"points": [\n' + ",\n".join("  " + json.dumps(p) for p in points) + "\n]"
                + moves + "}\n")
        write_text_atomic(path, text)

    def lut(self, size: int = LUT_SIZE) -> np.ndarray:
        """(size, 4) float32 RGBA; entry i is the TF at normalised intensity i / (size - 1)."""
        return self(np.linspace(0.0, 1.0, size)).astype(np.float32)

    def __call__(self, intensity) -> np.ndarray:
        """Exact RGBA at normalised intensities (any shape) -> shape + (4,)."""
        self._require_normalized()
        x = np.clip(np.asarray(intensity, dtype=np.float64), 0.0, 1.0)
        return _interpolate(np.asarray(self.points, dtype=np.float64), x)

    def _require_normalized(self) -> None:
        if self.space != "normalized":
            raise ValueError(f"this transfer function's positions are {self.space} values: "
                             f"use tf.for_volume(volume) to evaluate it for a volume")
        if self.is_moved:
            raise ValueError("this transfer function is shifted or scaled in data units: "
                             "use tf.for_volume(volume) to evaluate it for a volume")

    @property
    def needs_volume(self) -> bool:
        """Whether evaluating this TF needs a volume's value range (``for_volume``)."""
        return self.space != "normalized" or self.is_moved


@dataclass(frozen=True)
class ValueScale:
    """A volume's values as an editor needs them to show a TF in data units or percentiles over
    the histogram's normalised axis: the value range and the data values at 0, 1, ..., 100 %."""

    value_range: tuple[float, float]
    percentiles: tuple[float, ...]

    @classmethod
    def of(cls, volume) -> "ValueScale":
        table = np.asarray(volume.percentiles(np.arange(101.0)), dtype=np.float64)
        return cls(tuple(map(float, volume.value_range)), tuple(map(float, table)))

    def to_normalized(self, positions, space: Space) -> np.ndarray:
        positions = np.asarray(positions, dtype=np.float64)
        if space == "normalized":
            return positions
        if space == "percentile":
            positions = np.interp(positions, np.arange(101.0), self.percentiles)
        low, high = self.value_range
        return (positions - low) / (high - low)

    def from_normalized(self, x, space: Space) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        if space == "normalized":
            return x
        low, high = self.value_range
        values = low + x * (high - low)
        if space == "data":
            return values
        return np.interp(values, self.percentiles, np.arange(101.0))

    def to_data(self, positions, space: Space) -> np.ndarray:
        """Positions in ``space`` -> data values (where tf_shift and tf_scale act)."""
        positions = np.asarray(positions, dtype=np.float64)
        if space == "data":
            return positions
        if space == "percentile":
            return np.interp(positions, np.arange(101.0), self.percentiles)
        low, high = self.value_range
        return low + positions * (high - low)

    def from_data(self, values, space: Space) -> np.ndarray:
        """Data values -> positions in ``space``, the inverse of ``to_data``."""
        values = np.asarray(values, dtype=np.float64)
        if space == "data":
            return values
        if space == "percentile":
            return np.interp(values, self.percentiles, np.arange(101.0))
        low, high = self.value_range
        return (values - low) / (high - low)


def _interpolate(table: np.ndarray, x: np.ndarray) -> np.ndarray:
    """RGBA of the piecewise-linear table [position, r, g, b, a] at positions x."""
    # np.interp needs strictly increasing positions; a step (two points at one position) is
    # kept by nudging the second one up by an amount far below one LUT entry.
    positions = table[:, 0].copy()
    for i in range(1, len(positions)):
        if positions[i] <= positions[i - 1]:
            positions[i] = positions[i - 1] + 1e-12 * max(1.0, abs(positions[i - 1]))
    return np.stack([np.interp(x, positions, table[:, c]) for c in range(1, 5)], axis=-1)


def _tf(*points) -> TransferFunction:
    return TransferFunction(points=list(points))


def _data(*points) -> TransferFunction:
    return TransferFunction(space="data", points=list(points))


def _percentile(*points) -> TransferFunction:
    return TransferFunction(space="percentile", points=list(points))


# Named starting points. The CT ones are in Hounsfield units (air -1000, fat about -100, soft tissue
# 20-80, bone from about 300) and follow Inácio 2009 fig. 4.4: similar colours, opacity makes the
# difference, and a dark tone just below the structure keeps an unshaded rendering from looking
# like a flat silhouette. MRI has no absolute unit, so its preset is placed by percentiles (about
# half of a head scan's voxels are background), as is "auto", the first look at unknown data.
PRESETS: dict[str, TransferFunction] = {
    # Any data set, units unknown: the densest 40 % of the voxels, opaque only in the top percent.
    "auto": _percentile((0.0, 0.0, 0.0, 0.0, 0.0), (60.0, 0.3, 0.15, 0.1, 0.0),
                        (90.0, 0.85, 0.6, 0.45, 0.08), (99.0, 1.0, 0.95, 0.9, 0.6),
                        (100.0, 1.0, 1.0, 1.0, 0.9)),
    "grayscale": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0, 1.0)),
    "ct-bone": _data((-1000.0, 0.0, 0.0, 0.0, 0.0), (150.0, 0.25, 0.12, 0.08, 0.0),
                     (300.0, 0.55, 0.4, 0.3, 0.25), (700.0, 0.95, 0.9, 0.8, 0.8),
                     (3000.0, 1.0, 1.0, 1.0, 0.95)),
    "ct-soft-tissue": _data((-1000.0, 0.0, 0.0, 0.0, 0.0), (-300.0, 0.35, 0.12, 0.08, 0.0),
                            (-50.0, 0.85, 0.5, 0.4, 0.04), (80.0, 0.9, 0.65, 0.55, 0.04),
                            (300.0, 0.95, 0.9, 0.85, 0.5), (3000.0, 1.0, 1.0, 1.0, 0.8)),
    "mri-brain": _percentile((0.0, 0.0, 0.0, 0.0, 0.0), (50.0, 0.2, 0.2, 0.35, 0.0),
                             (75.0, 0.55, 0.55, 0.8, 0.03), (95.0, 0.95, 0.8, 0.7, 0.15),
                             (100.0, 1.0, 1.0, 0.9, 0.5)),
    "hot-metal": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (0.33, 0.75, 0.0, 0.0, 0.1),
                     (0.66, 1.0, 0.8, 0.0, 0.4), (1.0, 1.0, 1.0, 1.0, 0.8)),
    "rainbow": _tf((0.0, 0.25, 0.0, 0.6, 0.0), (0.25, 0.0, 0.4, 1.0, 0.1), (0.5, 0.0, 0.8, 0.2, 0.2),
                   (0.75, 1.0, 0.8, 0.0, 0.4), (1.0, 0.9, 0.0, 0.0, 0.6)),
    # Implicit surfaces: an opaque shell around the default iso level 0.5, empty elsewhere.
    "sdf-iso-shell": _tf((0.0, 0.0, 0.0, 0.0, 0.0), (0.46, 0.2, 0.5, 0.9, 0.0),
                         (0.5, 0.9, 0.95, 1.0, 0.9), (0.54, 0.2, 0.5, 0.9, 0.0), (1.0, 0.0, 0.0, 0.0, 0.0)),
}


def _read_bounded(path: Path) -> str:
    """The text of a TF file, refused unless a regular file of at most MAX_FILE_BYTES (a FIFO
    would block, /dev/zero never end)."""
    with os.fdopen(os.open(path, os.O_RDONLY | os.O_NONBLOCK), "rb") as file:  # a FIFO: no wait
        if not stat.S_ISREG(os.fstat(file.fileno()).st_mode):
            raise VGraphError(f"{path}: not a regular file")
        data = file.read(MAX_FILE_BYTES + 1)
    if len(data) > MAX_FILE_BYTES:
        raise VGraphError(f"{path}: larger than a transfer-function file can be ({MAX_FILE_BYTES} bytes)")
    return data.decode("utf-8")


def preset_or_file(text: str, base_dir: str | Path | None = None) -> TransferFunction:
    """The preset named ``text``, or the TF in the file at that path (relative to ``base_dir``
    if given, else to the current folder); ValueError saying which it is neither."""
    if text in PRESETS:
        return PRESETS[text]
    neither = f"{shown(text)} is neither a preset ({', '.join(PRESETS)}) nor a transfer-function file"
    problem = file_name_problem(text)
    if problem is not None:  # before the system sees it: it would raise, not answer
        raise ValueError(f"{neither}: {problem}")
    path = expanded(text)
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    if not os.path.isfile(path):  # False for what cannot be a file (too long with base_dir)
        raise ValueError(neither)
    try:
        return TransferFunction.load(path)
    except VGraphError as error:
        raise ValueError(str(error)) from None


def moved_preset(value: dict, base_dir: str | Path | None = None) -> dict:
    """``{"preset": NAME_OR_FILE, "tf_shift": s, "tf_scale": k}`` (the short form a network file or
    ``--set`` may give) as the JSON form of that TF moved, for the caller to validate (so a bad
    shift is reported under its own name); ValueError for another key or an unknown preset."""
    unknown = sorted(set(value) - {"preset", *MOVE_DEFAULTS})
    if unknown:
        raise ValueError(f"a preset with a shift has the keys preset, tf_shift and tf_scale, "
                         f"not {', '.join(map(repr, unknown))}")
    if not isinstance(value["preset"], str):
        raise ValueError(f"'preset' must be a preset's name or a file's path, got {value['preset']!r}")
    base = preset_or_file(value["preset"], base_dir)
    return {"space": base.space, "points": base.points,
            **{name: value.get(name, getattr(base, name)) for name in MOVE_DEFAULTS}}
