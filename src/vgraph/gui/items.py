"""The graphics items of the network editor: nodes, their ports, connections and property links.

Conventions:
- Data flows downwards, as in Voreen: inports sit on a node's top edge, outports on its bottom
  edge; a connection is a cubic curve leaving an outport downwards and entering an inport from above,
  or, where that curve would run under an unrelated node, a path around it (edge_routing.py).
- A port's colour is its data type's: fixed colours for the built-in types, and for any other
  type a hue derived from its name (stable across runs, so a plug-in type keeps its colour).
- Items only draw; they hold the ids they show and never change the model. The scene owns them.
- Text is painted directly in ``paint`` (no child text items: see docs/explanations/gui-internals.md on PySide6 pitfalls).
"""

from __future__ import annotations

import math
import zlib
from typing import Mapping

from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QBrush, QColor, QFont, QFontMetrics, QPainterPath, QPainterPathStroker, QPen
from PySide6.QtWidgets import QGraphicsEllipseItem, QGraphicsItem, QGraphicsPathItem

from vgraph.gui.edge_routing import Box, Route, curve_controls, route
from vgraph.live.evaluator import ProcessorStatus
from vgraph.network import Connection, Link
from vgraph.ports import Port
from vgraph.processor import Processor

NODE_WIDTH, NODE_HEIGHT = 168.0, 62.0
PORT_RADIUS = 6.0
CORNER_RADIUS = 10.0  # rounded corners of a routed connection

KNOWN_TYPE_COLORS = {"Volume": "#2f6fd6", "Image": "#2e9e4f", "Geometry": "#e08a1e", "TetMesh": "#0f9d9a",
                     "float": "#8a63c9", "int": "#8a63c9", "str": "#8c8c8c"}
STATE_COLORS = {"evaluated": "#2e9e4f", "error": "#d23c3c", "invalid": "#d9a21b",
                "not_ready": "#b5b5b5", "writer": "#7a8aa6", "running": "#2563eb"}
HIGHLIGHT_COMPATIBLE, HIGHLIGHT_REFUSED = "#22c55e", "#9ca3af"


def port_color(type_name: str) -> QColor:
    known = KNOWN_TYPE_COLORS.get(type_name)
    if known:
        return QColor(known)
    hue = zlib.crc32(type_name.encode()) % 360
    return QColor.fromHsv(hue, 170, 210)


class PortItem(QGraphicsEllipseItem):
    """One port of a node; ``highlight`` shows drag-to-connect feedback."""

    def __init__(self, node: "NodeItem", port: Port, position: QPointF):
        r = PORT_RADIUS
        super().__init__(-r, -r, 2 * r, 2 * r)
        self.setParentItem(node)
        self.node = node
        self.port = port
        self.direction = port.direction
        self.setPos(position)
        self.setZValue(2)
        self.setAcceptHoverEvents(True)
        extra = ""
        if port.direction == "in":
            flags = [w for w, on in (("optional", port.optional), ("multiple", port.multiple)) if on]
            extra = f" ({', '.join(flags)})" if flags else ""
        self.setToolTip(f"{self.address}: {port.type_name}, {port.direction}port{extra}")
        self.highlight(None)

    @property
    def address(self) -> str:
        return f"{self.node.processor_id}.{self.port.name}"

    def highlight(self, verdict: str | None) -> None:
        """None: normal; "compatible": a valid drop target; "refused": an invalid one."""
        color = port_color(self.port.type_name)
        if verdict == "refused":
            self.setBrush(QBrush(QColor(HIGHLIGHT_REFUSED)))
            self.setPen(QPen(QColor("#6b7280"), 1))
            self.setScale(0.8)
        elif verdict == "compatible":
            self.setBrush(QBrush(color))
            self.setPen(QPen(QColor(HIGHLIGHT_COMPATIBLE), 3))
            self.setScale(1.4)
        else:
            self.setBrush(QBrush(color))
            self.setPen(QPen(color.darker(150), 1.2))
            self.setScale(1.0)
        self.verdict = verdict


class NodeItem(QGraphicsItem):
    """A processor: id, type, a status line, and its ports."""

    def __init__(self, processor: Processor):
        super().__init__()
        self.processor_id = processor.id
        self.type_name = processor.type_name
        self.description = processor.description
        self.status = ProcessorStatus("invalid", "", "")
        self.setFlags(QGraphicsItem.ItemIsMovable | QGraphicsItem.ItemIsSelectable
                      | QGraphicsItem.ItemSendsGeometryChanges)
        self.setZValue(1)
        self.ports: dict[tuple[str, str], PortItem] = {}
        for direction, ports, y in (("in", processor.inports, 0.0), ("out", processor.outports, NODE_HEIGHT)):
            for i, port in enumerate(ports):
                x = NODE_WIDTH * (i + 1) / (len(ports) + 1)
                self.ports[(direction, port.name)] = PortItem(self, port, QPointF(x, y))
        self.setPos(*processor.position)
        self.set_status(self.status)

    def port(self, direction: str, name: str) -> PortItem:
        return self.ports[(direction, name)]

    def set_status(self, status: ProcessorStatus) -> None:
        if status == self.status and self.toolTip():
            return  # every mouse move of a drag asks again: repaint only what changed
        self.status = status
        lines = [f"{self.processor_id} ({self.type_name})"]
        if self.description:
            lines.append(self.description)
        lines.append(f"{status.state.replace('_', ' ')}: {status.detail}")
        self.setToolTip("\n".join(lines))
        self.update()

    def boundingRect(self) -> QRectF:
        return QRectF(-2, -2, NODE_WIDTH + 4, NODE_HEIGHT + 4)

    def paint(self, painter, option, widget=None) -> None:
        state_color = QColor(STATE_COLORS.get(self.status.state, "#999999"))
        border = QPen(QColor("#1d4ed8"), 3) if self.isSelected() else QPen(state_color, 2)
        painter.setPen(border)
        painter.setBrush(QBrush(QColor("#fbfbfd")))
        painter.drawRoundedRect(QRectF(0, 0, NODE_WIDTH, NODE_HEIGHT), 7, 7)
        painter.setBrush(QBrush(state_color))
        painter.setPen(Qt.NoPen)
        painter.drawEllipse(QPointF(NODE_WIDTH - 12, 14), 5, 5)
        font = QFont(painter.font())
        font.setPointSizeF(9.5)
        font.setBold(True)
        painter.setFont(font)
        painter.setPen(QColor("#111827"))
        title = QFontMetrics(font).elidedText(self.processor_id, Qt.ElideRight, int(NODE_WIDTH - 30))
        painter.drawText(QRectF(10, 6, NODE_WIDTH - 30, 18), Qt.AlignLeft | Qt.AlignVCenter, title)
        font.setBold(False)
        font.setPointSizeF(8)
        painter.setFont(font)
        painter.setPen(QColor("#4b5563"))
        painter.drawText(QRectF(10, 23, NODE_WIDTH - 20, 15), Qt.AlignLeft | Qt.AlignVCenter, self.type_name)
        painter.setPen(state_color.darker(130))
        painter.drawText(QRectF(10, 39, NODE_WIDTH - 20, 15), Qt.AlignLeft | Qt.AlignVCenter, self.status.text)
        if self.status.fraction is not None:  # running work with steps: a bar along the bottom edge
            painter.setPen(Qt.NoPen)
            painter.setBrush(QBrush(state_color.lighter(170)))
            painter.drawRect(QRectF(10, NODE_HEIGHT - 7, NODE_WIDTH - 20, 3))
            painter.setBrush(QBrush(state_color))
            painter.drawRect(QRectF(10, NODE_HEIGHT - 7, (NODE_WIDTH - 20) * self.status.fraction, 3))

    def itemChange(self, change, value):
        if change == QGraphicsItem.ItemPositionHasChanged and self.scene() is not None:
            self.scene().node_moved(self)
        return super().itemChange(change, value)


class _CurveItem(QGraphicsPathItem):
    """A selectable curve with a wide invisible grip for clicking."""

    GRIP = 10.0

    def shape(self) -> QPainterPath:
        stroker = QPainterPathStroker()
        stroker.setWidth(self.GRIP)
        return stroker.createStroke(self.path())


class EdgeItem(_CurveItem):
    """A connection between an outport and an inport, in the outport's data-type colour.

    Its course is an ``edge_routing.Route``: the default curve, or a path around the nodes in its
    way; the scene passes those nodes (``adjust``) and keeps the route for placing new nodes."""

    def __init__(self, connection: Connection, source: PortItem, target: PortItem):
        super().__init__()
        self.connection = connection
        self.source, self.target = source, target
        self.color = port_color(source.port.type_name)
        self.setFlags(QGraphicsItem.ItemIsSelectable)
        self.setZValue(0)
        self.setToolTip(str(connection))
        self.route: Route | None = None
        self.lane = 0.0   # the scene spreads routed connections over lanes (edge_routing.route)
        self.adjust()

    def adjust(self, obstacles: Mapping[str, Box] | None = None) -> None:
        """Re-route between the ports' current places around ``obstacles`` (processor id: box)."""
        start, end = self.source.scenePos(), self.target.scenePos()
        ends = tuple(Box.of(n.x(), n.y(), NODE_WIDTH, NODE_HEIGHT) for n in (self.source.node, self.target.node))
        self.route = route((start.x(), start.y()), (end.x(), end.y()), obstacles or {}, lane=self.lane, ends=ends)
        self.setPath(route_path(self.route))

    def paint(self, painter, option, widget=None) -> None:
        width = 4.0 if self.isSelected() else 2.2
        color = self.color.lighter(125) if self.isSelected() else self.color
        painter.setPen(QPen(color, width, Qt.SolidLine, Qt.RoundCap))
        painter.setBrush(Qt.NoBrush)
        painter.drawPath(self.path())


def connection_path(start: QPointF, end: QPointF) -> QPainterPath:
    """The default curve: leaves ``start`` downwards and enters ``end`` from above."""
    (c1x, c1y), (c2x, c2y) = curve_controls((start.x(), start.y()), (end.x(), end.y()))
    path = QPainterPath(start)
    path.cubicTo(QPointF(c1x, c1y), QPointF(c2x, c2y), end)
    return path


def route_path(course: Route, radius: float = CORNER_RADIUS) -> QPainterPath:
    """The route as drawn: the default curve, or the orthogonal path with rounded corners (a
    corner's arc stays inside the clearance the router kept, as ``radius`` < the router's margin)."""
    points = [QPointF(x, y) for x, y in course.points]
    if course.curved:
        return connection_path(points[0], points[-1])
    path = QPainterPath(points[0])
    for before, corner, after in zip(points, points[1:], points[2:]):
        into, out = corner - before, after - corner
        length_in, length_out = math.hypot(into.x(), into.y()), math.hypot(out.x(), out.y())
        r = min(radius, length_in / 2, length_out / 2)
        path.lineTo(corner - into * (r / length_in))
        path.quadTo(corner, corner + out * (r / length_out))
    path.lineTo(points[-1])
    return path


class LinkItem(_CurveItem):
    """A property link: a dashed arc on the right of the two nodes (arrow at the follower)."""

    def __init__(self, link: Link, source: NodeItem, target: NodeItem, lane: int = 0):
        super().__init__()
        self.link = link
        self.source, self.target = source, target
        self.lane = lane
        self.setFlags(QGraphicsItem.ItemIsSelectable)
        self.setZValue(-1)
        both = " (both ways)" if link.bidirectional else ""
        self.setToolTip(f"property link {link.source} -> {link.target}{both}")
        self.adjust()

    def adjust(self) -> None:
        right = QPointF(NODE_WIDTH, NODE_HEIGHT / 2)
        start, end = self.source.scenePos() + right, self.target.scenePos() + right
        bulge = QPointF(50.0 + 14.0 * self.lane, 0)
        path = QPainterPath(start)
        path.cubicTo(start + bulge, end + bulge, end)
        self.setPath(path)

    def paint(self, painter, option, widget=None) -> None:
        color = QColor("#1d4ed8") if self.isSelected() else QColor("#9333ea")
        painter.setPen(QPen(color, 2.5 if self.isSelected() else 1.5, Qt.DashLine))
        painter.setBrush(Qt.NoBrush)
        painter.drawPath(self.path())
        end = self.path().pointAtPercent(1.0)
        painter.setBrush(QBrush(color))
        painter.drawEllipse(end, 3.5, 3.5)
