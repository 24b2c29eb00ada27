"""The property-link dialog: see, add and remove links between properties of one kind.

The leader list holds every property of the network; the follower list only the properties a link
from the chosen leader could reach (same kind, not itself, not already linked with it). Every
change goes through the workspace, so it is undoable. Links also show in the editor as dashed
arcs, which can be selected and deleted there.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDialog, QDialogButtonBox, QFormLayout, QLabel,
                               QListWidget, QListWidgetItem, QPushButton, QVBoxLayout)

from vgraph.errors import VGraphError
from vgraph.gui.workspace import Workspace
from vgraph.network import Network

LINK_ROLE = Qt.UserRole + 1


def property_addresses(network: Network) -> list[tuple[str, str]]:
    """(address, kind) of every property, in network order."""
    return [(f"{p.id}.{name}", prop.kind) for p in network.processors.values()
            for name, prop in p.properties.items()]


def link_candidates(network: Network, leader: str) -> list[str]:
    """Properties a link from ``leader`` may go to."""
    kinds = dict(property_addresses(network))
    linked = {frozenset((l.source, l.target)) for l in network.links}
    return [address for address, kind in kinds.items()
            if kind == kinds.get(leader) and address != leader
            and frozenset((leader, address)) not in linked]


class LinkDialog(QDialog):
    def __init__(self, workspace: Workspace, parent=None):
        super().__init__(parent)
        self.setWindowTitle("Property links")
        self.workspace = workspace
        self.links = QListWidget()
        self.remove_button = QPushButton("Remove selected link")
        self.remove_button.clicked.connect(self.remove_selected)
        self.leader = QComboBox()
        self.follower = QComboBox()
        self.both_ways = QCheckBox("both ways")
        self.add_button = QPushButton("Add link")
        self.add_button.clicked.connect(self.add_link)
        self.message = QLabel()
        self.message.setWordWrap(True)
        form = QFormLayout()
        form.addRow("leader", self.leader)
        form.addRow("follower", self.follower)
        form.addRow("", self.both_ways)
        buttons = QDialogButtonBox(QDialogButtonBox.Close)
        buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addWidget(QLabel("Existing links (the follower takes the leader's value):"))
        layout.addWidget(self.links)
        layout.addWidget(self.remove_button)
        layout.addLayout(form)
        layout.addWidget(self.add_button)
        layout.addWidget(self.message)
        layout.addWidget(buttons)
        self.leader.currentTextChanged.connect(self._fill_followers)
        self.refresh()

    def refresh(self) -> None:
        network = self.workspace.network
        self.links.clear()
        for link in network.links:
            arrow = "<->" if link.bidirectional else "->"
            item = QListWidgetItem(f"{link.source} {arrow} {link.target}")
            item.setData(LINK_ROLE, link)
            self.links.addItem(item)
        current = self.leader.currentText()
        self.leader.blockSignals(True)
        self.leader.clear()
        self.leader.addItems([f"{address}" for address, _ in property_addresses(network)])
        if current:
            self.leader.setCurrentText(current)
        self.leader.blockSignals(False)
        self._fill_followers(self.leader.currentText())

    def _fill_followers(self, leader: str) -> None:
        self.follower.clear()
        if leader:
            self.follower.addItems(link_candidates(self.workspace.network, leader))
        self.add_button.setEnabled(self.follower.count() > 0)

    def add_link(self) -> None:
        try:
            self.workspace.link(self.leader.currentText(), self.follower.currentText(),
                                bidirectional=self.both_ways.isChecked())
        except VGraphError as error:
            self.message.setText(str(error))
            return
        self.message.setText("")
        self.refresh()

    def remove_selected(self) -> None:
        item = self.links.currentItem()
        if item is not None:
            self.workspace.unlink(item.data(LINK_ROLE))
            self.refresh()
