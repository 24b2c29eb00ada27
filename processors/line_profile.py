"""LineProfile: a volume sampled along the line between two world points (a ruler's), as a table
and a plot: 3D Slicer's line profile, ParaView's Plot Over Line.

Conventions (docs/guide/measuring.md shows them with examples; vgraph.measure_line holds the
sampling):
- ``start`` and ``end`` are world points (x, y, z) in patient space, the frame of the volume's
  affine; distances are world units along the line from ``start``.
- From a ruler: link a Markups processor's ``markups`` to this ``markups`` (a property link, so
  the profile follows every move of the ruler, undo included) and name the ruler in ``ruler``; the
  line then runs from the ruler's first point to its second, and ``start`` and ``end`` are unused.
  A ``ruler`` that names no markup, or a markup that is not a ruler, is refused by name.
- ``spacing_mode = samples``: ``samples`` points, both ends included. ``step``: one point every
  ``step`` world units from ``start``, up to the end.
- ``interpolation``: nearest, linear (trilinear) or cubic (the cubic B-spline through the samples,
  Cabral 2010 ch. 3): the values scipy.ndimage.map_coordinates gives at the points' voxel
  coordinates (order 0, 1, or 3 on the coefficients of vgraph.numerics.bspline.prefilter with
  mode='mirror'). A label volume takes nearest only; a volume of B-spline coefficients
  (CubicSplineProcessor) cubic only. Before the prefilter NaN/Inf voxels are replaced by the
  value range's ends, with a warning naming the processor and the count.
- A store (BrickedVolume) is read only around the line for nearest and linear (vgraph.measure_line);
  cubic reads its full-resolution array, within the store's memory budget.
- Points outside the box of voxel centres get NaN, and a VGraphWarning names the processor, how
  many points and where along the line: a profile still shows the part inside.
- Outports: ``table`` (vgraph.table.Table: distance, x, y, z in world units, value; ``vgraph run
  --port profile.table --data profile.csv`` writes it) and ``plot`` (an Image of value against
  distance, drawn on the CPU at the size the canvas asks for; computed only when read).
- Refused by name: a line of zero length, fewer than 2 samples, a step that gives fewer than 2 or
  more than 1,000,000 samples. Points that are not finite numbers are refused by the properties.
"""

from __future__ import annotations

import warnings

import numpy as np

from vgraph import (FloatProperty, Inport, IntProperty, MarkupsProperty, OptionProperty, Outport, Processor,
                    PropertyError, StringProperty, VectorProperty, VGraphError, VGraphWarning)
from vgraph.image import Image
from vgraph.markups import Markups
from vgraph.measure_line import MAX_SAMPLES, ORDERS, sample_count, sample_distances, sample_line, spline_coefficients
from vgraph.measure_plot import line_plot
from vgraph.table import Column, Table
from vgraph.volume import Volume


class LineProfile(Processor):
    """Samples a volume along a line between two world points into a table and a plot."""

    category = "Measuring"
    inports = [Inport("volume", Volume)]
    outports = [Outport("table", Table, description="distance, x, y, z (world units) and value per sample"),
                Outport("plot", Image, on_demand=True, description="value against distance")]
    renders_at_size = True  # the plot fills the canvas that shows it

    start = VectorProperty((0.0, 0.0, 0.0), doc="first point of the line (x, y, z), world units")
    end = VectorProperty((10.0, 0.0, 0.0), doc="last point of the line (x, y, z), world units")
    spacing_mode = OptionProperty("samples", choices=["samples", "step"],
                                  doc="samples: that many points, ends included; step: one every step world units")
    samples = IntProperty(100, min=2, doc="number of points along the line, both ends included")
    step = FloatProperty(1.0, min=0.0, doc="distance between points in world units (> 0)")
    interpolation = OptionProperty("linear", choices=list(ORDERS),
                                   doc="nearest, linear (trilinear) or cubic (cubic B-spline)")
    markups = MarkupsProperty(Markups(), doc="link a Markups processor's markups here to profile one of its "
                                             "rulers (see ruler)")
    ruler = StringProperty("", doc="the name of a ruler in markups: the line runs from its first point to its "
                                   "second and follows it (start and end unused); empty: start and end")

    def __init__(self, id=None, **values):
        super().__init__(id, **values)
        self._spline: tuple[Volume, np.ndarray] | None = None  # the last volume's coefficients
        self.summary = ""  # the last run's, for the inspector

    def frame_summary(self) -> str:
        return self.summary

    def inapplicable(self) -> set[str]:
        unused = {"step"} if self.spacing_mode == "samples" else {"samples"}
        return unused | ({"start", "end"} if self.ruler else set())

    def ends(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(start, end) of the line: the named ruler's points, else the properties."""
        if not self.ruler:
            return tuple(self.start), tuple(self.end)
        if self.ruler not in self.markups.names:
            there = ", ".join(m.name for m in self.markups.markups if m.kind == "ruler") or "none"
            raise PropertyError(f"{self.id}.ruler", f"no ruler named {self.ruler!r} in {self.id}.markups (rulers "
                                f"there: {there}); link a Markups processor's markups to {self.id}.markups")
        markup = self.markups[self.ruler]
        if markup.kind != "ruler":
            raise PropertyError(f"{self.id}.ruler", f"{self.ruler!r} is {'an' if markup.kind == 'angle' else 'a'} "
                                f"{markup.kind.replace('_', ' ')}, not a ruler: a profile runs along two points")
        return markup.points[0], markup.points[1]

    def check(self) -> None:
        start, _ = self.ends()
        length = self.length
        if length == 0.0:
            where = f"{self.id}.ruler" if self.ruler else f"{self.id}.end"
            raise PropertyError(where, f"the line has zero length: end equals start {list(start)}")
        if self.spacing_mode == "step":
            if self.step <= 0.0:
                raise PropertyError(f"{self.id}.step", f"must be above 0, got {self.step}")
            count = sample_count(length, self.step)
            if count < 2:
                raise PropertyError(f"{self.id}.step", f"step {self.step:g} is longer than the line "
                                    f"({length:g} world units): fewer than 2 samples")
            if count > MAX_SAMPLES:
                raise PropertyError(f"{self.id}.step", f"step {self.step:g} gives {count} samples along "
                                    f"{length:g} world units, more than {MAX_SAMPLES}")

    @property
    def length(self) -> float:
        start, end = self.ends()
        return float(np.linalg.norm(np.subtract(end, start)))

    def process(self, volume: Volume) -> dict:
        self.summary = ""
        self.check()
        self._check_interpolation(volume)
        distances = sample_distances(self.length, **({"samples": self.samples} if self.spacing_mode == "samples"
                                                     else {"step": self.step}))
        coefficients = self._coefficients(volume) if self.interpolation == "cubic" else None
        line = sample_line(volume, *self.ends(), distances, self.interpolation, coefficients)
        self._warn_outside(line.distance, line.outside)
        table = Table((Column("distance", line.distance, "world"),
                       *(Column(axis, line.points[:, n], "world") for n, axis in enumerate("xyz")),
                       Column("value", line.values)), source=f"LineProfile '{self.id}'")
        self.summary = _summary(line.distance, line.values)
        outputs = {"table": table}
        if self.wants("plot"):
            pixels = line_plot(line.distance, line.values, self.render_size,
                               title=f"Line profile ({self.interpolation})",
                               x_label="distance along the line [world units]", y_label="value")
            outputs["plot"] = Image.from_numpy(self.gl, pixels)
        return outputs

    def _check_interpolation(self, volume: Volume) -> None:
        if volume.is_spline_coefficients and self.interpolation != "cubic":
            raise VGraphError(f"LineProfile '{self.id}': the volume holds B-spline coefficients, not "
                              f"samples: use interpolation cubic, or put the profile before the CubicSplineProcessor")
        if volume.holds_labels and self.interpolation != "nearest":
            raise PropertyError(f"{self.id}.interpolation", f"{self.interpolation} interpolation mixes label "
                                f"values into labels that are not there: use nearest for a label volume")

    def _coefficients(self, volume: Volume) -> np.ndarray:
        """The volume's B-spline coefficients, kept while the same volume comes in (moving a
        point must not prefilter the whole volume again)."""
        if self._spline is None or self._spline[0] is not volume:
            if volume.nonfinite_count and not volume.is_spline_coefficients:
                warnings.warn(f"LineProfile '{self.id}': {volume.nonfinite_count} NaN/Inf voxels replaced by "
                              f"the value range's ends before the B-spline prefilter", VGraphWarning, stacklevel=3)
            self._spline = (volume, spline_coefficients(volume))
        return self._spline[1]

    def _warn_outside(self, distance: np.ndarray, outside: np.ndarray) -> None:
        count = int(outside.sum())
        if not count:
            return
        low, high = distance[outside].min(), distance[outside].max()
        span = f"{low:g}" if low == high else f"{low:g} to {high:g}"
        where = "the whole line lies" if count == len(outside) else \
            f"{count} of {len(outside)} samples (distance {span}) lie"
        warnings.warn(f"LineProfile '{self.id}': {where} outside the volume's box of voxel centres: "
                      f"their values are NaN", VGraphWarning, stacklevel=2)


def _summary(distance: np.ndarray, values: np.ndarray) -> str:
    """A line for the GUI's inspector: how many samples over how long, and the values' span."""
    text = f"{len(distance)} samples over {distance[-1]:g} world units"
    finite = values[np.isfinite(values)]
    if len(finite):
        text += f"; values {finite.min():.6g} to {finite.max():.6g}"
    if len(finite) < len(values):
        text += f"; {len(values) - len(finite)} outside the volume (NaN)"
    return text
