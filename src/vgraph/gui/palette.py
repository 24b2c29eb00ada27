"""The processor palette: every registered type (built-in and plug-in), by category, searchable.

Double-click (or Enter) adds the type to the network; dragging drops it where it is released. The
search matches type names, categories and descriptions, case-insensitively, word by word.
"""

from __future__ import annotations

from PySide6.QtCore import QMimeData, Qt, Signal
from PySide6.QtWidgets import QLineEdit, QTreeWidget, QTreeWidgetItem, QVBoxLayout, QWidget

from vgraph.gui.scene import PROCESSOR_MIME_TYPE
from vgraph.registry import registry

TYPE_ROLE = Qt.UserRole + 1


class _TypeTree(QTreeWidget):
    """Drags carry the processor type name."""

    def mimeData(self, items):
        data = QMimeData()
        names = [item.data(0, TYPE_ROLE) for item in items if item.data(0, TYPE_ROLE)]
        if names:
            data.setData(PROCESSOR_MIME_TYPE, names[0].encode())
            data.setText(names[0])
        return data


class ProcessorPalette(QWidget):
    processor_chosen = Signal(str)  # a type name

    def __init__(self, parent=None):
        super().__init__(parent)
        self.search = QLineEdit()
        self.search.setPlaceholderText("Search processors...")
        self.search.setClearButtonEnabled(True)
        self.tree = _TypeTree()
        self.tree.setHeaderHidden(True)
        self.tree.setDragEnabled(True)
        self.tree.setDragDropMode(QTreeWidget.DragOnly)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addWidget(self.search)
        layout.addWidget(self.tree)
        self.search.textChanged.connect(self.apply_filter)
        self.search.returnPressed.connect(self._choose_first_visible)
        self.tree.itemActivated.connect(self._activated)
        self.reload()

    def reload(self) -> None:
        """Rebuild from the registry (e.g. after a plug-in was loaded)."""
        self.tree.clear()
        categories: dict[str, QTreeWidgetItem] = {}
        for cls in registry.all():
            parent = categories.get(cls.category)
            if parent is None:
                parent = categories[cls.category] = QTreeWidgetItem([cls.category])
                parent.setFlags(parent.flags() & ~Qt.ItemIsDragEnabled)
            item = QTreeWidgetItem([cls.type_name])
            item.setData(0, TYPE_ROLE, cls.type_name)
            item.setToolTip(0, _tooltip(cls))
            parent.addChild(item)
        for name in sorted(categories):
            self.tree.addTopLevelItem(categories[name])
        self.tree.expandAll()
        self.apply_filter(self.search.text())

    def apply_filter(self, text: str) -> None:
        words = text.lower().split()
        for i in range(self.tree.topLevelItemCount()):
            category = self.tree.topLevelItem(i)
            shown = 0
            for j in range(category.childCount()):
                item = category.child(j)
                haystack = f"{item.text(0)} {category.text(0)} {item.toolTip(0)}".lower()
                match = all(word in haystack for word in words)
                item.setHidden(not match)
                shown += match
            category.setHidden(shown == 0)

    def visible_types(self) -> list[str]:
        return [category.child(j).data(0, TYPE_ROLE)
                for i in range(self.tree.topLevelItemCount())
                if not (category := self.tree.topLevelItem(i)).isHidden()
                for j in range(category.childCount()) if not category.child(j).isHidden()]

    def _activated(self, item: QTreeWidgetItem, column: int = 0) -> None:
        type_name = item.data(0, TYPE_ROLE)
        if type_name:
            self.processor_chosen.emit(type_name)

    def _choose_first_visible(self) -> None:
        visible = self.visible_types()
        if visible:
            self.processor_chosen.emit(visible[0])


def _tooltip(cls) -> str:
    ports = [f"{p.direction} {p.name}: {p.type_name}" for p in (*cls.inports, *cls.outports)]
    origin = cls.__module__
    return "\n".join([cls.description or cls.type_name, *ports, f"from {origin}"])
