"""The window as a daily tool: a first-run layout that fits the screen, the layout remembered
between runs, the View menu's docks and Reset Layout, Ctrl+Y, Save As's suggested path, and the
Help menu (docs read from the package, shortcuts built from the actions, About)."""

from PySide6.QtCore import QSettings, Qt, QUrl
from PySide6.QtGui import QKeySequence
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QDockWidget

from vgraph.gui import layout
from vgraph.gui.help import DocsDialog, redo_keys, ShortcutsDialog, doc_pages, docs_folder, shortcut_rows

from helpers.paths import REPO


def new_window(qtbot, settings_path, renderer):
    from vgraph.gui.app import MainWindow
    window = MainWindow(QSettings(str(settings_path), QSettings.IniFormat), renderer)
    window.show()
    qtbot.waitExposed(window)
    return window


def close(window):
    window.workspace.undo_stack.setClean()
    window.close()
    window.deleteLater()


def test_first_run_fits_the_available_screen(window):
    available = window.screen().availableGeometry()
    assert window.width() <= available.width() and window.height() <= available.height()
    expected = max(int(available.width() * layout.FIRST_RUN_FRACTION), min(available.width(), layout.SMALL_SCREEN[0]))
    assert abs(window.width() - expected) <= 2
    # the right column fits the widest editor (up to half the window)
    column = window.properties_dock.width()
    assert column >= min(layout.widest_editor_width(), window.width() // 2) - 8


def test_geometry_and_dock_state_come_back_from_the_settings(qtbot, tmp_path, renderer):
    window = new_window(qtbot, tmp_path / "settings.ini", renderer)   # closed here, not by a fixture
    window.resize(700, 560)   # within the offscreen screen (800 x 800): Qt fits restored windows in
    window.move(40, 30)
    window.resizeDocks([window.properties_dock], [333], Qt.Horizontal)
    window.removeDockWidget(window.log_dock)
    window.addDockWidget(Qt.LeftDockWidgetArea, window.log_dock)
    window.log_dock.show()
    qtbot.wait(50)
    size, width = window.size(), window.properties_dock.width()
    assert window.dockWidgetArea(window.log_dock) == Qt.LeftDockWidgetArea
    close(window)

    again = new_window(qtbot, tmp_path / "settings.ini", renderer)
    try:
        qtbot.wait(50)
        assert again.size() == size
        assert again.dockWidgetArea(again.log_dock) == Qt.LeftDockWidgetArea
        assert abs(again.properties_dock.width() - width) <= 2
        layout.reset_layout(again)   # Reset Layout: the docks go home and the stored layout is gone
        assert again.dockWidgetArea(again.log_dock) == Qt.BottomDockWidgetArea
        assert again.workspace.settings.value(layout.STATE_KEY) is None
    finally:
        close(again)


def test_a_closed_dock_comes_back_from_the_view_menu(window, qtbot):
    window.workspace.add_processor("Canvas", id="canvas")
    canvas_dock = window.canvases.docks["canvas"]
    window.refresh_dock_menu()
    docks = window.findChildren(QDockWidget)
    listed = {action.text() for action in window.view_menu.actions()}
    assert {dock.windowTitle() for dock in docks} <= listed and "Canvas: canvas" in listed
    assert window.reset_layout_action in window.view_menu.actions()

    canvas_dock.close()
    qtbot.waitUntil(lambda: not canvas_dock.isVisible())
    action = next(a for a in window.view_menu.actions() if a.text() == "Canvas: canvas")
    assert not action.isChecked()
    action.trigger()
    qtbot.waitUntil(canvas_dock.isVisible)


def test_ctrl_y_redoes(window, qtbot):
    window.workspace.add_processor("FunctionSelector", id="f")
    stack = window.workspace.undo_stack
    window.activateWindow()
    window.view.setFocus()
    QTest.keyClick(window.view, Qt.Key_Z, Qt.ControlModifier)
    qtbot.waitUntil(lambda: "f" not in window.workspace.network)
    QTest.keyClick(window.view, Qt.Key_Y, Qt.ControlModifier)
    qtbot.waitUntil(lambda: "f" in window.workspace.network)
    # let go of Ctrl: Qt keeps the last key event's modifiers as the application's, and a later
    # test's selectRow would extend a selection as if Ctrl were held
    QTest.keyRelease(window.view, Qt.Key_Control)
    assert stack.index() == 1
    assert QKeySequence("Ctrl+Y") in window.redo_action.shortcuts()
    assert QKeySequence.keyBindings(QKeySequence.Redo)[0] in window.redo_action.shortcuts()
    # offscreen Qt already binds Ctrl+Y; GNOME and KDE do not, and the window adds it there
    gnome = [QKeySequence("Ctrl+Shift+Z")]
    assert redo_keys(gnome) == [QKeySequence("Ctrl+Shift+Z"), QKeySequence("Ctrl+Y")]
    assert redo_keys(redo_keys(gnome)) == redo_keys(gnome)


def test_save_as_suggests_the_current_file(window, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert window.suggested_save_path() == str(tmp_path / "untitled.json")
    window.workspace.add_processor("FunctionSelector", id="f")
    (tmp_path / "sub").mkdir()
    assert window.save_network_as(tmp_path / "sub" / "mine.json")
    assert window.suggested_save_path() == str(tmp_path / "sub" / "mine.json")


def test_docs_dialog_lists_the_pages_and_shows_one(qtbot, monkeypatch):
    from PySide6.QtNetwork import QNetworkAccessManager
    monkeypatch.setattr(QNetworkAccessManager, "get", lambda *a: (_ for _ in ()).throw(AssertionError))
    folder = docs_folder()
    assert folder is not None
    pages = doc_pages()
    titles = {page.path.relative_to(folder).as_posix(): page.title for page in pages}
    docs = REPO / "docs"
    expected = {p.relative_to(docs).as_posix() for section in ("guide", "explanations", "reports", "reference/general")
                for p in (docs / section).glob("*.md")}
    assert set(titles) == expected | {"README.md", "reference/index.md"}   # not the processors' pages
    sections = [name.split("/")[0] for name in titles]   # the index, then the guide ... the reports
    assert sections[0] == "README.md" and sections.index("reports") > sections.index("explanations") \
        > sections.index("reference") > sections.index("guide")
    assert titles["reference/general/cli.md"] == "The vgraph command"   # backticks dropped from "# The `vgraph` command"
    dialog = DocsDialog()
    qtbot.addWidget(dialog)
    assert dialog.list.count() == len(titles)
    assert dialog.list.currentItem().text() == titles["guide/gui.md"]    # opens on the GUI page
    assert dialog.list.currentItem().toolTip() == "guide/gui.md"
    assert dialog.show_page("cli.md") and dialog.show_page("reference/general/cli.md")
    assert dialog.browser.toPlainText().startswith("The vgraph command")
    assert "vgraph run" in dialog.browser.toPlainText()
    dialog._follow(QUrl("network-format.md#processors"))   # a link between pages stays here
    assert dialog.list.currentItem().text() == titles["reference/general/network-format.md"]
    dialog._follow(QUrl("../../guide/own-data.md"))       # and between folders
    assert dialog.list.currentItem().text() == titles["guide/own-data.md"]


def test_docs_are_found_in_an_installed_layout(tmp_path, monkeypatch):
    import vgraph
    import vgraph.gui.help as help_module
    package = tmp_path / "site" / "vgraph"
    (package / "docs").mkdir(parents=True)
    (package / "docs" / "gui.md").write_text("# The GUI\n\ntext\n")
    monkeypatch.setattr(vgraph, "__file__", str(package / "__init__.py"))
    assert help_module.docs_folder() == package / "docs"
    assert [p.title for p in doc_pages()] == ["The GUI"]


def test_a_pages_pictures_show_from_the_installed_location(qtbot, tmp_path, monkeypatch):
    """Pictures are package data beside the pages (vgraph/docs/images): the page shows them from
    there, a wide one scaled to the page's column (again after a resize), a missing one left as a
    broken link."""
    import numpy as np
    import PIL.Image
    import vgraph
    from PySide6.QtGui import QTextDocument
    from vgraph.gui.help import document_images, image_path
    package = tmp_path / "site" / "vgraph"
    (package / "docs" / "images").mkdir(parents=True)
    small = np.zeros((30, 40, 3), np.uint8)
    small[:, :20] = (255, 0, 0)                       # left half red, right half black
    PIL.Image.fromarray(small).save(package / "docs" / "images" / "small.png")
    PIL.Image.fromarray(np.full((200, 1600, 3), 90, np.uint8)).save(package / "docs" / "images" / "wide.png")
    (package / "docs" / "gui.md").write_text(
        "# The GUI\n\n![small](images/small.png)\n\n![wide](images/wide.png)\n\n![gone](images/gone.png)\n")
    monkeypatch.setattr(vgraph, "__file__", str(package / "__init__.py"))
    dialog = DocsDialog()
    qtbot.addWidget(dialog)
    dialog.show()
    qtbot.waitExposed(dialog)
    document = dialog.browser.document()
    shown = document.resource(QTextDocument.ImageResource, QUrl("images/small.png"))
    assert shown.width() == 40 and shown.height() == 30
    assert shown.pixelColor(5, 5).getRgb()[:3] == (255, 0, 0) and shown.pixelColor(35, 5).getRgb()[:3] == (0, 0, 0)
    sizes = lambda: {link: (c.charFormat().toImageFormat().width(), c.charFormat().toImageFormat().height())
                     for c, link in document_images(document)}
    column = dialog.image_width()
    assert 200 < column < 1600 and column < dialog.browser.viewport().width()
    assert set(sizes()) == {"images/small.png", "images/wide.png", "images/gone.png"}
    assert sizes()["images/wide.png"] == (column, 200 * column / 1600)
    assert sizes()["images/small.png"] == (40, 30)     # narrower than the column: as it is
    dialog.resize(dialog.width() - 200, dialog.height())
    qtbot.waitUntil(lambda: dialog.image_width() < column)
    assert sizes()["images/wide.png"] == (dialog.image_width(), 200 * dialog.image_width() / 1600)
    page = package / "docs" / "gui.md"
    assert image_path(page, "images/wide.png") == package / "docs" / "images" / "wide.png"
    assert image_path(page, "images/gone.png") is None
    assert image_path(page, "https://example.org/x.png") is None


def test_every_picture_the_docs_link_is_found(qtbot):
    """The repository's pages: every image link names a file of docs/images (what the wheel ships),
    from the pages in docs/'s folders too (../images/...)."""
    from vgraph.gui.help import document_images, image_path
    dialog = DocsDialog()
    qtbot.addWidget(dialog)
    linked = set()
    for row, page in enumerate(dialog.pages):
        dialog.list.setCurrentRow(row)
        for _, link in document_images(dialog.browser.document()):
            path = image_path(page.path, link)
            assert path is not None, (page.path.name, link)
            linked.add(path.resolve())
    assert linked and linked <= {p.resolve() for p in (REPO / "docs" / "images").glob("*.png")}


def test_the_processor_reference_opens_from_the_list_and_its_links(qtbot):
    """docs/reference/ is a subfolder: its index is listed, a processor's page opens from a link
    with its picture (../images/...), and its links lead back to the essay pages."""
    from vgraph.gui.help import document_images, image_path
    dialog = DocsDialog()
    qtbot.addWidget(dialog)
    assert dialog.show_page("index.md")
    assert dialog.list.currentItem().text() == "Processor reference"
    dialog._follow(QUrl("RayCaster.md"))
    assert dialog.shown == docs_folder() / "reference" / "RayCaster.md"
    assert dialog.list.currentItem() is None and dialog.browser.toPlainText().startswith("RayCaster")
    assert "sampling_rate" in dialog.browser.toPlainText()
    pictures = [image_path(dialog.shown, link) for _, link in document_images(dialog.browser.document())]
    assert pictures == [docs_folder() / "reference" / ".." / "images" / "rendering_compositing.png"]
    assert pictures[0].is_file()
    dialog._follow(QUrl("../explanations/ray-casting.md#raycaster"))
    assert dialog.list.currentItem().text() == "Volume rendering: EntryExitPoints and RayCaster"
    dialog._follow(QUrl("../reference/index.md"))   # ray-casting.md links the reference's index
    assert dialog.list.currentItem().text() == "Processor reference"


def test_shortcuts_dialog_lists_the_actions_keys(window, qtbot):
    rows = dict(shortcut_rows(window))
    assert "Ctrl+Y" in rows["Redo"] and rows["Save"] == "Ctrl+S"
    window.save_action.setShortcut(QKeySequence("Ctrl+Alt+S"))  # built from the actions, not a list
    dialog = ShortcutsDialog(window)
    qtbot.addWidget(dialog)
    cells = {dialog.table.item(r, 0).text(): dialog.table.item(r, 1).text()
             for r in range(dialog.table.rowCount())}
    assert cells["Save"] == "Ctrl+Alt+S" and "Ctrl+Y" in cells["Redo"]
    help_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&Help")
    assert {a.text() for a in help_menu.actions()} == {"&Documentation", "&Keyboard Shortcuts",
                                                       "&About vgraph"}
