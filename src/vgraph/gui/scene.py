"""The network editor: a QGraphicsScene that is a view of the workspace's Network, and its view.

Conventions:
- The scene builds its items from the network and then follows the network's events
  (processor_added/removed, connected/disconnected, linked/unlinked, property_changed, moved,
  evaluated); it never changes the model itself: edits go to the Workspace (undo commands).
- Nodes follow ``moved`` events (a move command, its undo and redo); a drag moves the node items
  itself and writes the positions back as one Move command on release.
- Drops from the palette carry the processor type name as ``PROCESSOR_MIME_TYPE``.
- Connections go around unrelated nodes (edge_routing.py). A node that moves re-routes its own
  connections, those it now lies on and those that went around it; the rest keep their course.
  New processors (added or dropped) go to the nearest spot covering no node and no connection;
  one added after another (``spot_after``) asks for the spot below it when it takes its data,
  else beside it (placement.py). ``last_added`` is the anchor when nothing is selected.
"""

from __future__ import annotations

from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QPainter, QTransform
from PySide6.QtWidgets import QGraphicsScene, QGraphicsView

from vgraph.errors import VGraphError
from vgraph.gui.edge_routing import LANE_STEP, MARGIN, Box, free_spot
from vgraph.live.evaluator import processor_status
from vgraph.gui.interactions import ConnectInteraction
from vgraph.gui.placement import feeds, spot_after
from vgraph.gui.items import NODE_HEIGHT, NODE_WIDTH, EdgeItem, LinkItem, NodeItem, PortItem
from vgraph.gui.workspace import Workspace
from vgraph.network import Connection, Link, Network
from vgraph.registry import registry

PROCESSOR_MIME_TYPE = "application/x-vgraph-processor-type"
SCENE_EXTENT = 20000.0
LANES = 4  # routed connections take lanes 0, 1, 2, 3, 0, ... in the order they were made
STRUCTURE_EVENTS = {"processor_added", "processor_removed", "connected", "disconnected",
                    "linked", "unlinked"}


class NetworkScene(QGraphicsScene):
    status_message = Signal(str)

    def __init__(self, workspace: Workspace, parent=None, status_of=None):
        super().__init__(parent)
        self.workspace = workspace
        self.status_of = status_of or (lambda pid: processor_status(self.network, self.network[pid]))
        self.network: Network | None = None
        self.nodes: dict[str, NodeItem] = {}
        self.edges: dict[Connection, EdgeItem] = {}
        self.link_items: dict[Link, LinkItem] = {}
        self.links_visible = True
        self.interaction: ConnectInteraction | None = None
        self.last_added: str | None = None
        self.setSceneRect(QRectF(-SCENE_EXTENT / 2, -SCENE_EXTENT / 2, SCENE_EXTENT, SCENE_EXTENT))
        workspace.network_replaced.connect(self.set_network)
        self.set_network(workspace.network)

    # --- following the model --------------------------------------------------------------------
    def set_network(self, network: Network) -> None:
        self.detach()
        self.clear()
        self.nodes.clear(), self.edges.clear(), self.link_items.clear()
        self.network = network
        self.last_added = None
        network.subscribe(self._on_event)
        for processor in network.processors.values():
            self._add_node(processor)
        for connection in network.connections:
            self._add_edge(connection)
        self._rebuild_links()
        self.refresh_states()

    def detach(self) -> None:
        """Stop following the current network (before it is replaced or the window closes)."""
        if self.network is not None:
            self.network.unsubscribe(self._on_event)

    def _on_event(self, event: str, **details) -> None:
        if event == "processor_added":
            self._add_node(details["processor"])
        elif event == "processor_removed":
            node = self.nodes.pop(details["processor"].id, None)
            if node is not None:
                self.removeItem(node)
                self._reroute_around(node.processor_id, None)
        elif event == "connected":
            self._add_edge(details["connection"])
        elif event == "disconnected":
            edge = self.edges.pop(details["connection"], None)
            if edge is not None:
                self.removeItem(edge)
        elif event in ("linked", "unlinked"):
            self._rebuild_links()
        elif event == "moved":
            node = self.nodes.get(details["processor"].id)
            if node is not None and (node.x(), node.y()) != details["position"]:
                node.setPos(*details["position"])  # the node's itemChange adjusts its edges
        if event in STRUCTURE_EVENTS or event in ("property_changed", "evaluated"):
            self.refresh_states()

    def _add_node(self, processor) -> NodeItem:
        node = NodeItem(processor)
        self.nodes[processor.id] = node
        self.addItem(node)
        self._reroute_around(processor.id, node_box(node))  # it may sit on a connection
        return node

    def _add_edge(self, connection: Connection) -> EdgeItem:
        source = self.nodes[connection.source].port("out", connection.outport)
        target = self.nodes[connection.target].port("in", connection.inport)
        edge = EdgeItem(connection, source, target)
        edge.lane = LANE_STEP * (len(self.edges) % LANES)
        edge.adjust(self.obstacles_of(edge))
        self.edges[connection] = edge
        self.addItem(edge)
        return edge

    def _rebuild_links(self) -> None:
        for item in self.link_items.values():
            self.removeItem(item)
        self.link_items.clear()
        lanes: dict[frozenset, int] = {}
        for link in self.network.links:
            ends = (link.source.split(".")[0], link.target.split(".")[0])
            pair = frozenset(ends)
            item = LinkItem(link, self.nodes[ends[0]], self.nodes[ends[1]], lanes.get(pair, 0))
            lanes[pair] = lanes.get(pair, 0) + 1
            item.setVisible(self.links_visible)
            self.link_items[link] = item
            self.addItem(item)

    def refresh_states(self) -> None:
        for pid, node in self.nodes.items():
            if pid in self.network:
                node.set_status(self.status_of(pid))

    def obstacles_of(self, edge: EdgeItem) -> dict[str, Box]:
        """The nodes a connection must not run under: all but its own two."""
        ends = (edge.source.node, edge.target.node)
        return {pid: node_box(node) for pid, node in self.nodes.items() if node not in ends}

    def _reroute_around(self, processor_id: str, box: Box | None) -> None:
        """Re-route the connections a node at ``box`` (None: gone) may change: those that went
        around it (its old place) and those it now lies on."""
        grown = box.inflated(MARGIN) if box is not None else None
        for edge in self.edges.values():
            if processor_id in (edge.connection.source, edge.connection.target):
                continue
            if processor_id in edge.route.avoided or (grown is not None and edge.route.crosses(grown)):
                edge.adjust(self.obstacles_of(edge))

    def node_moved(self, node: NodeItem) -> None:
        for edge in self.edges.values():
            if node in (edge.source.node, edge.target.node):
                edge.adjust(self.obstacles_of(edge))
        if self.nodes.get(node.processor_id) is node:
            self._reroute_around(node.processor_id, node_box(node))
        for item in self.link_items.values():
            if node in (item.source, item.target):
                item.adjust()

    def set_links_visible(self, visible: bool) -> None:
        self.links_visible = visible
        for item in self.link_items.values():
            item.setVisible(visible)

    # --- selection ------------------------------------------------------------------------------
    def selection(self) -> tuple[list[str], list[Connection], list[Link]]:
        items = self.selectedItems()
        return ([i.processor_id for i in items if isinstance(i, NodeItem)],
                [i.connection for i in items if isinstance(i, EdgeItem)],
                [i.link for i in items if isinstance(i, LinkItem)])

    def delete_selected(self) -> None:
        processors, connections, links = self.selection()
        self.workspace.remove(processors, connections, links)

    def anchor(self) -> str | None:
        """The processor a new one follows: the one selected, else the last added (if still there)."""
        processors = self.selection()[0]
        if len(processors) == 1:
            return processors[0]
        return self.last_added if self.last_added in self.nodes else None

    def spot_after(self, anchor_id: str, type_name: str) -> tuple[float, float]:
        """Where a ``type_name`` processor added after ``anchor_id`` goes: below it when it takes
        its data, else to its right, moved to the nearest free spot."""
        node = self.nodes[anchor_id]
        fed = feeds(self.network[anchor_id], registry.get(type_name))
        x, y = spot_after((node.x(), node.y()), (NODE_WIDTH, NODE_HEIGHT), fed)
        return self.free_position(QPointF(x, y), centred=False)

    def select_processor(self, processor_id: str) -> None:
        self.last_added = processor_id
        self.clearSelection()
        self.nodes[processor_id].setSelected(True)

    def free_position(self, around: QPointF, centred: bool = True) -> tuple[float, float]:
        """The top-left corner of the spot nearest ``around`` (the node's centre there, or its
        corner if not ``centred``) where a new node covers no node and no connection; spots below
        come first, so processors added one after another line up downwards, as data flows."""
        x, y = around.x(), around.y()
        if centred:
            x, y = x - NODE_WIDTH / 2, y - NODE_HEIGHT / 2
        return free_spot((x, y), (NODE_WIDTH, NODE_HEIGHT), [node_box(n) for n in self.nodes.values()],
                         [edge.route.points for edge in self.edges.values()])

    # --- mouse ----------------------------------------------------------------------------------
    def mousePressEvent(self, event) -> None:
        transform = self.views()[0].transform() if self.views() else QTransform()
        item = self.itemAt(event.scenePos(), transform)
        if event.button() == Qt.LeftButton and isinstance(item, PortItem) and item.direction == "out":
            self.interaction = ConnectInteraction(self, item)
            self.interaction.move(event.scenePos())
            event.accept()
            return
        super().mousePressEvent(event)

    def mouseMoveEvent(self, event) -> None:
        if self.interaction is not None:
            self.interaction.move(event.scenePos())
            event.accept()
            return
        super().mouseMoveEvent(event)

    def mouseReleaseEvent(self, event) -> None:
        if self.interaction is not None:
            interaction, self.interaction = self.interaction, None
            interaction.finish(event.scenePos())
            event.accept()
            return
        super().mouseReleaseEvent(event)
        moved = {pid: (node.x(), node.y()) for pid, node in self.nodes.items()
                 if pid in self.network and tuple(self.network[pid].position) != (node.x(), node.y())}
        if moved:
            self.workspace.move(moved)

    # --- drops from the palette -----------------------------------------------------------------
    def dragEnterEvent(self, event) -> None:
        event.setAccepted(event.mimeData().hasFormat(PROCESSOR_MIME_TYPE))

    def dragMoveEvent(self, event) -> None:
        event.setAccepted(event.mimeData().hasFormat(PROCESSOR_MIME_TYPE))

    def dropEvent(self, event) -> None:
        if not event.mimeData().hasFormat(PROCESSOR_MIME_TYPE):
            event.ignore()
            return
        type_name = bytes(event.mimeData().data(PROCESSOR_MIME_TYPE)).decode()
        try:
            processor = self.workspace.add_processor(type_name, self.free_position(event.scenePos(), centred=False))
        except VGraphError as error:
            self.status_message.emit(f"Cannot add {type_name}: {error}")
        else:
            self.select_processor(processor.id)
        event.acceptProposedAction()


def node_box(node: NodeItem) -> Box:
    return Box.of(node.x(), node.y(), NODE_WIDTH, NODE_HEIGHT)


class NetworkView(QGraphicsView):
    """Zoom with the wheel (around the cursor), pan with the middle button, rubber-band select."""

    ZOOM_STEP = 1.15

    def __init__(self, scene: NetworkScene, parent=None):
        super().__init__(scene, parent)
        self.setRenderHints(QPainter.Antialiasing | QPainter.TextAntialiasing)
        self.setDragMode(QGraphicsView.RubberBandDrag)
        self.setTransformationAnchor(QGraphicsView.AnchorUnderMouse)
        self.setAcceptDrops(True)
        self._pan_from: QPointF | None = None

    def wheelEvent(self, event) -> None:
        steps = event.angleDelta().y() / 120.0
        if steps:
            self.zoom(self.ZOOM_STEP ** steps)

    def zoom(self, factor: float) -> None:
        current = self.transform().m11()
        factor = min(max(current * factor, 0.2), 4.0) / current
        self.scale(factor, factor)

    def fit_network(self) -> None:
        nodes = self.scene().nodes.values()
        if nodes:
            rect = QRectF()
            for node in nodes:
                rect = rect.united(node.sceneBoundingRect())
            self.fitInView(rect.adjusted(-60, -60, 60, 60), Qt.KeepAspectRatio)
            if self.transform().m11() > 1.5:
                self.resetTransform()
                self.centerOn(rect.center())

    def mousePressEvent(self, event) -> None:
        if event.button() == Qt.MiddleButton:
            self._pan_from = event.position()
            self.viewport().setCursor(Qt.ClosedHandCursor)
            event.accept()
            return
        super().mousePressEvent(event)

    def mouseMoveEvent(self, event) -> None:
        if self._pan_from is not None:
            delta = event.position() - self._pan_from
            self._pan_from = event.position()
            self.horizontalScrollBar().setValue(self.horizontalScrollBar().value() - int(delta.x()))
            self.verticalScrollBar().setValue(self.verticalScrollBar().value() - int(delta.y()))
            event.accept()
            return
        super().mouseMoveEvent(event)

    def mouseReleaseEvent(self, event) -> None:
        if event.button() == Qt.MiddleButton and self._pan_from is not None:
            self._pan_from = None
            self.viewport().unsetCursor()
            event.accept()
            return
        super().mouseReleaseEvent(event)
