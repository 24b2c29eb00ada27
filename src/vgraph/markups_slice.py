"""Markups as a slice view shows them: the parts of point lists, rulers, angles and closed curves
that lie in the slice, in the slice image's coordinates (issue 36; docs/guide/measuring.md,
"Markups in the slice views"). No Qt: the GUI paints what this gives (gui/slice_markups.py).

Conventions:
- The slice is a ``SlicePlane`` (vgraph.slicing: u right, v up, both in [0, 1] over the image) and
  a half thickness ``reach`` in world units: what lies within ``reach`` of the plane along its
  normal is "in the slice" (by default half a voxel step along the normal, or half the thick
  slab, ``slice_reach``). This is 3D Slicer's rule for markups in a slice view: a point list's
  points show on the slices they lie on, not on all of them.
- Points: each point in the slice is a disc at its projection. Lines (a ruler, an angle's arms,
  a closed curve's edges, the angle's arc) are cut to the slab |distance| <= reach and the part
  inside projected, so a closed curve drawn in this slice shows whole, and a ruler that crosses
  the slice obliquely shows the short piece where it passes through, with a crossing mark (a
  smaller disc) in its middle, as a line square to the slice has no length to show.
- Labels: the markup's name and measurement (vgraph.markups_drawing.label_text: lengths in world
  units followed by ``units``, angles in degrees) at the markup's anchor (a ruler's middle, an
  angle's vertex, the first point of the others) when it lies in the slice, else at the first
  thing of the markup drawn; no label when nothing of it is in the slice.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vgraph.markups import Markup
from vgraph.markups_drawing import angle_arc, label_anchor, label_text
from vgraph.slicing import SlicePlane, voxel_step


@dataclass
class SliceMarks:
    """What a slice shows of some markups, in image coordinates (u, v)."""
    lines: list[np.ndarray] = field(default_factory=list)     # (2, 2) segments' ends
    points: list[np.ndarray] = field(default_factory=list)    # (2,) disc centres
    crossings: list[np.ndarray] = field(default_factory=list)  # (2,) where a line passes through
    labels: list[tuple[np.ndarray, str]] = field(default_factory=list)


def slice_reach(plane: SlicePlane, slab_thickness: float = 0.0) -> float:
    """Half the slice's thickness in world units: half a voxel step along the normal (the
    volume's grid, from the plane's box), or half the thick slab when that is wider."""
    half_step = 0.0
    if plane.box is not None:
        half_step = 0.5 * voxel_step(plane.normal, plane.box.spacing, plane.box.direction)
    return max(half_step, 0.5 * float(slab_thickness or 0.0))


def slice_marks(markups, plane: SlicePlane, reach: float, units: str = "") -> SliceMarks:
    """The visible markups' parts in the slice (module docstring)."""
    marks = SliceMarks()
    for markup in markups:
        if markup.visible:
            _add_markup(marks, markup, plane, reach, units)
    return marks


def _add_markup(marks: SliceMarks, markup: Markup, plane: SlicePlane, reach: float, units: str) -> None:
    points = markup.array
    if markup.kind == "angle":
        polylines = [points, angle_arc(points)]
    elif markup.kind == "closed_curve":
        polylines = [np.vstack([points, points[:1]])]
    else:
        polylines = [points] if markup.kind == "ruler" else []
    drawn = []
    for polyline in polylines:
        for start, end in zip(polyline[:-1], polyline[1:]):
            piece = _in_slab(start, end, plane, reach)
            if piece is not None:
                marks.lines.append(plane.uv_of(piece))
                drawn.append(piece[0])
                if not _touches(piece, start, end):
                    marks.crossings.append(plane.uv_of(piece.mean(axis=0)))
    inside = np.abs(_distances(points, plane)) <= reach
    for point in points[inside]:
        marks.points.append(plane.uv_of(point))
    drawn = [*points[inside], *drawn]
    if not drawn:
        return
    anchor = label_anchor(markup)
    where = anchor if abs(_distances(anchor[None, :], plane)[0]) <= reach else drawn[0]
    marks.labels.append((plane.uv_of(where), label_text(markup, units)))


def _distances(points: np.ndarray, plane: SlicePlane) -> np.ndarray:
    """Signed world distances of points (n, 3) from the plane along its normal."""
    return (np.asarray(points, float) - np.asarray(plane.centre)) @ np.asarray(plane.normal)


def _touches(piece: np.ndarray, start: np.ndarray, end: np.ndarray) -> bool:
    """Whether the piece in the slab keeps an end of its segment (else the segment only passes
    through the slice, shown as a crossing mark: a line across the slice is a short stub)."""
    return bool(np.array_equal(piece[0], start) or np.array_equal(piece[1], end))


def _in_slab(start: np.ndarray, end: np.ndarray, plane: SlicePlane, reach: float) -> np.ndarray | None:
    """The part of the segment within ``reach`` of the plane, (2, 3), or None."""
    a, b = _distances(np.vstack([start, end]), plane)
    if a == b:
        return np.vstack([start, end]) if abs(a) <= reach else None
    # t where the distance a + t (b - a) crosses -reach and +reach, kept within [0, 1]
    t0, t1 = sorted(((-reach - a) / (b - a), (reach - a) / (b - a)))
    t0, t1 = max(t0, 0.0), min(t1, 1.0)
    if t0 > t1:
        return None
    return np.vstack([start + t0 * (end - start), start + t1 * (end - start)])
