"""Workspace and robustness: save/open round trips that the CLI agrees with, bad files, unsaved
changes, recent files, processor errors on nodes and in the log, the GL-free evaluator, `vgraph gui`."""

import json
import os
import subprocess
import sys

import numpy as np
import PIL.Image
from PySide6.QtWidgets import QMessageBox

import vgraph
from vgraph.cli import build_parser, main

from helpers.paths import REPO

GRAY = REPO / "networks" / "grayscale.json"


def build_volume_network(ws, folder):
    """Sphere -> spline -> writer, saved in ``folder`` (relative paths then mean that folder)."""
    ws.save_as(folder / "start.json")
    ws.add_processor("FunctionSelector", (0, 0), id="f")
    ws.add_processor("CubicSplineProcessor", (10, 150), id="spline")
    ws.add_processor("VolumeWriter", (20, 300), id="writer")
    ws.connect("f.volume", "spline.volume")
    ws.connect("spline.volume", "writer.volume")
    ws.set_property("f.resolution", 24)
    ws.set_property("f.function", "sphere")
    ws.set_property("writer.path", "out/sphere.npy")


def test_saved_network_loads_in_vgraph_and_reopens_to_the_same_file(window, tmp_path):
    ws = window.workspace
    build_volume_network(ws, tmp_path)
    assert ws.is_modified() and window.isWindowModified()
    assert window.save_network_as(tmp_path / "mine")          # the suffix is added
    saved = tmp_path / "mine.json"
    assert not ws.is_modified() and ws.path == saved and window.windowTitle() == "mine.json[*] - vgraph"

    loaded = vgraph.load(saved)
    assert [(p.id, p.type_name, p.position) for p in loaded.processors.values()] == [
        ("f", "FunctionSelector", (0.0, 0.0)), ("spline", "CubicSplineProcessor", (10.0, 150.0)),
        ("writer", "VolumeWriter", (20.0, 300.0))]
    assert loaded.connections == ws.network.connections
    assert loaded.get("f.resolution") == 24 and loaded.get("writer.path") == "out/sphere.npy"

    outcome = window.evaluation.run(include_writers=True, wait=True)   # in the render process
    assert outcome.ran == ["f", "spline", "writer"] and not outcome.failed
    np.testing.assert_array_equal(loaded.evaluate("spline.volume"), np.load(tmp_path / "out" / "sphere.npy"))

    assert window.open_network(saved)
    assert window.save_network_as(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_text() == saved.read_text()


def test_run_writers_writes_what_vgraph_run_writes(window, qtbot, tmp_path):
    ws = window.workspace
    build_volume_network(ws, tmp_path)
    window.save_network_as(tmp_path / "net.json")
    assert window.evaluation.run(wait=True).writers == ["writer"]
    assert not (tmp_path / "out" / "sphere.npy").exists()      # writers wait for the request
    with qtbot.waitSignal(window.evaluation.finished, timeout=20000):
        window.writers_action.trigger()
    gui_written = np.load(tmp_path / "out" / "sphere.npy")
    assert main(["run", str(tmp_path / "net.json")]) == 0      # the CLI writes the same file
    np.testing.assert_array_equal(np.load(tmp_path / "out" / "sphere.npy"), gui_written)


def test_grayscale_network_saved_by_the_gui_renders_the_same_image(window, tmp_path):
    """Round trip with GL processors: the canvas shows what the CLI renders, from either file."""
    assert window.open_network(GRAY)
    window.evaluation.run(wait=True)
    shown = window.canvases.views["canvas"].frame()
    assert window.save_network_as(tmp_path / "gray.json")
    document = json.loads((tmp_path / "gray.json").read_text())
    assert [p["id"] for p in document["processors"]] == ["source", "gray", "canvas"]
    for network, png in ((GRAY, "original.png"), (tmp_path / "gray.json", "gui.png")):
        assert main(["run", str(network), "-o", str(tmp_path / png)]) == 0
        np.testing.assert_array_equal(np.asarray(PIL.Image.open(tmp_path / png)), shown)


def test_a_bad_file_opens_a_dialog_naming_the_problems(window, tmp_path, monkeypatch):
    shown = []
    monkeypatch.setattr(QMessageBox, "critical", lambda parent, title, text: shown.append((title, text)))
    ws = window.workspace
    ws.add_processor("Number", (0, 0), id="keep")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "vgraph-network", "version": 1,
                               "processors": [{"id": "g", "type": "Greyscale"}],
                               "connections": [{"from": "x.image", "to": "g.image"}]}))
    ws.undo_stack.setClean()
    assert not window.open_network(bad)
    (title, text), = shown
    assert title == "Cannot open network"
    assert f"{bad}: processors[0].type: unknown processor type 'Greyscale'" in text
    assert f"{bad}: connections[0]: no processor with id 'x'" in text
    assert "keep" in ws.network and ws.path is None                     # nothing was replaced
    assert window.log.messages("error")[-1].startswith(f"Cannot open {bad}")
    assert not window.open_network(tmp_path / "missing.json")
    assert "file not found" in shown[-1][1]


def test_unsaved_changes_prompt_cancel_discard_and_save(window, tmp_path, monkeypatch):
    ws = window.workspace
    ws.add_processor("Number", (0, 0), id="n")
    answers = []
    monkeypatch.setattr(window, "ask_save_changes", lambda: answers.pop(0))
    answers.append(QMessageBox.Cancel)
    window.new_network()
    assert "n" in ws.network                                           # cancelled: kept
    monkeypatch.setattr(window, "ask_save_path", lambda: str(tmp_path / "kept.json"))
    answers.append(QMessageBox.Save)
    window.new_network()
    assert list(ws.network.processors) == [] and "n" in vgraph.load(tmp_path / "kept.json")
    ws.add_processor("Number", (0, 0), id="m")
    answers.append(QMessageBox.Discard)
    assert window.open_network(tmp_path / "kept.json")
    assert list(ws.network.processors) == ["n"] and answers == []
    assert not ws.is_modified()                                        # nothing asked when clean
    window.new_network()


def test_recent_files_are_remembered_in_the_settings(window, tmp_path):
    for name in ("a.json", "b.json"):
        window.workspace.new()
        window.save_network_as(tmp_path / name)
    window.open_network(tmp_path / "a.json")
    expected = [str((tmp_path / "a.json").resolve()), str((tmp_path / "b.json").resolve())]
    assert window.workspace.recent_files() == expected
    assert [a.text() for a in window.recent_menu.actions()] == expected
    window.recent_menu.actions()[1].trigger()
    assert window.workspace.path == tmp_path / "b.json"


def test_a_processor_error_shows_on_its_node_and_in_the_log_and_the_gui_goes_on(window, qtbot):
    ws = window.workspace
    ws.add_processor("Number", (0, 0), id="n")
    ws.add_processor("Fragile", (0, 150), id="frag")
    ws.add_processor("Collect", (0, 300), id="sink")
    ws.connect("n.value", "frag.value")
    ws.connect("frag.value", "sink.value")
    window.evaluation.run(wait=True)  # the edits so far evaluated: the next finish is the failing job's
    window.scene.select_processor("frag")
    with qtbot.waitSignal(window.evaluation.finished, timeout=5000):
        window.inspector.editors["fail"].spin.setValue(1)
    node = window.scene.nodes["frag"]
    assert node.status.state == "error"
    assert "ZeroDivisionError: deliberate failure" in node.toolTip()
    assert window.log.messages("error") == ["processor 'frag' (Fragile): ZeroDivisionError: deliberate failure"]
    assert window.scene.nodes["n"].status.state == "evaluated"
    assert window.scene.nodes["sink"].status.state == "invalid"       # skipped, not failed again
    assert "deliberate failure" in window.inspector.status.text()

    with qtbot.waitSignal(window.evaluation.finished, timeout=5000) as blocker:
        ws.undo_stack.undo()                                           # fail = 0 again
    assert blocker.args[0].ran == ["frag", "sink"]
    assert node.status.state == "evaluated" and window.scene.nodes["sink"].status.state == "evaluated"
    assert window.log.messages("info")[-1] == "processor 'frag' evaluates again"


GL_FREE_SCRIPT = """
import json, sys
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication
from vgraph import gl_context
from vgraph.gui.app import MainWindow

if __name__ == "__main__":
    app = QApplication([])
    window = MainWindow(QSettings(sys.argv[2], QSettings.IniFormat))
    assert window.open_network(sys.argv[1])
    outcome = window.evaluation.run(wait=True)
    frame = window.canvases.views["canvas"].frame()
    print(json.dumps({"ran": outcome.ran, "frame": list(frame.shape), "gl": gl_context.has_context(),
                      "node": window.scene.nodes["gray"].status.state}))
    window.workspace.undo_stack.setClean()
    window.close()
"""


def test_the_gui_process_creates_no_gl_context(tmp_path):
    """In a fresh process (as `vgraph gui`): the render process renders, the GUI holds no GL."""
    script = tmp_path / "gui_script.py"
    script.write_text(GL_FREE_SCRIPT)
    done = subprocess.run([sys.executable, str(script), str(GRAY), str(tmp_path / "s.ini")],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "QT_QPA_PLATFORM": "offscreen"})
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result == {"ran": ["source", "gray", "canvas"], "frame": [192, 192, 4], "gl": False,
                      "node": "evaluated"}


def test_vgraph_gui_command_and_lazy_qt_import(monkeypatch, tmp_path):
    import vgraph.gui.app
    args = build_parser().parse_args(["gui", str(GRAY)])
    assert args.network == GRAY
    opened = []
    monkeypatch.setattr(vgraph.gui.app, "run_gui", lambda path, **options: opened.append(path) or 0)
    assert main(["gui", str(GRAY)]) == 0 and opened == [GRAY]
    code = "import sys, vgraph.cli; sys.exit('PySide6' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_screenshot_saves_the_rendered_window_and_exits(tmp_path, qtbot, capsys):
    out = tmp_path / "shot.png"
    network = REPO / "networks" / "raycast_sphere.json"
    assert main(["gui", str(network), "--select", "rc", "--window-size", "900x700", "--screenshot", str(out)]) == 0
    shot = np.asarray(PIL.Image.open(out).convert("RGB")).astype(int)
    assert shot.shape == (700, 900, 3)
    canvas = vgraph.imagefile.to_uint8(vgraph.load(network).evaluate("canvas"))[..., :3].astype(int)
    # the rendered sphere is in the window: its brightest colour appears in the screenshot
    brightest = canvas.reshape(-1, 3)[canvas.sum(axis=2).argmax()]
    assert (np.abs(shot - brightest).sum(axis=2) <= 3).any()

    assert main(["gui", str(network), "--select", "nope", "--screenshot", str(tmp_path / "no.png")]) == 2
    assert "no processor with id 'nope'" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "vgraph-network", "version": 1, "processors": [{"id": "x", "type": "Nope"}]}')
    assert main(["gui", str(bad), "--screenshot", str(tmp_path / "no.png")]) == 2   # no dialog waits
    assert "processors[0].type: unknown processor type 'Nope'" in capsys.readouterr().err
    assert not (tmp_path / "no.png").exists()
