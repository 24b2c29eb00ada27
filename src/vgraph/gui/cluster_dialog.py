"""Network > Render on Cluster...: the cluster setting, stored with the GUI's other preferences.

QSettings keys (the Workspace's settings, so tests use their own file): ``cluster/address``
(``local:N`` or ``tcp://HOST:PORT`` as ``vgraph run --cluster`` takes it; empty: render in the
render process), ``cluster/split`` and ``cluster/tiles`` (``CxR``). The window passes the setting
to ``LiveEvaluation.set_cluster``; the render process does the rest (``vgraph.live.cluster``).
"""

from __future__ import annotations

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import (QComboBox, QDialog, QDialogButtonBox, QFormLayout, QLabel, QLineEdit,
                               QVBoxLayout)

from vgraph.distributed import SPLITS, parse_cluster, parse_grid
from vgraph.errors import VGraphError
from vgraph.live.cluster import ClusterSetting


def parse_setting(address: str, split: str = "tiles", tiles: str = "2x2") -> ClusterSetting | None:
    """The setting from its three texts (None for an empty address); a bad one raises VGraphError
    naming what is wrong, as ``vgraph run --cluster`` would."""
    address = address.strip()
    if not address:
        return None
    parse_cluster(address)
    if split not in SPLITS:
        raise VGraphError(f"unknown split '{split}'; choose one of {', '.join(SPLITS)}")
    return ClusterSetting(address, split, parse_grid(tiles))


def load_setting(settings: QSettings) -> ClusterSetting | None:
    """The stored setting; a stored value that no longer parses counts as none (never an error
    at start-up)."""
    try:
        return parse_setting(str(settings.value("cluster/address", "") or ""),
                             str(settings.value("cluster/split", "tiles") or "tiles"),
                             str(settings.value("cluster/tiles", "2x2") or "2x2"))
    except VGraphError:
        return None


def save_setting(settings: QSettings, setting: ClusterSetting | None) -> None:
    if setting is None:
        settings.setValue("cluster/address", "")
        return
    settings.setValue("cluster/address", setting.address)
    settings.setValue("cluster/split", setting.split)
    settings.setValue("cluster/tiles", f"{setting.tiles[0]}x{setting.tiles[1]}")


class ClusterDialog(QDialog):
    """Address, split and tiles; OK refuses a value that does not parse and says why."""

    def __init__(self, setting: ClusterSetting | None, parent=None):
        super().__init__(parent)
        self.setWindowTitle("Render on Cluster")
        self.address = QLineEdit(setting.address if setting else "")
        self.address.setPlaceholderText("local:2 or tcp://HOST:PORT (empty: render here)")
        self.split = QComboBox()
        self.split.addItems(list(SPLITS))
        self.split.setCurrentText(setting.split if setting else "tiles")
        self.tiles = QLineEdit(f"{setting.tiles[0]}x{setting.tiles[1]}" if setting else "2x2")
        self.problem = QLabel("")
        form = QFormLayout()
        form.addRow("Cluster", self.address)
        form.addRow("Split", self.split)
        form.addRow("Tiles (columns x rows)", self.tiles)
        buttons = QDialogButtonBox(QDialogButtonBox.Ok | QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addWidget(QLabel("Final frames are drawn by the cluster's workers; frames while "
                                "dragging stay here. The workers must see the network's files "
                                "at the same paths."))
        layout.addLayout(form)
        layout.addWidget(self.problem)
        layout.addWidget(buttons)

    def setting(self) -> ClusterSetting | None:
        return parse_setting(self.address.text(), self.split.currentText(), self.tiles.text())

    def accept(self) -> None:
        try:
            self.setting()
        except VGraphError as error:
            self.problem.setText(str(error))
            return
        super().accept()
