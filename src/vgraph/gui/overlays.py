"""Overlays drawn by Qt over a canvas's frame: the data's bounding box and an orientation marker
(axes triad). They are painted on the widget, never into the rendered image, so a saved or
exported image stays equal to ``vgraph run``'s.

Geometry comes from the frame itself: the concrete camera it was rendered with and the world box
that camera framed (``ViewGeometry``, from the render process's ``view_cameras`` and
``view_boxes``). A world point goes through ``camera.view_projection(aspect)`` (aspect = the
frame's width / height) to NDC, and NDC to the widget by the rectangle the frame is drawn in:
``x = left + (ndc_x + 1) / 2 * width``, ``y = top + (1 - ndc_y) / 2 * height`` (the pixel-centre
convention of ``Camera.rays``: pixel column c spans [c, c + 1)).

- Box: the 12 edges of the box, clipped against the near plane (a camera inside the box still
  gets the edges in front of it), in ``BOX_COLOUR``.
- Triad: world x, y, z as seen by the camera (directions only: the rotation, no perspective), from
  a point ``TRIAD_MARGIN`` px inside the frame's bottom-right corner, each axis ``triad_length``
  px long when it lies in the image plane; x red, y green, z blue, labelled at the tips. Axes
  pointing away from the viewer are drawn first, so the nearer ones cover them.
- Slices: the polygon where each SliceViewer's plane cuts its volume's box (slice_clicks
  ``slice_overlays``), clipped against the near plane like the box, its edges in the colour of
  its plane as 3D Slicer colours it (axial red, sagittal yellow, coronal green; custom
  magenta; the slice views' crosshairs use the same colours, slice_overlay.py), over a faint
  fill of the same colour so the plane reads as a surface.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PySide6.QtCore import QLineF, QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QPainter, QPen, QPolygonF

from vgraph.camera import Camera

BOX_COLOUR = QColor(255, 200, 0)
BOX_WIDTH = 2.0
AXIS_COLOURS = {"x": QColor(235, 60, 60), "y": QColor(60, 210, 60), "z": QColor(70, 130, 255)}
AXIS_WIDTH = 3.0
# 3D Slicer's slice colours: a line or outline takes the colour of the plane it marks, in the
# 3D view and in the slice views alike (slice_overlay.py).
SLICE_COLOURS = {"axial": QColor(243, 74, 51), "sagittal": QColor(237, 213, 76),
                 "coronal": QColor(110, 176, 75), "custom": QColor(230, 110, 230)}
SLICE_WIDTH = 2.0
SLICE_FILL_ALPHA = 40
TRIAD_MARGIN = 20.0      # px from the frame's corner to the triad's reach (room for the labels)
TRIAD_FRACTION = 0.08    # axis length as a fraction of the frame's smaller side ...
TRIAD_LIMITS = (16.0, 48.0)  # ... within these pixel lengths
_NEAR_EPSILON = 1e-9

# Corner k of the box takes max along axis a where bit a of k is set; edges join corners one bit apart.
_CORNER_BITS = np.array([[(k >> axis) & 1 for axis in range(3)] for k in range(8)], dtype=bool)
BOX_EDGES = tuple((k, k | (1 << axis)) for k in range(8) for axis in range(3) if not k & (1 << axis))


@dataclass(frozen=True)
class ViewGeometry:
    """What a frame shows: the concrete camera it was rendered with and the box that camera framed."""
    camera: Camera
    box_min: tuple[float, float, float]
    box_max: tuple[float, float, float]

    def corners(self) -> np.ndarray:
        """The 8 world corners, (8, 3); corner k has max along the axes whose bit is set in k."""
        return np.where(_CORNER_BITS, np.asarray(self.box_max, float), np.asarray(self.box_min, float))


def _planned(camera: Camera, geometry: ViewGeometry, aspect: float) -> Camera:
    """A camera with near and far set (the frame's camera always has them; be safe otherwise)."""
    if camera.near is None or camera.far is None or camera.fit_to_data:
        return camera.resolved(geometry.box_min, geometry.box_max, aspect)
    return camera


def to_clip(camera: Camera, points: np.ndarray, aspect: float) -> np.ndarray:
    """World points (N, 3) -> homogeneous clip coordinates (N, 4)."""
    points = np.asarray(points, dtype=np.float64)
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    return homogeneous @ camera.view_projection(aspect).T


def clip_to_widget(clip: np.ndarray, rect: QRectF) -> np.ndarray:
    """Clip coordinates in front of the camera (N, 4) -> widget pixel positions (N, 2)."""
    ndc = clip[:, :2] / clip[:, 3:4]
    x = rect.left() + (ndc[:, 0] + 1.0) / 2.0 * rect.width()
    y = rect.top() + (1.0 - ndc[:, 1]) / 2.0 * rect.height()
    return np.stack([x, y], axis=1)


def project(geometry: ViewGeometry, points, rect: QRectF) -> np.ndarray:
    """Widget positions (N, 2) of world points in front of the camera, for a frame drawn in
    ``rect`` (its aspect is the frame's)."""
    aspect = rect.width() / rect.height()
    camera = _planned(geometry.camera, geometry, aspect)
    return clip_to_widget(to_clip(camera, points, aspect), rect)


def box_lines(geometry: ViewGeometry, rect: QRectF) -> list[QLineF]:
    """The box's edges in widget coordinates, each clipped to the part in front of the near plane."""
    aspect = rect.width() / rect.height()
    camera = _planned(geometry.camera, geometry, aspect)
    clip = to_clip(camera, geometry.corners(), aspect)
    # In clip space the near plane is z = -w: a point is in front of it where z + w >= 0.
    distance = clip[:, 2] + clip[:, 3]
    lines = []
    for a, b in BOX_EDGES:
        da, db = distance[a], distance[b]
        if da < 0.0 and db < 0.0:
            continue
        start, end = clip[a], clip[b]
        if da < 0.0:
            start = start + (end - start) * (da / (da - db))
        elif db < 0.0:
            end = end + (start - end) * (db / (db - da))
        if min(start[3], end[3]) <= _NEAR_EPSILON:
            continue
        (x0, y0), (x1, y1) = clip_to_widget(np.stack([start, end]), rect)
        lines.append(QLineF(x0, y0, x1, y1))
    return lines


def near_clipped(clip: np.ndarray) -> np.ndarray:
    """A closed polygon's vertices in clip space (k, 4) cut to the part in front of the near plane
    (z + w >= 0; Sutherland-Hodgman against that one plane): (m, 4), m = 0 when all is behind."""
    distance = clip[:, 2] + clip[:, 3]
    kept = []
    for i in range(len(clip)):
        j = (i + 1) % len(clip)
        if distance[i] >= 0.0:
            kept.append(clip[i])
        if (distance[i] >= 0.0) != (distance[j] >= 0.0):  # the edge crosses the plane
            kept.append(clip[i] + (clip[j] - clip[i]) * (distance[i] / (distance[i] - distance[j])))
    kept = [point for point in kept if point[3] > _NEAR_EPSILON]
    return np.array(kept).reshape(-1, 4)


def polygon_points(geometry: ViewGeometry, points, rect: QRectF) -> np.ndarray:
    """Widget positions (m, 2) of a closed world polygon (k, 3), cut at the near plane."""
    aspect = rect.width() / rect.height()
    camera = _planned(geometry.camera, geometry, aspect)
    clip = near_clipped(to_clip(camera, points, aspect))
    return clip_to_widget(clip, rect) if len(clip) else np.zeros((0, 2))


def draw_slices(painter: QPainter, geometry: ViewGeometry, rect: QRectF, slices) -> None:
    """``slices``: (orientation, outline (k, 3) world points) of each slice plane. The faint fills
    first, then every outline, so no plane's fill tints another's edges."""
    polygons = []
    for orientation, outline in slices:
        points = polygon_points(geometry, outline, rect) if len(outline) >= 3 else ()
        if len(points) >= 2:
            polygons.append((SLICE_COLOURS.get(orientation, SLICE_COLOURS["custom"]),
                             QPolygonF([QPointF(float(x), float(y)) for x, y in points])))
    painter.setPen(Qt.NoPen)
    for colour, polygon in polygons:
        fill = QColor(colour)
        fill.setAlpha(SLICE_FILL_ALPHA)
        painter.setBrush(fill)
        painter.drawPolygon(polygon)
    painter.setBrush(Qt.NoBrush)
    for colour, polygon in polygons:
        painter.setPen(QPen(colour, SLICE_WIDTH))
        painter.drawPolygon(polygon)


def triad_length(rect: QRectF) -> float:
    low, high = TRIAD_LIMITS
    return float(np.clip(TRIAD_FRACTION * min(rect.width(), rect.height()), low, high))


def triad_origin(rect: QRectF) -> QPointF:
    """The triad's centre: ``TRIAD_MARGIN`` plus one axis length inside the bottom-right corner."""
    reach = TRIAD_MARGIN + triad_length(rect)
    return QPointF(rect.right() - reach, rect.bottom() - reach)


def triad_axes(camera: Camera, rect: QRectF) -> list[tuple[str, QPointF, float]]:
    """(axis name, widget position of its tip, depth towards the viewer) for world x, y, z,
    farthest first (drawing order)."""
    right, up, forward = camera.basis()
    origin, length = triad_origin(rect), triad_length(rect)
    axes = []
    for name, direction in zip("xyz", np.eye(3)):
        tip = QPointF(origin.x() + length * float(direction @ right),
                      origin.y() - length * float(direction @ up))  # widget y points down
        axes.append((name, tip, -float(direction @ forward)))
    return sorted(axes, key=lambda axis: axis[2])


def draw_box(painter: QPainter, geometry: ViewGeometry, rect: QRectF) -> None:
    painter.setPen(QPen(BOX_COLOUR, BOX_WIDTH))
    painter.drawLines(box_lines(geometry, rect))


def draw_triad(painter: QPainter, camera: Camera, rect: QRectF) -> None:
    origin = triad_origin(rect)
    font = painter.font()
    font.setBold(True)
    painter.setFont(font)
    for name, tip, _ in triad_axes(camera, rect):
        colour = AXIS_COLOURS[name]
        painter.setPen(QPen(colour, AXIS_WIDTH, Qt.SolidLine, Qt.RoundCap))
        painter.drawLine(QLineF(origin, tip))
        # The label just beyond the tip, along the axis (centred on the tip for an axis end-on).
        offset = tip - origin
        norm = max((offset.x() ** 2 + offset.y() ** 2) ** 0.5, 1e-9)
        label = tip + offset * (9.0 / norm) if norm > 1.0 else tip
        painter.drawText(QRectF(label.x() - 8, label.y() - 8, 16, 16), Qt.AlignCenter, name)


def draw_overlays(painter: QPainter, geometry: ViewGeometry | None, rect: QRectF,
                  box: bool, axes: bool, slices=()) -> None:
    """Draw the requested overlays for a frame shown in ``rect`` (nothing without geometry);
    ``slices`` as draw_slices takes them (empty: none)."""
    if geometry is None or rect.width() <= 0 or rect.height() <= 0 or not (box or axes or len(slices)):
        return
    painter.save()
    painter.setRenderHint(QPainter.Antialiasing, True)
    painter.setClipRect(rect)
    if len(slices):
        draw_slices(painter, geometry, rect, slices)
    if box:
        draw_box(painter, geometry, rect)
    if axes:
        draw_triad(painter, geometry.camera, rect)
    painter.restore()
