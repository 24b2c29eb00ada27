"""The GUI's acceptance test: networks/curvature_torus.json built from an empty window with the
mouse (palette, port drags, canvas trackball), tuned in the inspector, saved with File > Save As;
the saved file has the shipped network's structure and renders, with `vgraph run`, exactly the
frame the canvas showed."""

import json

import numpy as np
import PIL.Image
from PySide6.QtCore import QEvent, Qt

from vgraph.cli import main

from helpers.paths import REPO
from helpers.gui import drag, port_position, send_mouse

SHIPPED = REPO / "networks" / "curvature_torus.json"


def add_from_palette(qtbot, window, type_name: str) -> str:
    """Double-click a type in the palette, as a user does; returns the new processor's id."""
    palette = window.palette
    palette.search.clear()
    items = [palette.tree.topLevelItem(i).child(j) for i in range(palette.tree.topLevelItemCount())
             for j in range(palette.tree.topLevelItem(i).childCount())]
    item = next(item for item in items if item.text(0) == type_name)
    palette.tree.scrollToItem(item)  # as a user scrolls to it: the palette shows a dozen rows
    rect = palette.tree.visualItemRect(item)
    qtbot.mouseClick(palette.tree.viewport(), Qt.LeftButton, pos=rect.center())
    qtbot.mouseDClick(palette.tree.viewport(), Qt.LeftButton, pos=rect.center())
    return window.inspector.processor_id  # the new node is selected


def connect(qtbot, window, source: str, target: str) -> None:
    (src, outport), (dst, inport) = source.split("."), target.split(".")
    drag(qtbot, window, port_position(window, src, "out", outport), port_position(window, dst, "in", inport))


def structure(document: dict, ids: dict[str, str]) -> dict:
    """Types, connections and links, with ids renamed to the shipped ones."""
    rename = lambda address: ".".join([ids.get(address.split(".")[0], address.split(".")[0]), address.split(".")[1]])
    return {"types": sorted((ids.get(p["id"], p["id"]), p["type"]) for p in document["processors"]),
            "connections": sorted((rename(c["from"]), rename(c["to"])) for c in document["connections"]),
            "links": sorted(tuple(sorted((rename(l["from"]), rename(l["to"])))) + (l["bidirectional"],)
                            for l in document["links"])}


def test_build_the_curvature_torus_with_the_mouse_tune_it_and_save_it(window, qtbot, tmp_path, monkeypatch):
    ids = {}
    for shipped_id, type_name in (("source", "FunctionSelector"), ("spline", "CubicSplineProcessor"),
                                  ("eep", "EntryExitPoints"), ("curvature", "CurvatureRaycaster"),
                                  ("canvas", "Canvas")):
        ids[shipped_id] = add_from_palette(qtbot, window, type_name)
    window.fit_action.trigger()                                      # View > Fit Network
    network = window.workspace.network
    # Each new processor was connected to the one before it where the ports pair unambiguously.
    made = {(f"{c.source}.{c.outport}", f"{c.target}.{c.inport}") for c in network.connections}
    address = lambda a: f"{ids[a.split('.')[0]]}.{a.split('.')[1]}"
    assert made == {(address(s), address(t)) for s, t in (
        ("source.volume", "spline.volume"), ("spline.volume", "eep.volume"), ("eep.entry", "curvature.entry"),
        ("eep.exit", "curvature.exit"), ("curvature.image", "canvas.image"))}
    connect(qtbot, window, address("spline.volume"), address("curvature.volume"))   # the one left
    assert len(network.connections) == 6

    # tune: a colour map in the inspector, then turn the torus on the canvas
    window.scene.select_processor(ids["curvature"])
    window.inspector.editors["colormap"].combo.setCurrentText("viridis")
    outcome = window.evaluation.run(wait=True)
    assert not outcome.failed and ids["canvas"] in outcome.frames
    view = window.canvases.views[ids["canvas"]]
    camera = network.get(f"{ids['eep']}.camera")
    center = (view.width() / 2, view.height() / 2)
    send_mouse(view, QEvent.MouseButtonPress, center, Qt.LeftButton, Qt.LeftButton)
    send_mouse(view, QEvent.MouseMove, (center[0] + 25, center[1] - 40), Qt.NoButton, Qt.LeftButton)
    send_mouse(view, QEvent.MouseButtonRelease, (center[0] + 25, center[1] - 40), Qt.LeftButton, Qt.NoButton)
    assert network.get(f"{ids['curvature']}.camera") == network.get(f"{ids['eep']}.camera") != camera
    window.evaluation.run(wait=True)
    shown = view.frame()
    assert view.is_final and shown.shape == (512, 512, 4)

    saved = tmp_path / "my_torus.json"
    monkeypatch.setattr(window, "ask_save_path", lambda: str(saved))
    window.save_as_action.trigger()
    assert not window.workspace.is_modified()
    document = json.loads(saved.read_text())
    renamed = {new: old for old, new in ids.items()}
    assert structure(document, renamed) == structure(json.loads(SHIPPED.read_text()), {})

    assert main(["run", str(saved), "-o", str(tmp_path / "cli.png")]) == 0
    np.testing.assert_array_equal(np.asarray(PIL.Image.open(tmp_path / "cli.png")), shown)
