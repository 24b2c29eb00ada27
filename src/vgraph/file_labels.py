"""A volume file's labels: whether its voxels are labels rather than intensities, which label
values it holds, and a colour for each that no other label of the volume shares.

Labels are either declared (``Volume.holds_labels``, set by the readers from the header:
vgraph.io.label_hints) or guessed from the values by this rule, which real label maps meet and
real intensity scans do not:

    integer data type, 2 to MAX_GUESSED_LABELS (64) distinct values, and at least half of the
    distinct values have a neighbour (value - 1 or value + 1) that occurs too.

Why each part: label maps are stored as integers (a float volume is a measurement, even with few
values); they hold tens of labels at most (a 29-tissue frog, FreeSurfer's ~45 aseg structures)
while an 8- or 16-bit scan holds hundreds to thousands of distinct values (the shared data sets:
255 to 2987); and labels are numbered mostly consecutively (0..28; aseg's 2, 4, 5, 7, 8, 10..18,
...), while a coarsely quantised scan with few values has them evenly spaced apart: the CTA of a
stent holds 33 values in steps of about 62 (none with a neighbour), which the count alone would
take for labels. A two-valued 0/1 mask counts as labels, a 0/255 one as intensities.

Counting stops early: a strided sample of the voxels with more than 64 values already rules the
guess out (the common case of an intensity scan), without counting the whole volume.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass

import numpy as np

from vgraph.labels import PALETTE, PALETTE_SIZE, LabelEntry, LabelTable, palette_color

MAX_GUESSED_LABELS = 64
MAX_LISTED_LABELS = 256  # beyond, a table of one row per label is too long to edit: colours repeat
NEIGHBOUR_SHARE = 0.5  # of the distinct values that must have a neighbouring value
_SAMPLE_VOXELS = 1 << 16
_CHUNK_VOXELS = 1 << 22


@dataclass(frozen=True)
class Labels:
    """What a volume's values say: ``values`` the distinct label values (None when it holds
    intensities), ``facts`` the words that say why ("29 labels (integer values 0..28)"),
    ``near_miss`` intensities with few enough values to be labels but spaced apart."""
    values: tuple[int, ...] | None
    facts: str
    near_miss: bool = False

    @property
    def found(self) -> bool:
        return self.values is not None


def guessed_labels(volume) -> Labels:
    """The rule of the module docstring on the volume's values (read whole)."""
    data = volume.data
    if data.dtype.kind not in "iu":
        return Labels(None, f"{data.dtype} values")
    values = distinct_values(data, MAX_GUESSED_LABELS)
    if values is None:
        return Labels(None, f"{data.dtype}, more than {MAX_GUESSED_LABELS} distinct values")
    if values.size < 2:
        return Labels(None, f"{data.dtype}, one value ({values[0]})")
    share = neighbour_share(values)
    if share < NEIGHBOUR_SHARE:
        return Labels(None, f"{data.dtype}, {values.size} distinct values spaced apart over "
                            f"{_span(values)}, {share:.0%} next to another", near_miss=True)
    return Labels(tuple(int(v) for v in values), f"{values.size} labels (integer values {_span(values)})")


def declared_labels(volume) -> Labels:
    """A volume whose file declares labels (or the user does, --labels): its distinct values.
    Fractional values cannot be labels: None then, the facts say why."""
    data = volume.data
    if data.dtype.kind == "f":
        finite = data[np.isfinite(data)]
        if finite.size != data.size or np.any(finite != np.round(finite)):
            return Labels(None, f"{data.dtype} values that are not all whole numbers")
    values = np.unique(data) if data.dtype.kind == "f" else distinct_values(data, None)
    return Labels(tuple(int(v) for v in values), f"{values.size} labels (values {_span(values)})")


def distinct_values(data: np.ndarray, limit: int | None) -> np.ndarray | None:
    """The sorted distinct values (int64) of integer ``data``, or None when there are more than
    ``limit`` (None: no limit). Counted in chunks: the memory used stays small for any volume."""
    flat = data.reshape(-1)
    if limit is not None and np.unique(flat[::max(1, flat.size // _SAMPLE_VOXELS)]).size > limit:
        return None
    found = np.empty(0, dtype=np.int64)
    for start in range(0, flat.size, _CHUNK_VOXELS):
        found = np.union1d(found, _distinct(flat[start:start + _CHUNK_VOXELS]))
        if limit is not None and found.size > limit:
            return None
    return found


def _distinct(chunk: np.ndarray) -> np.ndarray:
    if chunk.dtype.itemsize <= 2:  # one counting pass, no sort
        low = int(chunk.min())
        return np.flatnonzero(np.bincount(chunk.astype(np.int32) - low)).astype(np.int64) + low
    return np.unique(chunk).astype(np.int64)


def neighbour_share(values: np.ndarray) -> float:
    """The share of ``values`` (sorted, distinct integers) that have value - 1 or value + 1 among them."""
    values = np.asarray(values, dtype=np.int64)
    gaps = np.diff(values) == 1
    with_neighbour = np.zeros(values.size, dtype=bool)
    with_neighbour[:-1] |= gaps
    with_neighbour[1:] |= gaps
    return float(with_neighbour.mean())


def distinct_label_table(values) -> LabelTable:
    """A label table in which every label of ``values`` but 0 (the background, hidden) has a
    colour of its own: the default table (palette colour by value) when the palette's colours of
    these values differ, else one row per label, coloured in order of value by the palette and,
    past its PALETTE_SIZE colours, by hues spread by the golden angle. Past MAX_LISTED_LABELS
    labels the default table (palette colours repeat)."""
    shown = [int(v) for v in values if int(v) != 0]
    default = LabelTable.default()
    if len(shown) > MAX_LISTED_LABELS or len({palette_color(v) for v in shown}) == len(shown):
        return default
    rows = [LabelEntry(value=value, color=categorical_color(rank)) for rank, value in enumerate(shown)]
    return default.model_copy(update={"labels": (*default.labels, *rows)})


def categorical_color(index: int) -> tuple[float, float, float]:
    """The ``index``-th colour of a list of distinct colours: the label palette's, then hues
    spread by the golden angle (no two alike) at alternating saturation and brightness."""
    if index < PALETTE_SIZE:
        return tuple(float(c) for c in PALETTE[index])
    step = index - PALETTE_SIZE
    hue = (0.11 + step * 0.6180339887498949) % 1.0
    saturation, brightness = (0.55, 0.95) if step % 2 == 0 else (0.85, 0.7)
    return tuple(float(c) for c in colorsys.hsv_to_rgb(hue, saturation, brightness))


def _span(values) -> str:
    return f"{int(values[0])}..{int(values[-1])}"
