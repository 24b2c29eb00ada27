"""The Help menu: the documentation pages (read from the installed package, no network), the
keyboard shortcuts and About.

Conventions:
- The docs are the Markdown pages of docs/, installed as the package data ``vgraph/docs``, their
  pictures as ``vgraph/docs/images`` (about 3.4 MB, every one linked from a page); a source
  checkout (or an editable install, which maps only the code) reads the repository's docs/ folder.
- A page's relative image links resolve beside the page, wherever it is installed
  (``image_path``); pictures wider than the page's column are shown scaled down to it (again
  when the dialog is resized), so a 1920-pixel screenshot does not push the text sideways.
- The shortcut list is built from the window's actions, so it cannot drift from what the keys do.
- A link to another page opens that page in the same browser; any other link goes to the desktop.
  Links are read relative to the page shown, so pages in docs/'s folders (guide/, reference/,
  explanations/, reports/: docs/README.md says what is where) link each other and the pictures
  with ``../``. The list holds the index, then the guide, the reference's index and its
  hand-written pages, the explanations and the reports, in that order (``LISTED``); a processor's
  page (docs/reference/, written by vgraph.reference_docs) opens from the links.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import QEvent, QSize, Qt, QUrl
from PySide6.QtGui import QAction, QDesktopServices, QImage, QKeySequence, QTextCursor, QTextDocument
from PySide6.QtWidgets import (QDialog, QDialogButtonBox, QListWidget, QListWidgetItem,
                               QMessageBox, QSplitter, QTableWidget, QTableWidgetItem, QTextBrowser,
                               QVBoxLayout)

import vgraph

START_PAGE = "guide/gui.md"
REFERENCE_INDEX = "reference/index.md"   # listed; it links the processors' pages
# The pages listed, in this order (relative to docs/); titles sorted within each.
LISTED = ("*.md", "guide/*.md", REFERENCE_INDEX, "reference/general/*.md", "explanations/*.md", "reports/*.md")
MIN_IMAGE_WIDTH = 200   # px: pictures are not scaled below this, however narrow the column


def docs_folder() -> Path | None:
    """Where the Markdown pages are: inside the installed package, else the source checkout's."""
    package = Path(vgraph.__file__).resolve().parent
    for folder in (package / "docs", package.parents[1] / "docs"):
        if any(folder.glob("*.md")):
            return folder
    return None


@dataclass(frozen=True)
class Page:
    path: Path
    title: str


def page_title(path: Path) -> str:
    """The page's first level-1 heading without Markdown backticks; the file name if it has none."""
    with path.open(encoding="utf-8") as text:
        for line in text:
            if line.startswith("# "):
                return line[2:].strip().replace("`", "")
    return path.stem


def doc_pages(folder: Path | None = None) -> list[Page]:
    folder = folder if folder is not None else docs_folder()
    if folder is None:
        return []
    pages = []
    for pattern in LISTED:
        group = (Page(p, page_title(p)) for p in folder.glob(pattern))
        pages += sorted(group, key=lambda p: p.title.lower())
    return pages


def image_path(page: Path, link: str) -> Path | None:
    """The file a page's image link names: relative links beside the page; None for a link that
    is not a local file (a web address), or a file that is missing."""
    url = QUrl(link)
    if url.isRelative():
        path = page.parent / url.path()
    elif url.isLocalFile():
        path = Path(url.toLocalFile())
    else:
        return None
    return path if path.is_file() else None


def document_images(document: QTextDocument) -> list[tuple[QTextCursor, str]]:
    """(a cursor selecting the image, its link) for every image of the shown page."""
    images = []
    block = document.begin()
    while block.isValid():
        fragments = block.begin()
        while not fragments.atEnd():
            fragment = fragments.fragment()
            if fragment.charFormat().isImageFormat():
                cursor = QTextCursor(document)
                cursor.setPosition(fragment.position())
                cursor.setPosition(fragment.position() + fragment.length(), QTextCursor.KeepAnchor)
                images.append((cursor, fragment.charFormat().toImageFormat().name()))
            fragments += 1
        block = block.next()
    return images


class DocsDialog(QDialog):
    """The page list on the left, the page (rendered Markdown) on the right."""

    def __init__(self, parent=None, folder: Path | None = None):
        super().__init__(parent)
        self.setWindowTitle("vgraph documentation")
        self.folder = folder if folder is not None else docs_folder()
        self.pages = doc_pages(self.folder)
        self.list = QListWidget()
        for page in self.pages:
            item = QListWidgetItem(page.title)
            item.setData(Qt.UserRole, str(page.path))
            item.setToolTip(self._name(page.path))
            self.list.addItem(item)
        self.browser = QTextBrowser()
        self.browser.setOpenLinks(False)  # page links are followed here, the rest by the desktop
        # A scroll bar that comes and goes would change the column the pictures are fitted to.
        self.browser.setVerticalScrollBarPolicy(Qt.ScrollBarAlwaysOn)
        self.browser.viewport().installEventFilter(self)   # refit the pictures on resizes
        self.image_sizes: dict[str, QSize] = {}   # link -> natural size of the shown page's pictures
        self.shown: Path | None = None   # the page shown; its links are relative to it
        self.browser.anchorClicked.connect(self._follow)
        splitter = QSplitter()
        splitter.addWidget(self.list)
        splitter.addWidget(self.browser)
        splitter.setStretchFactor(1, 1)
        buttons = QDialogButtonBox(QDialogButtonBox.Close)
        buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addWidget(splitter, 1)
        layout.addWidget(buttons)
        self.list.currentRowChanged.connect(self._show_row)
        if not self.pages:
            self.browser.setMarkdown("No documentation pages were found in this installation.")
        else:
            if not self.show_page(START_PAGE):
                self.list.setCurrentRow(0)
        self.resize(1100, 720)
        # the titles are long ("Volumes larger than memory", ...): show them whole when they fit
        titles = min(self.list.sizeHintForColumn(0) + 24, 380)
        splitter.setSizes([titles, self.width() - titles])

    def _name(self, path: Path) -> str:
        """The page's path relative to the docs folder ("guide/gui.md"), else its file name."""
        if self.folder is not None and path.is_relative_to(self.folder):
            return path.relative_to(self.folder).as_posix()
        return path.name

    def show_page(self, name: str) -> bool:
        """Show the page ``name``, relative to the docs folder ("guide/gui.md") or a file name
        ("cli.md"); False if there is none."""
        for row, page in enumerate(self.pages):
            if name in (page.path.name, self._name(page.path)):
                self.list.setCurrentRow(row)
                return True
        return False

    def show_file(self, path: Path) -> None:
        """Show the page in file ``path``: a listed page by selecting its row, any other (a
        processor's reference page) with no row selected."""
        for row, page in enumerate(self.pages):
            if page.path.resolve() == path.resolve():
                self.list.setCurrentRow(row)
                return
        self.list.setCurrentRow(-1)
        self.list.clearSelection()
        self._show_path(path)

    def _show_row(self, row: int) -> None:
        if 0 <= row < len(self.pages):
            self._show_path(self.pages[row].path)

    def _show_path(self, path: Path) -> None:
        self.shown = path
        self.browser.setSearchPaths([str(path.parent)])  # relative images resolve beside the page
        self.browser.setMarkdown(path.read_text(encoding="utf-8"))
        self._place_images(path)

    def _place_images(self, page: Path) -> None:
        """Each picture from its file beside the page (``image_path``), fitted to the column."""
        document = self.browser.document()
        self.image_sizes = {}
        for _, link in document_images(document):
            path = image_path(page, link)
            image = QImage(str(path)) if path is not None else QImage()
            if not image.isNull():   # a missing one keeps Qt's placeholder; its link says which
                document.addResource(QTextDocument.ImageResource, QUrl(link), image)
                self.image_sizes[link] = image.size()
        self.fit_images()

    def image_width(self) -> int:
        """The widest a picture is shown: the page's column, inside the document's margins."""
        margin = self.browser.document().documentMargin()
        return max(MIN_IMAGE_WIDTH, int(self.browser.viewport().width() - 2 * margin - 4))

    def fit_images(self) -> None:
        """Pictures wider than the column scaled down to it (keeping their aspect), others natural."""
        width = self.image_width()
        for cursor, link in document_images(self.browser.document()):
            size = self.image_sizes.get(link)
            if size is None:
                continue
            picture = cursor.charFormat().toImageFormat()
            shown = min(size.width(), width)
            if picture.width() != shown:
                picture.setWidth(shown)
                picture.setHeight(size.height() * shown / size.width())
                cursor.setCharFormat(picture)

    def eventFilter(self, watched, event) -> bool:
        if watched is self.browser.viewport() and event.type() == QEvent.Resize and self.image_sizes:
            self.fit_images()
        return super().eventFilter(watched, event)

    def _follow(self, url: QUrl) -> None:
        page = self._linked_page(url)
        if page is not None:
            self.show_file(page)
            if url.fragment():
                self.browser.scrollToAnchor(url.fragment())
        elif url.isRelative() and url.fragment() and not url.path():
            self.browser.scrollToAnchor(url.fragment())
        else:
            QDesktopServices.openUrl(url)

    def _linked_page(self, url: QUrl) -> Path | None:
        """The Markdown page a link names, relative to the page shown; None for anything else (a
        web address, a picture, a page that is missing)."""
        if url.isLocalFile():
            path = Path(url.toLocalFile())
        elif url.isRelative() and url.path() and self.shown is not None:
            path = self.shown.parent / url.path()
        else:
            return None
        return path if path.suffix == ".md" and path.is_file() else None


def redo_keys(platform_keys: list[QKeySequence]) -> list[QKeySequence]:
    """The platform's redo keys plus Ctrl+Y: GNOME and KDE give only Ctrl+Shift+Z, and people
    coming from Windows press Ctrl+Y."""
    ctrl_y = QKeySequence("Ctrl+Y")
    return list(platform_keys) + ([] if ctrl_y in platform_keys else [ctrl_y])


def shortcut_rows(window) -> list[tuple[str, str]]:
    """(action text, its shortcuts) for every action of ``window`` that has a shortcut."""
    rows = []
    for action in window.findChildren(QAction):
        keys = [k.toString(QKeySequence.NativeText) for k in action.shortcuts() if not k.isEmpty()]
        if keys:
            rows.append((action.text().replace("&", "").rstrip("."), ", ".join(keys)))
    return sorted(set(rows))


class ShortcutsDialog(QDialog):
    def __init__(self, window):
        super().__init__(window)
        self.setWindowTitle("Keyboard shortcuts")
        rows = shortcut_rows(window)
        self.table = QTableWidget(len(rows), 2)
        self.table.setHorizontalHeaderLabels(["Command", "Keys"])
        self.table.verticalHeader().hide()
        self.table.setEditTriggers(QTableWidget.NoEditTriggers)
        for row, (text, keys) in enumerate(rows):
            self.table.setItem(row, 0, QTableWidgetItem(text))
            self.table.setItem(row, 1, QTableWidgetItem(keys))
        self.table.resizeColumnsToContents()
        self.table.horizontalHeader().setStretchLastSection(True)
        buttons = QDialogButtonBox(QDialogButtonBox.Close)
        buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addWidget(self.table)
        layout.addWidget(buttons)
        self.resize(460, 560)


def about_text() -> str:
    return (f"<b>vgraph {vgraph.__version__}</b><p>A node-graph framework for volume visualization "
            f"on one shared OpenGL context.</p><p>Help > Documentation has the manual; "
            f"<code>vgraph --help</code> lists the commands.</p>")


def build_help_menu(window) -> None:
    menu = window.menuBar().addMenu("&Help")
    window.docs_action = QAction("&Documentation", window)
    window.docs_action.setShortcut(QKeySequence.HelpContents)
    window.docs_action.triggered.connect(lambda *_: DocsDialog(window).exec())
    window.shortcuts_action = QAction("&Keyboard Shortcuts", window)
    window.shortcuts_action.triggered.connect(lambda *_: ShortcutsDialog(window).exec())
    window.about_action = QAction("&About vgraph", window)
    window.about_action.triggered.connect(lambda *_: QMessageBox.about(window, "About vgraph", about_text()))
    menu.addActions([window.docs_action, window.shortcuts_action, window.about_action])
