"""The welcome page (gui/welcome.py): it lists the shipped example networks with their thumbnails
and the recent files, a click opens an example, a dropped volume file opens as File > Open opens
it (the whole network around it), and the page goes when a network is opened or a processor added
and comes back with File > New."""

from PySide6.QtCore import QMimeData, QPoint, Qt, QUrl
from PySide6.QtGui import QDragEnterEvent, QDropEvent
from PySide6.QtWidgets import QApplication

from helpers.paths import REPO
from vgraph.fileformat import load_network

NETWORKS = REPO / "networks"


def example_items(window) -> dict:
    listing = window.welcome.page.examples
    return {listing.item(i).text(): listing.item(i) for i in range(listing.count())}


def test_the_empty_window_lists_the_shipped_networks_with_thumbnails(window):
    assert window.welcome.showing() and window.welcome.page.isVisible()
    items = example_items(window)
    assert sorted(items) == sorted(p.stem for p in NETWORKS.glob("*.json"))
    shown = [name for name, item in items.items() if not item.icon().isNull()]
    # Every network with a canvas has its thumbnail; the volume_* conversions (a writer only) have none.
    assert sorted(shown) == sorted(p.stem for p in (NETWORKS / "thumbnails").glob("*.png"))
    assert {"raycast_head", "mpr_mri_head", "tets_bonsai"} <= set(shown)
    assert "CT head" in items["raycast_head"].toolTip()   # the network's description


def test_a_click_on_an_example_opens_it(window, qtbot):
    listing = window.welcome.page.examples
    item = example_items(window)["raycast_sphere"]
    listing.scrollToItem(item)
    qtbot.mouseClick(listing.viewport(), Qt.LeftButton, pos=listing.visualItemRect(item).center())
    assert window.workspace.path == NETWORKS / "raycast_sphere.json"
    assert not window.welcome.showing() and window.view.isVisible()
    assert str(NETWORKS / "raycast_sphere.json") in [window.welcome.page.recent.item(i).text()
                                                     for i in range(window.welcome.page.recent.count())]


def drag_and_drop(widget, path) -> bool:
    """Drag ``path`` onto ``widget`` and drop it; whether the widget accepted the drag."""
    mime = QMimeData()
    mime.setUrls([QUrl.fromLocalFile(str(path))])
    enter = QDragEnterEvent(QPoint(10, 10), Qt.CopyAction, mime, Qt.LeftButton, Qt.NoModifier)
    QApplication.sendEvent(widget, enter)
    accepted = bool(enter.isAccepted())
    if accepted:
        QApplication.sendEvent(widget, QDropEvent(QPoint(10, 10).toPointF(), Qt.CopyAction, mime,
                                                  Qt.LeftButton, Qt.NoModifier))
    return accepted


def test_a_dropped_volume_file_opens_as_file_open_would(window):
    volume = NETWORKS / "data" / "engine_labels.nrrd"
    assert drag_and_drop(window.welcome.page, volume)
    expected = load_network(volume)   # what File > Open builds around a data file
    network = window.workspace.network
    assert {(p.id, p.type_name) for p in network.processors.values()} == \
        {(p.id, p.type_name) for p in expected.processors.values()}
    assert network.description == expected.description and window.workspace.path is None
    assert not window.welcome.showing()


def test_the_page_goes_with_a_processor_and_comes_back_with_new(window):
    window.add_processor("VolumeSource")   # the palette still works on the welcome page
    assert not window.welcome.showing()
    window.workspace.undo_stack.setClean()
    window.new_network()
    assert window.welcome.showing()
    window.welcome.page.empty_button.click()
    assert not window.welcome.showing() and window.view.isVisible()
