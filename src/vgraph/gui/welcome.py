"""The welcome page: what the network editor's place shows while the window has no network.

It offers what starts the work: *Open Volume, Mesh or Network...* (File > Open's dialog; a volume
or mesh file opens as the whole network around it: vgraph.volume_network / mesh_network), *Empty
Network* (the editor, to build one from the palette), the shipped example networks
(networks/*.json, with the thumbnails bench/make_network_thumbnails.py renders into
networks/thumbnails: shipped, so nothing is rendered or downloaded here) and the recent files. A
file dropped onto the page opens as File > Open would open it.

Conventions:
- ``WelcomeSwitch`` holds the central widget, a stack of this page and the network editor: the page
  shows when a network with no processors is put in place (the first window, File > New) and goes
  when one with processors is opened, when a processor is added (the palette still works) or when
  *Empty Network* is chosen.
- The page asks the window through signals; it opens nothing itself.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import QObject, QSize, Qt, Signal
from PySide6.QtGui import QIcon, QPixmap
from PySide6.QtWidgets import (QFrame, QHBoxLayout, QLabel, QListView, QListWidget, QListWidgetItem,
                               QPushButton, QScrollArea, QStackedWidget, QVBoxLayout, QWidget)

import vgraph

THUMBNAIL_SIZE = 128   # px, the thumbnails' longer side
ICON_SIZE = 96         # px, as the page shows them: two or three a row in the editor's column


def examples_folder() -> Path | None:
    """The shipped networks: a source checkout's networks/ folder (None where there is none)."""
    folder = Path(vgraph.__file__).resolve().parents[2] / "networks"
    return folder if any(folder.glob("*.json")) else None


@dataclass(frozen=True)
class Example:
    path: Path
    description: str
    thumbnail: Path | None


def shipped_examples(folder: Path | None) -> list[Example]:
    """The example networks in ``folder``, by name, with their description and thumbnail."""
    if folder is None:
        return []
    examples = []
    for path in sorted(folder.glob("*.json")):
        try:
            description = json.loads(path.read_text(encoding="utf-8")).get("description", "")
        except (OSError, ValueError, AttributeError):
            description = ""   # opening it will name what is wrong
        thumbnail = folder / "thumbnails" / f"{path.stem}.png"
        examples.append(Example(path, description, thumbnail if thumbnail.is_file() else None))
    return examples


def dropped_file(mime) -> str | None:
    """The first local file of a drag, if any."""
    for url in mime.urls() if mime.hasUrls() else []:
        if url.isLocalFile():
            return url.toLocalFile()
    return None


class WelcomePage(QWidget):
    open_requested = Signal(str)     # a network, volume or mesh file to open
    open_dialog_requested = Signal()
    empty_requested = Signal()

    def __init__(self, examples: list[Example], parent: QWidget | None = None):
        super().__init__(parent)
        self.setAcceptDrops(True)
        title = QLabel("<h2>Start</h2>Open a volume or mesh file (or drop it here): vgraph builds the "
                       "network that renders it. Or open an example network, or build one from the palette.")
        title.setWordWrap(True)
        self.open_button = QPushButton("Open Volume, Mesh or Network...")
        self.open_button.clicked.connect(self.open_dialog_requested)
        self.empty_button = QPushButton("Empty Network")
        self.empty_button.clicked.connect(self.empty_requested)
        buttons = QHBoxLayout()
        buttons.addWidget(self.open_button)
        buttons.addWidget(self.empty_button)
        buttons.addStretch(1)
        self.examples = self._example_list(examples)
        self.recent = QListWidget()
        self.recent.itemActivated.connect(self._open_item)
        self.recent.itemClicked.connect(self._open_item)
        layout = QVBoxLayout(self)
        layout.addWidget(title)
        layout.addLayout(buttons)
        layout.addWidget(QLabel("<b>Example networks</b>"))
        layout.addWidget(self.examples, 3)
        layout.addWidget(QLabel("<b>Recent files</b>"))
        layout.addWidget(self.recent, 1)

    def _example_list(self, examples: list[Example]) -> QListWidget:
        listing = QListWidget()
        listing.setViewMode(QListView.IconMode)
        listing.setIconSize(QSize(ICON_SIZE, ICON_SIZE))
        listing.setGridSize(QSize(ICON_SIZE + 48, ICON_SIZE + 40))
        listing.setResizeMode(QListView.Adjust)
        listing.setMovement(QListView.Static)
        listing.setWordWrap(True)
        for example in examples:
            item = QListWidgetItem(example.path.stem)
            if example.thumbnail is not None:
                item.setIcon(QIcon(QPixmap(str(example.thumbnail))))
            item.setToolTip(example.description or str(example.path))
            item.setData(Qt.UserRole, str(example.path))
            listing.addItem(item)
        listing.itemClicked.connect(self._open_item)
        listing.itemActivated.connect(self._open_item)
        return listing

    def set_recent_files(self, files: list[str]) -> None:
        self.recent.clear()
        for path in files:
            item = QListWidgetItem(path)
            item.setData(Qt.UserRole, path)
            self.recent.addItem(item)

    def _open_item(self, item: QListWidgetItem) -> None:
        self.open_requested.emit(item.data(Qt.UserRole))

    def dragEnterEvent(self, event) -> None:
        if dropped_file(event.mimeData()) is not None:
            event.acceptProposedAction()
        else:
            event.ignore()

    def dragMoveEvent(self, event) -> None:
        self.dragEnterEvent(event)

    def dropEvent(self, event) -> None:
        path = dropped_file(event.mimeData())
        if path is not None:
            event.acceptProposedAction()
            self.open_requested.emit(path)


class WelcomeSwitch(QObject):
    """The window's central widget: the welcome page or the network editor (module docstring)."""

    def __init__(self, window, examples: list[Example] | None = None):
        super().__init__(window)
        self.window = window
        self.page = WelcomePage(shipped_examples(examples_folder()) if examples is None else examples)
        self.scroll = QScrollArea()   # the page must not widen the window's middle column
        self.scroll.setWidgetResizable(True)
        self.scroll.setFrameShape(QFrame.NoFrame)
        self.scroll.setWidget(self.page)
        self.stack = QStackedWidget()
        self.stack.addWidget(self.scroll)
        self.stack.addWidget(window.view)
        self.network = None
        self.page.open_requested.connect(lambda path: window.open_network(path))
        self.page.open_dialog_requested.connect(lambda: window.open_network())
        self.page.empty_requested.connect(self.show_editor)
        workspace = window.workspace
        self.page.set_recent_files(workspace.recent_files())
        workspace.recent_files_changed.connect(self.page.set_recent_files)
        workspace.network_replaced.connect(self._follow)
        self._follow(workspace.network)

    def showing(self) -> bool:
        return self.stack.currentWidget() is self.scroll

    def show_editor(self) -> None:
        self.stack.setCurrentWidget(self.window.view)

    def _follow(self, network) -> None:
        if self.network is not None:
            self.network.unsubscribe(self._on_event)
        self.network = network
        network.subscribe(self._on_event)
        self.stack.setCurrentWidget(self.window.view if network.processors else self.scroll)

    def _on_event(self, event: str, **_details) -> None:
        if event == "processor_added":
            self.show_editor()

    def detach(self) -> None:
        if self.network is not None:
            self.network.unsubscribe(self._on_event)
            self.network = None
