"""Label volumes: the label table (a colour, opacity and visibility per integer label) and the
majority-of-interpolation-weights rule that reconstructs labels between voxels.

Conventions (docs/guide/exploring.md shows them with pictures):
- A label volume holds integer labels (any integer dtype, or floats whose values are all whole
  numbers); ``label_codes`` refuses anything else, naming the consumer.
- ``LabelTable``: ``labels`` lists entries (value, name, RGB colour, opacity, visible). A label the
  table does not list is "unlisted": with ``unlisted = "palette"`` it gets the colour
  ``palette_color(value)`` (a fixed list of distinct colours, repeating every PALETTE_SIZE labels)
  and ``unlisted_opacity``; with ``"hidden"`` it is not drawn. The default table lists label 0 as
  hidden background and draws every other label from the palette, opaque.
- A label is *shown* when it is visible with opacity > 0; all other labels (hidden ones, label 0
  by default, unlisted ones under "hidden") are one class, the background.
- Majority rule: at a sample point, the 8 voxels whose centres surround it vote with their
  trilinear weights (a point outside the box of the voxel centres is first clamped onto it: the
  weights of clamp-to-edge filtering); each class sums the weights of its voxels and the class
  with the largest sum wins; on a tie, the smaller label value wins and the background loses to
  any label. So labels never blend as
  numbers (1 and 3 never make a 2), and between two labels the boundary is where their weight sums
  tie: half-way between the voxel centres for two touching blocks, a smooth surface in general
  (for one label against background it is the 0.5 iso-surface of its trilinear indicator).
- Codes: the labels as they go to the GPU. Volumes whose labels lie in [0, 65535] are uploaded as
  they are (code = label); others are renumbered by their sorted distinct values (code = rank),
  which keeps the order and therefore the tie rule. ``LabelCodes.values[code]`` is the label.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from vgraph.errors import VGraphError

# A colour list of well-separated hues (Kelly's 22 colours of maximum contrast, without white and
# black, which are the background's), in the order Kelly gives: neighbouring labels differ most.
PALETTE = np.array([
    (0xF3, 0xC3, 0x00), (0x87, 0x56, 0x92), (0xF3, 0x84, 0x00), (0xA1, 0xCA, 0xF1), (0xBE, 0x00, 0x32),
    (0xC2, 0xB2, 0x80), (0x84, 0x84, 0x82), (0x00, 0x88, 0x56), (0xE6, 0x8F, 0xAC), (0x00, 0x67, 0xA5),
    (0xF9, 0x93, 0x79), (0x60, 0x4E, 0x97), (0xF6, 0xA6, 0x00), (0xB3, 0x44, 0x6C), (0xDC, 0xD3, 0x00),
    (0x88, 0x2D, 0x17), (0x8D, 0xB6, 0x00), (0x65, 0x45, 0x22), (0xE2, 0x58, 0x22), (0x2B, 0x3D, 0x26),
], dtype=np.float64) / 255.0
PALETTE_SIZE = len(PALETTE)
DIRECT_CODES = 65535  # labels in [0, DIRECT_CODES] go to the GPU unchanged

_Channel = Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)]


def palette_color(value: int) -> tuple[float, float, float]:
    """The palette colour of an unlisted label: label 1 the first colour, label 2 the second, ...
    (label 0 and negative labels too, by the value modulo the palette's size)."""
    return tuple(float(c) for c in PALETTE[(int(value) - 1) % PALETTE_SIZE])


class LabelEntry(BaseModel):
    """One row of the label table."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    value: int = Field(ge=-2**63, le=2**63 - 1)
    name: str = ""
    color: tuple[_Channel, _Channel, _Channel] = (1.0, 1.0, 1.0)
    opacity: _Channel = 1.0
    visible: bool = True

    @property
    def shown(self) -> bool:
        return self.visible and self.opacity > 0.0


def _unique_values(entries: tuple[LabelEntry, ...]) -> tuple[LabelEntry, ...]:
    seen = set()
    for entry in entries:
        if entry.value in seen:
            raise ValueError(f"label {entry.value} is listed twice; each label value once")
        seen.add(entry.value)
    return entries


class LabelTable(BaseModel):
    """What each label looks like (see the module docstring)."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    labels: Annotated[tuple[LabelEntry, ...], AfterValidator(_unique_values)] = ()
    unlisted: Literal["palette", "hidden"] = "palette"
    unlisted_opacity: _Channel = 1.0

    @classmethod
    def default(cls) -> "LabelTable":
        return cls(labels=(LabelEntry(value=0, name="background", color=(0.0, 0.0, 0.0), opacity=0.0,
                                      visible=False),))

    def with_entry(self, entry: LabelEntry) -> "LabelTable":
        """A copy with ``entry`` replacing the row of its value (or added, rows kept sorted)."""
        rows = [row for row in self.labels if row.value != entry.value] + [entry]
        return self.model_copy(update={"labels": tuple(sorted(rows, key=lambda row: row.value))})

    def colors(self, values: np.ndarray) -> np.ndarray:
        """RGBA (float32) per label value: rgb its colour, a its opacity where the label is shown
        and 0 where it is background. Vectorised over the unlisted labels."""
        values = np.asarray(values, dtype=np.int64)
        rgba = np.zeros((values.size, 4), dtype=np.float32)
        if self.unlisted == "palette":
            rgba[:, :3] = PALETTE[(values - 1) % PALETTE_SIZE]
            rgba[:, 3] = self.unlisted_opacity
        listed = {entry.value: entry for entry in self.labels}
        if listed:
            where = np.flatnonzero(np.isin(values, np.fromiter(listed, dtype=np.int64)))
            for index in where:
                entry = listed[int(values[index])]
                rgba[index] = (*entry.color, entry.opacity if entry.shown else 0.0)
        return rgba


class LabelCodes:
    """A label volume as GPU codes (see the module docstring): ``codes`` [z, y, x] uint16 or
    uint32, ``values[code]`` the label of each code."""

    def __init__(self, codes: np.ndarray, values: np.ndarray):
        self.codes, self.values = codes, values

    def classes(self, table: LabelTable) -> np.ndarray:
        """Per code: the code where its label is shown, else BACKGROUND (int64)."""
        shown = table.colors(self.values)[:, 3] > 0.0
        return np.where(shown, np.arange(self.values.size), BACKGROUND)


BACKGROUND = np.iinfo(np.int64).max  # the class of all labels that are not shown: loses every tie


def label_codes(data: np.ndarray, consumer: str) -> LabelCodes:
    """The codes of a label array, or VGraphError naming ``consumer`` when it holds no labels."""
    if data.dtype.kind == "f":
        data = _whole_numbers(data, consumer)
    elif data.dtype.kind not in "iu":
        raise VGraphError(f"{consumer}: a label volume needs integer labels, not {data.dtype} data")
    if data.size == 0:
        raise VGraphError(f"{consumer}: the label volume is empty")
    low, high = int(data.min()), int(data.max())
    if high > np.iinfo(np.int64).max:
        raise VGraphError(f"{consumer}: label values must fit a 64-bit signed integer, got {high}")
    if low >= 0 and high <= DIRECT_CODES:
        return LabelCodes(data.astype(np.uint16, copy=False), np.arange(high + 1, dtype=np.int64))
    values, inverse = np.unique(data, return_inverse=True)
    dtype = np.uint16 if values.size <= DIRECT_CODES + 1 else np.uint32
    return LabelCodes(inverse.reshape(data.shape).astype(dtype), values.astype(np.int64))


def _whole_numbers(data: np.ndarray, consumer: str) -> np.ndarray:
    finite = np.isfinite(data)
    if not finite.all():
        z, y, x = np.argwhere(~finite)[0]
        raise VGraphError(f"{consumer}: label volumes need integer labels; voxel (x={x}, y={y}, "
                          f"z={z}) is {float(data[z, y, x])}")
    fractional = data != np.round(data)
    if fractional.any():
        z, y, x = np.argwhere(fractional)[0]
        raise VGraphError(f"{consumer}: label volumes need integer labels, but this {data.dtype} volume "
                          f"has fractional values, e.g. {float(data[z, y, x])!r} at voxel (x={x}, y={y}, z={z}); "
                          f"round or cast it to an integer type first")
    if np.abs(data).max() >= 2.0**63:
        raise VGraphError(f"{consumer}: label values must fit a 64-bit integer, got up to {np.abs(data).max()}")
    return data.astype(np.int64)


# --- the majority rule (the CPU reference of shaders/labels/majority.glsl) ----------------------
CORNERS = np.array([(c & 1, (c >> 1) & 1, (c >> 2) & 1) for c in range(8)])  # (x, y, z) offsets


def majority(classes: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The majority rule at texture coordinates ``points`` (N, 3), (x, y, z) in [0, 1]: the winning
    class per point, its weight sum, and the shading normal per voxel step (x, y, z): where the 8
    voxels include background, the gradient of the weight sum of all shown classes together (their
    outer surface: no seam where two labels touch), else the gradient of the winner's sum (its
    boundary with another label). ``classes`` [z, y, x] holds each voxel's class
    (LabelCodes.classes()[codes])."""
    dims = np.array(classes.shape[::-1])
    p = np.clip(np.asarray(points, dtype=np.float64) * dims - 0.5, 0, dims - 1)  # into the box (the shader's why)
    base = np.clip(np.floor(p), 0, np.maximum(dims - 2, 0))
    f = p - base
    base = base.astype(np.int64)
    votes = np.empty((8, len(p)), dtype=np.int64)
    weights = np.empty((8, len(p)))
    slopes = np.empty((8, len(p), 3))
    for c, offset in enumerate(CORNERS):
        voxel = np.clip(base + offset, 0, dims - 1)
        votes[c] = classes[voxel[:, 2], voxel[:, 1], voxel[:, 0]]
        axis = np.where(offset == 1, f, 1.0 - f)   # per-axis weights of this corner
        weights[c] = axis.prod(axis=1)
        sign = offset * 2 - 1
        slopes[c] = sign * np.stack([axis[:, 1] * axis[:, 2], axis[:, 0] * axis[:, 2],
                                     axis[:, 0] * axis[:, 1]], axis=1)
    same = votes[:, None, :] == votes[None, :, :]          # [c, d, n]
    sums = (same * weights[None, :, :]).sum(axis=1)        # each corner's class total
    # Largest sum first, then the smaller class: lexsort's last key is the primary one.
    order = np.lexsort((votes, -sums), axis=0)[0]
    columns = np.arange(len(p))
    winner = votes[order, columns]
    member = votes == winner[None, :]
    gradient = (member[:, :, None] * slopes).sum(axis=0)
    background = votes == BACKGROUND
    surface = (~background[:, :, None] * slopes).sum(axis=0)
    normal = np.where(background.any(axis=0)[:, None], surface, gradient)
    return winner, sums[order, columns], normal
