"""The markups a slice canvas draws over its frame (issue 36; docs/guide/measuring.md, "Markups in
the slice views"): the parts of every Markups processor's markups (every markups property that
does not follow another through a link) that lie in the slice
(vgraph.markups_slice: within half a voxel step of the plane, or half the thick slab), painted by
Qt at screen resolution in that processor's ``color``, with their labels (name and length in world
units followed by its ``units``, or angle in degrees).

Painted on the widget like the crosshair (slice_overlay.py), never into the frame, so a saved
image stays what ``vgraph run`` draws; drawn whether or not the "Slices" overlay is on (markups
are data the user placed, not a view aid). The plane is the one the render process reported with
the frame ('id.slice_plane'), so the markups land on the pixels of the frame shown.
"""

from __future__ import annotations

from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QPainter, QPen

from vgraph.errors import VGraphError
from vgraph.gui.slice_overlay import uv_to_widget
from vgraph.live.slice_clicks import PLANE_SUFFIX
from vgraph.markups_slice import slice_marks, slice_reach
from vgraph.properties import MarkupsProperty

LINE_WIDTH = 2.0
POINT_RADIUS = 4.0
CROSSING_RADIUS = 2.5   # where a line passes through the slice
DEFAULT_COLOUR = QColor(255, 217, 0)   # the Markups processor's default colour


def markups_addresses(network) -> list[str]:
    """'id.name' of every markups property in the network, in order, except those that follow
    another through a link (a LineProfile's, linked to a Markups node's ruler): they hold the same
    markups, shown once, at their leader, and edited there."""
    followers = {link.target for link in network.links}
    return [f"{processor_id}.{name}" for processor_id, processor in network.processors.items()
            for name, prop in processor.properties.items()
            if isinstance(prop, MarkupsProperty) and f"{processor_id}.{name}" not in followers]


def markups_sources(network) -> list[tuple[str, object, QColor, str]]:
    """(address, markups, colour, units) of every markups property ``markups_addresses`` gives."""
    sources = []
    for address in markups_addresses(network):
        processor_id, name = address.split(".", 1)
        processor = network.processors[processor_id]
        sources.append((address, processor.property_values[name], _colour(processor),
                        str(processor.property_values.get("units", "") or "")))
    return sources


def _colour(processor) -> QColor:
    rgba = processor.property_values.get("color")
    if rgba is None:
        return DEFAULT_COLOUR
    return QColor.fromRgbF(*(float(c) for c in rgba[:3]), 1.0)


def network_slab(network, viewer_id: str) -> float:
    try:
        return float(network.get(f"{viewer_id}.slab_thickness") or 0.0)
    except VGraphError:  # a plug-in's slice processor without a slab
        return 0.0


def draw_slice_markups(painter: QPainter, viewer_id: str, network, cameras: dict, rect: QRectF) -> None:
    """The markups in the slice of ``viewer_id``'s last frame, drawn in ``rect``."""
    plane = cameras.get(viewer_id + PLANE_SUFFIX)
    if plane is None or rect.width() <= 0 or rect.height() <= 0:
        return
    sources = markups_sources(network)
    if not sources:
        return
    reach = slice_reach(plane, network_slab(network, viewer_id))
    painter.save()
    painter.setRenderHint(QPainter.Antialiasing, True)
    painter.setClipRect(rect)
    for _address, markups, colour, units in sources:
        marks = slice_marks(markups.markups, plane, reach, units)
        painter.setPen(QPen(colour, LINE_WIDTH, Qt.SolidLine, Qt.RoundCap))
        for ends in marks.lines:
            painter.drawLine(uv_to_widget(ends[0], rect), uv_to_widget(ends[1], rect))
        painter.setBrush(colour)
        painter.setPen(Qt.NoPen)
        for uv in marks.points:
            painter.drawEllipse(uv_to_widget(uv, rect), POINT_RADIUS, POINT_RADIUS)
        for uv in marks.crossings:
            painter.drawEllipse(uv_to_widget(uv, rect), CROSSING_RADIUS, CROSSING_RADIUS)
        painter.setPen(colour)
        for uv, text in marks.labels:
            painter.drawText(uv_to_widget(uv, rect) + QPointF(POINT_RADIUS + 2, -POINT_RADIUS - 2), text)
    painter.restore()
