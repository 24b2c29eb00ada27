"""VolumeStatistics: what a volume is (grid, type, values, time points) as one Python value, and
its histogram drawn into pixels; the data of the VolumeInfo and Histogram processors.

Conventions:
- Everything comes from the Volume's own API (dims, spacing, origin, affine, value_range,
  finite_extremes, percentiles, histogram, time_steps), so a BrickedVolume (a store larger than
  memory) is described without reading it whole: its extremes are the recorded ones and its
  percentiles and histogram come from a summary level (vgraph.bricks.volume); ``from_summary``
  says so.
- Percentiles are those of the finite voxels, as np.percentile's default (linear) method gives them
  (Volume.percentiles: exact for integer data spanning at most 65536 values).
- ``histogram_pixels`` draws a histogram over the whole image: column x covers normalised
  intensity [x / width, (x + 1) / width] and shows the bin holding its centre,
  bin = min(bins - 1, floor((2 x + 1) bins / (2 width))) in integers (the upper bin when the
  centre lies on an edge); the bar is round(v / max v * height) pixels
  high from the bottom, v the count or log(1 + count). The transfer function's opacity curve is
  drawn over it in the TF's own colour: at column x the row round(opacity((x + 0.5) / width)
  (height - 1)) from the bottom, joined to the previous column's by a vertical run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.gl.image_filters import premultiplied
from vgraph.transfer_function import TransferFunction


@dataclass(frozen=True)
class VolumeStatistics:
    """A volume described; ``lines()`` in words, ``as_dict()`` as JSON-ready numbers."""
    source: str
    dims: tuple[int, int, int]            # voxels (x, y, z)
    spacing: tuple[float, float, float]   # world units (x, y, z)
    origin: tuple[float, float, float]
    affine: tuple[tuple[float, ...], ...]  # 4 x 4: voxel (i, j, k, 1) -> world (RAS)
    dtype: str
    minimum: float | None                 # of the finite voxels; None when none is finite
    maximum: float | None
    value_range: tuple[float, float]      # what normalised intensity 0 and 1 are (TF positions)
    nonfinite_count: int
    percentiles: dict[float, float]       # percent -> data value; empty when no voxel is finite
    time_steps: int
    holds_labels: bool
    from_summary: bool                    # percentiles of a store's summary level, not every voxel

    @classmethod
    def of(cls, volume, percents) -> "VolumeStatistics":
        extremes = volume.finite_extremes
        percents = tuple(float(p) for p in percents)
        # without a finite voxel Volume.percentiles maps percents onto the value range: no statistic
        values = volume.percentiles(percents) if percents and extremes is not None else ()
        return cls(source=volume.source, dims=tuple(int(v) for v in volume.dims),
                   spacing=tuple(float(v) for v in volume.spacing), origin=tuple(float(v) for v in volume.origin),
                   affine=tuple(tuple(float(v) for v in row) for row in volume.affine),
                   dtype=str(volume_dtype(volume)),
                   minimum=None if extremes is None else float(extremes[0]),
                   maximum=None if extremes is None else float(extremes[1]),
                   value_range=tuple(float(v) for v in volume.value_range),
                   nonfinite_count=int(volume.nonfinite_count),
                   percentiles={p: float(v) for p, v in zip(percents, values)},
                   time_steps=int(volume.time_steps), holds_labels=bool(volume.holds_labels),
                   from_summary=volume.bricks is not None)

    @property
    def voxel_count(self) -> int:
        return int(np.prod(self.dims, dtype=np.int64))

    def lines(self) -> list[str]:
        """The description in a few short lines (the GUI inspector shows them)."""
        x, y, z = self.dims
        lines = [f"{x} \u00d7 {y} \u00d7 {z} {self.dtype} ({self.voxel_count:,} voxels)",
                 f"spacing ({_numbers(self.spacing)}), origin ({_numbers(self.origin)})"]
        linear = np.array(self.affine)[:3, :3]
        if not np.allclose(linear, np.diag(self.spacing)):
            lines.append("affine rows " + "; ".join(_numbers(row) for row in self.affine[:3]))
        if self.minimum is None:
            lines.append("no finite values")
        else:
            lines.append(f"values {self.minimum:g} to {self.maximum:g}"
                         + (f", {self.nonfinite_count:,} not finite" if self.nonfinite_count else ""))
        if self.value_range != (self.minimum, self.maximum):
            lines.append(f"value range (TF scale) {self.value_range[0]:g} to {self.value_range[1]:g}")
        if self.percentiles:
            summary = " (of a summary level)" if self.from_summary else ""
            lines.append("percentiles " + ", ".join(f"{p:g}%: {v:.6g}" for p, v in self.percentiles.items())
                         + summary)
        if self.time_steps > 1:
            lines.append(f"one of {self.time_steps} time points")
        if self.holds_labels:
            lines.append("labels (the file says)")
        return lines

    def as_dict(self) -> dict:
        """Plain numbers and lists (json.dumps takes it); percentiles keyed by their percent as text."""
        return {"source": self.source, "dims": list(self.dims), "spacing": list(self.spacing),
                "origin": list(self.origin), "affine": [list(row) for row in self.affine], "dtype": self.dtype,
                "min": self.minimum, "max": self.maximum, "value_range": list(self.value_range),
                "nonfinite_count": self.nonfinite_count,
                "percentiles": {f"{p:g}": v for p, v in self.percentiles.items()},
                "time_steps": self.time_steps, "holds_labels": self.holds_labels,
                "from_summary": self.from_summary}


def volume_dtype(volume) -> np.dtype:
    """The stored type, without reading a store's voxels (a BrickedVolume knows it from metadata)."""
    return volume.dtype if volume.bricks is not None else volume.data.dtype


def _numbers(values) -> str:
    return ", ".join(f"{v:g}" for v in values)


# --- the histogram as pixels ----------------------------------------------------------------------
def column_bins(width: int, bins: int) -> np.ndarray:
    """The bin each of ``width`` columns shows (the bin holding the column's centre)."""
    # in integers: a centre exactly on a bin's edge (x + 0.5 = k width / bins) takes the upper bin,
    # not whichever way a float product rounds
    return np.minimum(bins - 1, (2 * np.arange(width, dtype=np.int64) + 1) * bins // (2 * width))


def bar_heights(counts: np.ndarray, width: int, height: int, log: bool) -> np.ndarray:
    """Pixels of each column's bar: round(v / max v * height), v = count or log(1 + count)."""
    values = np.log1p(counts.astype(np.float64)) if log else counts.astype(np.float64)
    top = values.max() if values.size else 0.0
    if top <= 0:
        return np.zeros(width, np.int64)
    return np.round(values[column_bins(width, len(counts))] / top * height).astype(np.int64)


def curve_rows(tf: TransferFunction, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows from the bottom of the TF's opacity at each column's centre, and its RGB there."""
    rgba = tf((np.arange(width) + 0.5) / width)
    return np.round(rgba[:, 3] * (height - 1)).astype(np.int64), rgba[:, :3]


def histogram_pixels(counts: np.ndarray, size: tuple[int, int], *, log: bool, bar_color, background,
                     tf: TransferFunction | None = None, line_width: int = 1) -> np.ndarray:
    """Premultiplied float32 RGBA (height, width, 4), row 0 at the top (module docstring); the
    colours are straight RGBA, as colour properties hold them."""
    width, height = size
    image = np.empty((height, width, 4), np.float32)
    image[...] = premultiplied(background)
    rows_from_bottom = np.arange(height)[::-1, None]  # image row 0 is the top
    filled = rows_from_bottom < bar_heights(counts, width, height, log)[None, :]
    image[filled] = premultiplied(bar_color)
    if tf is not None:
        rows, colors = curve_rows(tf, width, height)
        previous = np.concatenate([rows[:1], rows[:-1]])
        low = np.minimum(rows, previous) - (line_width - 1) // 2
        high = np.maximum(rows, previous) + line_width // 2
        on_curve = (rows_from_bottom >= low[None, :]) & (rows_from_bottom <= high[None, :])
        image[on_curve] = np.concatenate([np.broadcast_to(colors[None, :, :], (height, width, 3)),
                                          np.ones((height, width, 1))], axis=-1)[on_curve]
    return image
