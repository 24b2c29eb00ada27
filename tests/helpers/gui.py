"""Mouse helpers for the GUI tests (pytest-qt, QT_QPA_PLATFORM=offscreen); the ``window`` fixture
is in conftest.py."""

from PySide6.QtCore import QPointF, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import QApplication


def view_point(window, scene_pos: QPointF):
    return window.view.mapFromScene(scene_pos)


def drag(qtbot, window, start: QPointF, end: QPointF, steps: int = 4, release: bool = True):
    """Press at ``start``, move to ``end`` in steps, release (all in scene coordinates)."""
    viewport = window.view.viewport()
    qtbot.mousePress(viewport, Qt.LeftButton, pos=view_point(window, start))
    for i in range(1, steps + 1):
        qtbot.mouseMove(viewport, view_point(window, start + (end - start) * (i / steps)))
    if release:
        qtbot.mouseRelease(viewport, Qt.LeftButton, pos=view_point(window, end))


def port_position(window, processor_id: str, direction: str, name: str) -> QPointF:
    return window.scene.nodes[processor_id].port(direction, name).scenePos()


def send_mouse(view, kind, pos, button, buttons, modifiers=Qt.NoModifier):
    # Explicit buttons: QTest.mouseMove does not reliably report held buttons.
    point = QPointF(*pos)
    event = QMouseEvent(kind, point, view.mapToGlobal(point), button, buttons, modifiers)
    QApplication.sendEvent(view, event)


def raycast_workspace(settings):
    """A Workspace holding EntryExitPoints eep -> RayCaster rc -> Canvas canvas (no volume yet)."""
    from vgraph.gui.workspace import Workspace
    workspace = Workspace(settings)
    workspace.add_processor("EntryExitPoints", (0, 0), id="eep")
    workspace.add_processor("RayCaster", (0, 120), id="rc")
    workspace.add_processor("Canvas", (0, 240), id="canvas")
    workspace.connect("eep.entry", "rc.entry")
    workspace.connect("eep.exit", "rc.exit")
    workspace.connect("rc.image", "canvas.image")
    return workspace


MPR_CANVASES = ("axial_canvas", "coronal_canvas", "sagittal_canvas", "canvas")


def open_mpr(window, qtbot, size: int):
    """networks/mpr_mri_head.json in the window, its canvases at ``size`` pixels, rendered."""
    from helpers.paths import REPO
    assert window.open_network(REPO / "networks" / "mpr_mri_head.json")
    for canvas in MPR_CANVASES:
        window.workspace.set_property(f"{canvas}.size", [size, size])
    settle(window, qtbot)
    return window


def settle(window, qtbot):
    """Wait until the render process is idle and every canvas shows a final frame."""
    qtbot.waitUntil(lambda: window.evaluation.idle()
                    and all(view.is_final and view.frame() is not None
                            for view in window.canvases.views.values()), timeout=120000)


def open_and_compare_with_run(window, path):
    """Open the network file ``path`` in the window: its canvas shows, within one 8-bit step, what
    `vgraph run` draws of it. Returns the frame shown."""
    import numpy as np
    import vgraph
    assert window.open_network(path)
    window.evaluation.run(wait=True)
    view = window.canvases.views["canvas"]
    frame = view.frame()
    expected = vgraph.imagefile.to_uint8(vgraph.load(path).evaluate("canvas"))
    assert frame.shape == expected.shape and view.is_final
    assert np.abs(frame.astype(int) - expected).max() <= 1
    return frame


def ray_caster_tf_editor(window, transfer_function):
    """The inspector's transfer-function editor of a RayCaster 'rc', added, given
    ``transfer_function`` and selected."""
    from vgraph.gui.transfer_function_editor import TransferFunctionEditor
    window.workspace.add_processor("RayCaster", (0, 0), id="rc")
    window.workspace.set_property("rc.transfer_function", transfer_function)
    window.scene.select_processor("rc")
    shown = window.inspector.editors["transfer_function"]
    assert isinstance(shown, TransferFunctionEditor)
    return shown


def ray_caster_tf(window):
    """The transfer function of the RayCaster 'rc'."""
    return window.workspace.network.get("rc.transfer_function")
