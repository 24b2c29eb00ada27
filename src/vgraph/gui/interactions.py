"""Mouse interactions of the network editor, one class per interaction (as in orange-canvas-core).

``ConnectInteraction``: press on an outport, drag, release on an inport. While dragging, every
inport is judged with ``Network.check_connection`` on the hypothetical connection: acceptable ones
are highlighted, refused ones greyed; hovering a refused one puts the network's reason in the status
bar, and releasing on it keeps the reason there (nothing is connected). Releasing on an acceptable
inport connects through the undo stack; a taken single inport is acceptable: its connection is
replaced (one undo step, ``Workspace.connect(replacing=True)``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from PySide6.QtCore import QPointF, Qt
from PySide6.QtGui import QPen
from PySide6.QtWidgets import QGraphicsPathItem

from vgraph.errors import VGraphError
from vgraph.gui.items import PortItem, connection_path, port_color
from vgraph.network import Connection

if TYPE_CHECKING:
    from vgraph.gui.scene import NetworkScene


class ConnectInteraction:
    def __init__(self, scene: "NetworkScene", source: PortItem):
        self.scene = scene
        self.source = source
        self.refusals: dict[PortItem, str | None] = {}
        self.line = QGraphicsPathItem()
        self.line.setPen(QPen(port_color(source.port.type_name), 2, Qt.DashLine))
        self.line.setZValue(3)
        scene.addItem(self.line)
        self._judge_inports()
        compatible = sum(reason is None for reason in self.refusals.values())
        scene.status_message.emit(f"Connecting {source.address} ({source.port.type_name}): "
                                  f"{compatible} compatible inport{'s' if compatible != 1 else ''}")

    def _judge_inports(self) -> None:
        for node in self.scene.nodes.values():
            for port in node.ports.values():
                if port.direction != "in":
                    continue
                reason = self.scene.workspace.connection_refusal(self.connection_to(port), replacing=True)
                self.refusals[port] = reason
                port.highlight("compatible" if reason is None else "refused")

    def connection_to(self, inport: PortItem) -> Connection:
        return Connection(self.source.node.processor_id, self.source.port.name,
                          inport.node.processor_id, inport.port.name)

    def inport_at(self, scene_pos: QPointF) -> PortItem | None:
        for item in self.scene.items(scene_pos):
            if isinstance(item, PortItem) and item in self.refusals:
                return item
        return None

    def move(self, scene_pos: QPointF) -> None:
        target = self.inport_at(scene_pos)
        end = target.scenePos() if target is not None else scene_pos
        self.line.setPath(connection_path(self.source.scenePos(), end))
        if target is not None:
            reason = self.refusals[target]
            connection = self.connection_to(target)
            replaced = self.scene.workspace.replaced_by(connection)
            self.scene.status_message.emit(
                f"Refused: {reason}" if reason else
                f"Release to replace {replaced} by {connection}" if replaced else
                f"Release to connect {connection}")

    def finish(self, scene_pos: QPointF) -> Connection | None:
        """Connect if released on an acceptable inport; returns the connection made."""
        target = self.inport_at(scene_pos)
        self.cancel()
        if target is None:
            self.scene.status_message.emit("")
            return None
        reason = self.refusals[target]
        if reason is not None:
            self.scene.status_message.emit(f"Refused: {reason}")
            return None
        connection = self.connection_to(target)
        try:
            self.scene.workspace.connect(f"{connection.source}.{connection.outport}",
                                         f"{connection.target}.{connection.inport}", replacing=True)
        except VGraphError as error:  # the network changed under the drag: report, do not crash
            self.scene.status_message.emit(f"Refused: {error}")
            return None
        self.scene.status_message.emit(f"Connected {connection}")
        return connection

    def cancel(self) -> None:
        for port in self.refusals:
            port.highlight(None)
        self.scene.removeItem(self.line)
