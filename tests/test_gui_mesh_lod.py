"""Meshes in the window while dragging (issue 32, item 7): the render process draws a mesh's coarse
level of detail in the drag's frames and the mesh itself after the release."""

import numpy as np
from PySide6.QtCore import QEvent, Qt

from vgraph.fileformat import network_document
from vgraph.gui.live_evaluation import INTERACTIVE_SCALE
from vgraph.live.render_messages import RenderJob
from vgraph.live.render_server import RenderServer

from helpers.gui import send_mouse
from helpers.meshes import blob_network


def rendered(network, scale: float) -> np.ndarray:
    """The canvas as a fresh render process draws the network at ``scale`` (below 1: a drag's frame)."""
    job = RenderJob(1, network_document(network), str(network.base_dir), scale=scale)
    return RenderServer().handle(job).outcome.frames["canvas"]


def test_a_camera_drag_shows_the_coarse_mesh_and_the_release_the_mesh_itself(window, qtbot, tmp_path):
    path = tmp_path / "blob_tets.json"
    blob_network(tmp_path).save(path)
    assert window.open_network(path)
    window.evaluation.run(wait=True)
    view = window.canvases.views["canvas"]
    shown = []
    window.evaluation.frames.connect(lambda frames, final: "canvas" in frames and shown.append(
        (frames["canvas"].copy(), final)))
    centre = (view.width() / 2, view.height() / 2)
    send_mouse(view, QEvent.MouseButtonPress, centre, Qt.LeftButton, Qt.LeftButton)
    with qtbot.waitSignal(window.evaluation.frames, timeout=60000):
        send_mouse(view, QEvent.MouseMove, (centre[0] + 40, centre[1]), Qt.NoButton, Qt.LeftButton)
    with qtbot.waitSignal(window.evaluation.frames, timeout=60000, check_params_cb=lambda frames, final: final):
        send_mouse(view, QEvent.MouseButtonRelease, (centre[0] + 40, centre[1]), Qt.LeftButton, Qt.NoButton)
    (dragged, dragged_final), (released, released_final) = shown[0], shown[-1]
    assert not dragged_final and dragged.shape[:2] == (16, 16) and released_final

    network = window.workspace.network  # the camera the drag left
    coarse = rendered(network, INTERACTIVE_SCALE)
    np.testing.assert_array_equal(dragged, coarse)           # the drag's frame: the coarse mesh ...
    network.set("pt.coarse_tetrahedra", 0)
    assert np.abs(rendered(network, INTERACTIVE_SCALE).astype(int) - coarse).max() > 0  # ... not the mesh
    network.set("pt.coarse_tetrahedra", 20_000)
    np.testing.assert_array_equal(released, rendered(network, 1.0))  # the release: the mesh itself
