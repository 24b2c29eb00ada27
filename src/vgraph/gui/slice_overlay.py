"""What a slice canvas draws over its frame at screen resolution: the other slices' planes as
crosshair lines, its own plane's outline, and readouts (top left) of the slice position (RAS
letter and world coordinate, slice number along the index axis nearest the normal, the thick
slab when there is one) and the window/level in data values.

Painted by Qt on the widget (CanvasView.paintEvent, with the "Slices" overlay toggle), never into
the frame, so the lines stay crisp and 2 px wide however small the view shows the image, and a
saved image stays what ``vgraph run`` draws (the SliceViewer's own ``crosshair`` property, for
scripts, draws into the image).

Colours follow 3D Slicer: a line takes the colour of the plane it marks, axial red, sagittal
yellow, coronal green (custom planes magenta), in every view, the 3D overlay included
(overlays.SLICE_COLOURS). So in the coronal view the axial level is a red horizontal line and the
sagittal level a yellow vertical one.

Geometry comes from the planes the render process reported with the view cameras
('id.slice_plane', slice_clicks.py): the line where another viewer's plane (through its centre,
with its normal) cuts this viewer's plane, put into this image's (u, v), clipped to the image
and mapped to the widget by the rectangle the frame is drawn in, as the click mapping does in
reverse. Only viewers slicing the same volume grid are drawn, and planes parallel to this one
give no line. A line goes through the other viewer's cursor as the network holds it (its
reported plane's centre while the cursor is automatic), so during a cursor drag the lines follow
the mouse before the other slices' frames arrive.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QLineF, QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QPainter, QPen, QPolygonF

from vgraph.gui.overlays import SLICE_COLOURS
from vgraph.errors import VGraphError
from vgraph.live.slice_clicks import PLANE_SUFFIX, VOLUME_SUFFIX
from vgraph.slicing import index_vectors

LINE_WIDTH = 2.0
OUTLINE_WIDTH = 1.5
READOUT_COLOUR = QColor(235, 235, 235)
READOUT_MARGIN = 6
_PARALLEL = 1e-6
# The world axis a plane of an orientation is constant along, and the RAS letters of its ends.
_POSITION_AXES = {"axial": (2, "I", "S"), "coronal": (1, "P", "A"), "sagittal": (0, "L", "R")}


def colour_of(orientation: str) -> QColor:
    return SLICE_COLOURS.get(orientation, SLICE_COLOURS["custom"])


def orientation_of(network, viewer_id: str) -> str:
    """The viewer's orientation; 'custom' for a processor that reports a plane without one (a
    plug-in's)."""
    try:
        return network.get(f"{viewer_id}.orientation")
    except VGraphError:
        return "custom"


def intersection_uv(own, other, through=None) -> tuple[np.ndarray, np.ndarray] | None:
    """The line where ``other``'s plane (through ``through``, default its centre) cuts ``own``'s,
    in own's image coordinates: (point, direction), or None when the planes are parallel."""
    n1, n2 = np.asarray(own.normal, float), np.asarray(other.normal, float)
    direction = np.cross(n1, n2)
    if np.linalg.norm(direction) < _PARALLEL:
        return None
    # The point of own's plane nearest its centre that lies on other's plane: move from own's
    # centre along the in-plane direction perpendicular to the line.
    towards = np.cross(direction, n1)  # in own's plane, across the line
    centre = np.asarray(own.centre, float)
    on_other = np.asarray(other.centre if through is None else through, float)
    t = (on_other - centre) @ n2 / (towards @ n2)
    point = centre + t * towards
    start, end = own.uv_of(np.stack([point, point + direction]))
    return start, end - start


def _cursor(network, viewer_id: str):
    """The viewer's cursor as the network holds it now (None: automatic, or no cursor): the
    lines follow a drag at once instead of waiting for the other viewers' next frames."""
    try:
        return network.get(f"{viewer_id}.cursor")
    except VGraphError:
        return None


def clipped_to_image(point, direction) -> tuple[np.ndarray, np.ndarray] | None:
    """The part of the line point + s * direction inside [0, 1]^2 (Liang-Barsky): its two ends,
    or None when the line misses the image."""
    low, high = -np.inf, np.inf
    for axis in range(2):
        if abs(direction[axis]) < 1e-12:
            if not 0.0 <= point[axis] <= 1.0:
                return None
            continue
        a, b = (0.0 - point[axis]) / direction[axis], (1.0 - point[axis]) / direction[axis]
        low, high = max(low, min(a, b)), min(high, max(a, b))
    if low > high:
        return None
    return point + low * direction, point + high * direction


def uv_to_widget(uv, rect: QRectF) -> QPointF:
    return QPointF(rect.left() + float(uv[0]) * rect.width(),
                   rect.top() + (1.0 - float(uv[1])) * rect.height())


def crosshair_lines(own_id: str, network, cameras: dict, rect: QRectF) -> list[tuple[QColor, QLineF]]:
    """(colour, widget line) for every other SliceViewer's plane across ``own_id``'s image."""
    own = cameras.get(own_id + PLANE_SUFFIX)
    if own is None:
        return []
    lines = []
    for key, plane in cameras.items():
        viewer_id = key[:-len(PLANE_SUFFIX)]
        if (not key.endswith(PLANE_SUFFIX) or viewer_id == own_id
                or viewer_id not in network.processors or plane.box != own.box):
            continue
        line = intersection_uv(own, plane, _cursor(network, viewer_id))
        ends = None if line is None else clipped_to_image(*line)
        if ends is not None:
            lines.append((colour_of(orientation_of(network, viewer_id)),
                          QLineF(uv_to_widget(ends[0], rect), uv_to_widget(ends[1], rect))))
    return lines


def outline_polygon(plane, rect: QRectF) -> QPolygonF:
    """Where the plane cuts its volume's box, in the widget (empty when unknown or missed)."""
    outline = plane.outline()
    return QPolygonF([uv_to_widget(uv, rect) for uv in plane.uv_of(outline)] if len(outline) else [])


def position_text(orientation: str, plane, cursor) -> str:
    """'Axial S 12.3 mm  slice 45/90': the world coordinate the plane is at (RAS letters: the
    sign's side) and the slice number along the index axis closest to the normal."""
    point = np.asarray(plane.centre if cursor is None else cursor, float)
    text = orientation.capitalize()
    if orientation in _POSITION_AXES:
        axis, negative, positive = _POSITION_AXES[orientation]
        value = float(point[axis])
        text += f"  {positive if value >= 0 else negative} {abs(value):.1f}"
    if plane.box is not None:
        box = plane.box
        axis = int(np.argmax(np.abs(index_vectors(plane.normal, box.spacing, box.direction))))
        index = float(box.indices(point)[axis])
        text += f"  slice {int(round(index)) + 1}/{box.dims[axis]}"
    return text


def window_text(window, volume) -> str:
    """'W 400 L 40' in data values: the viewer's window, or the whole value range when automatic."""
    if window is None:
        if volume is None:
            return ""
        low, high = volume.value_range
        window = ((low + high) / 2.0, high - low)
    return f"W {window[1]:.4g}  L {window[0]:.4g}"


def readouts(viewer_id: str, network, cameras: dict) -> list[str]:
    plane = cameras.get(viewer_id + PLANE_SUFFIX)
    if plane is None:
        return []
    lines = [position_text(network.get(f"{viewer_id}.orientation"), plane,
                           network.get(f"{viewer_id}.cursor"))]
    slab = network.get(f"{viewer_id}.slab_thickness") or 0.0
    if slab > 0.0:
        lines[0] += f"  MIP slab {slab:g}"
    if network.get(f"{viewer_id}.mapping") == "window":
        text = window_text(network.get(f"{viewer_id}.window"), cameras.get(viewer_id + VOLUME_SUFFIX))
        if text:
            lines.append(text)
    return lines


def draw_slice_overlay(painter: QPainter, viewer_id: str, network, cameras: dict, rect: QRectF) -> None:
    """The crosshair lines, the own plane's outline and the readouts of a slice canvas."""
    plane = cameras.get(viewer_id + PLANE_SUFFIX)
    if plane is None or rect.width() <= 0 or rect.height() <= 0:
        return
    painter.save()
    painter.setRenderHint(QPainter.Antialiasing, True)
    painter.setClipRect(rect)
    painter.setBrush(Qt.NoBrush)
    painter.setPen(QPen(colour_of(network.get(f"{viewer_id}.orientation")), OUTLINE_WIDTH))
    painter.drawPolygon(outline_polygon(plane, rect))
    for colour, line in crosshair_lines(viewer_id, network, cameras, rect):
        painter.setPen(QPen(colour, LINE_WIDTH))
        painter.drawLine(line)
    painter.setClipping(False)
    painter.setPen(READOUT_COLOUR)
    metrics = painter.fontMetrics()
    y = rect.top() + READOUT_MARGIN + metrics.ascent()
    for text in readouts(viewer_id, network, cameras):
        painter.drawText(QPointF(rect.left() + READOUT_MARGIN, y), text)
        y += metrics.height()
    painter.restore()
