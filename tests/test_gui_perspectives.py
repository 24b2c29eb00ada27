"""The two perspectives (gui/perspectives.py): in the views perspective the canvases get at least
half of the window's area at 1280 x 800 and 1920 x 1080 (measured on the widgets), the network
editor comes back in the editing perspective, and a new window starts in the perspective (and its
dock state) the last one was closed in."""

import pytest
from PySide6.QtCore import QSettings, Qt
from PySide6.QtWidgets import QApplication

from helpers.gui import MPR_CANVASES
from helpers.paths import REPO


def canvas_share(window) -> float:
    """The canvases' visible area over the window's."""
    area = sum(view.width() * view.height() for view in window.canvases.views.values()
               if view.isVisible() and not view.visibleRegion().isEmpty())
    return area / (window.width() * window.height())


def editor_shown(window) -> bool:
    """The central widget (the network editor, or the welcome page while there is no network) is in."""
    return window.centralWidget() is not None and window.centralWidget().isVisible()


def process(qtbot):
    for _ in range(3):
        QApplication.processEvents()
    qtbot.wait(50)


@pytest.mark.parametrize("size", [(1280, 800), (1920, 1080)])
def test_views_perspective_gives_the_canvases_half_the_window(window, qtbot, size):
    window.arrange(*size)
    assert window.open_network(REPO / "networks" / "mpr_mri_head.json")
    process(qtbot)
    editing_share, editor_size = canvas_share(window), window.view.size()
    window.perspectives.switch("views")
    process(qtbot)
    assert not window.view.isVisible() and not window.palette_dock.isVisible()
    assert all(window.canvases.views[c].isVisible() for c in MPR_CANVASES)
    share = canvas_share(window)
    assert share >= 0.5, f"canvases take {share:.0%} of {size}"
    assert share > editing_share
    # "3D + 3 slices": the 3D view large on the left, the slices stacked beside it
    views = window.canvases.views
    main = views["canvas"].mapTo(window, views["canvas"].rect().topLeft())
    for name in MPR_CANVASES[:3]:
        corner = views[name].mapTo(window, views[name].rect().topLeft())
        assert corner.x() > main.x() + views["canvas"].width() - 20
        assert views["canvas"].width() * views["canvas"].height() > 2 * views[name].width() * views[name].height()
    window.perspectives.switch("editing")
    process(qtbot)
    assert window.view.isVisible() and window.palette_dock.isVisible()
    assert window.view.size() == editor_size and window.perspectives.actions["editing"].isChecked()


def test_f9_toggles_and_the_toolbar_switches(window, qtbot):
    assert window.perspectives.current == "editing"
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    qtbot.keyClick(window, Qt.Key_F9)
    assert window.perspectives.current == "views" and not editor_shown(window)
    window.perspectives.toolbar.widgetForAction(window.perspectives.actions["editing"]).click()
    assert window.perspectives.current == "editing" and editor_shown(window)


def test_a_new_window_comes_back_in_the_last_perspective(qtbot, tmp_path, renderer):
    from vgraph.gui.app import MainWindow
    path = tmp_path / "settings.ini"
    first = MainWindow(QSettings(str(path), QSettings.IniFormat), renderer)
    first.show()
    qtbot.waitExposed(first)
    first.perspectives.switch("views")
    assert first.welcome.showing() and editor_shown(first)   # an empty window keeps its welcome
    first.log_dock.show()        # a change the user made to the views perspective
    process(qtbot)
    first.close()
    first.deleteLater()
    second = MainWindow(QSettings(str(path), QSettings.IniFormat), renderer)
    second.show()
    qtbot.waitExposed(second)
    try:
        assert second.perspectives.current == "views"
        assert second.log_dock.isVisible() and not second.palette_dock.isVisible()
        assert editor_shown(second) and second.welcome.showing()   # no network yet: where to start
        assert second.open_network(REPO / "networks" / "raycast_sphere.json")
        process(qtbot)
        assert not editor_shown(second) and second.canvases.views["canvas"].isVisible()
        second.perspectives.switch("editing")   # the editing state kept when the first left it
        process(qtbot)
        assert editor_shown(second) and second.palette_dock.isVisible()
        second.perspectives.switch("views")     # the views state kept when it was left
        process(qtbot)
        assert second.log_dock.isVisible() and not second.palette_dock.isVisible()
    finally:
        second.close()
        second.deleteLater()


def test_reset_layout_goes_back_to_the_editing_layout(window, qtbot):
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.perspectives.switch("views")
    process(qtbot)
    window.reset_layout_action.trigger()
    process(qtbot)
    assert window.perspectives.current == "editing" and window.view.isVisible()
    assert window.palette_dock.isVisible() and window.log_dock.isVisible()
    assert window.workspace.settings.value("perspective/views/state") is None


def view_rects(window) -> dict:
    """Each canvas view's rectangle in window coordinates, for those on screen (not behind a tab)."""
    rects = {}
    for name, view in window.canvases.views.items():
        if view.isVisible() and not view.visibleRegion().isEmpty():
            rects[name] = view.rect().translated(view.mapTo(window, view.rect().topLeft()))
    return rects


def assert_tiled(window, count: int) -> dict:
    """``count`` canvases all on screen at once (none tabbed behind another), none overlapping."""
    rects = view_rects(window)
    assert len(window.canvases.views) == count and len(rects) == count, f"on screen: {sorted(rects)}"
    for a in rects:
        for b in rects:
            assert a == b or not rects[a].intersects(rects[b]), f"{a} overlaps {b}"
    return rects


def test_a_canvas_added_or_removed_in_the_views_perspective_is_tiled(window, qtbot):
    """One canvas at a time, as a user adds them: 1x2, then '3D + slices', then a 2 x 2 grid, and
    back on undo; never a tab behind the others."""
    window.arrange(1280, 800)
    assert window.open_network(REPO / "networks" / "raycast_sphere.json")
    window.perspectives.switch("views")
    process(qtbot)
    workspace = window.workspace
    workspace.add_processor("Canvas", (400, 0), id="second")
    process(qtbot)
    rects = assert_tiled(window, 2)
    assert rects["canvas"].top() == rects["second"].top() and rects["canvas"].right() < rects["second"].left()
    workspace.add_processor("Canvas", (400, 100), id="third")
    process(qtbot)
    rects = assert_tiled(window, 3)   # the 3D view (camera upstream) left and large, slices stacked
    assert rects["second"].left() > rects["canvas"].right() and rects["third"].top() > rects["second"].bottom()
    assert rects["canvas"].width() > rects["second"].width()
    workspace.add_processor("Canvas", (400, 200), id="fourth")
    process(qtbot)
    assert_tiled(window, 4)
    workspace.remove(processor_ids=["canvas"])   # three canvases, none a 3D view: a 2 x 2 grid
    process(qtbot)
    rects = assert_tiled(window, 3)
    assert rects["second"].top() == rects["third"].top() and rects["fourth"].top() > rects["second"].bottom()
    workspace.undo_stack.undo()   # the 3D view back: '3D + 3 slices'
    process(qtbot)
    rects = assert_tiled(window, 4)
    assert all(rects[name].left() > rects["canvas"].right() for name in ("second", "third", "fourth"))
