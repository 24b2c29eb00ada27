"""Opening a network whose writers would write outside its folder asks first, naming them."""

import json

import pytest

from vgraph.fileformat import network_document



def network_with_writers(folder, paths: dict[str, str]):
    """A network file in ``folder`` with one ImageWriter per id -> path (as written in the file)."""
    folder.mkdir(parents=True, exist_ok=True)
    document = {"format": "vgraph-network", "version": 1, "description": "",
                "processors": [{"id": pid, "type": "ImageWriter", "properties": {"path": path},
                                "position": [0, 120 * i]} for i, (pid, path) in enumerate(paths.items())],
                "connections": [], "links": []}
    file = folder / "writers.json"
    file.write_text(json.dumps(document))
    return file


@pytest.fixture
def outside(tmp_path):
    return network_with_writers(tmp_path / "received", {"inside": "out.png",
                                                        "escape": "../home/notes.png",
                                                        "absolute": str(tmp_path / "etc" / "x.png")})


def test_cancel_leaves_the_open_network_as_it_was(window, outside, tmp_path, monkeypatch):
    window.workspace.add_processor("Number", (0, 0), id="mine")
    window.workspace.undo_stack.setClean()
    before, network = network_document(window.workspace.network), window.workspace.network
    asked = []
    monkeypatch.setattr(window, "ask_allow_writes", lambda path, writes: asked.append((path, writes)) or False)

    assert not window.open_network(outside)
    assert asked == [(outside, [("escape", (tmp_path / "home" / "notes.png").resolve()),
                                ("absolute", (tmp_path / "etc" / "x.png").resolve())])]
    assert window.workspace.network is network and network_document(network) == before
    assert window.workspace.path is None and not window.workspace.is_modified()
    assert window.log.messages("error") == []


def test_allow_opens_it_with_the_named_folders_allowed(window, outside, tmp_path, monkeypatch):
    monkeypatch.setattr(window, "ask_allow_writes", lambda path, writes: True)

    assert window.open_network(outside)
    network = window.workspace.network
    assert window.workspace.path == outside and set(network.processors) == {"inside", "escape", "absolute"}
    assert network.get("escape.path") == "../home/notes.png"
    assert any(str((tmp_path / "home" / "notes.png").resolve()) in message
               for message in window.log.messages("warning"))


def test_writers_inside_the_folder_open_without_asking(window, tmp_path, monkeypatch):
    inside = network_with_writers(tmp_path / "own", {"w": "out.png", "deeper": "results/b.png"})
    monkeypatch.setattr(window, "ask_allow_writes", lambda path, writes: pytest.fail("asked"))
    assert window.open_network(inside)
    assert set(window.workspace.network.processors) == {"w", "deeper"}


@pytest.mark.parametrize("button, allowed", [("Allow", True), ("Cancel", False)])
def test_the_dialog_names_each_processor_and_path(window, outside, tmp_path, button, allowed):
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication
    shown = []

    def answer():
        box = QApplication.activeModalWidget()
        shown.append(box.text())
        next(b for b in box.buttons() if b.text().replace("&", "") == button).click()

    QTimer.singleShot(0, answer)
    writes = [("escape", tmp_path / "home" / "notes.png"), ("absolute", tmp_path / "etc" / "x.png")]
    assert window.ask_allow_writes(outside, writes) is allowed
    assert f"escape: {tmp_path / 'home' / 'notes.png'}" in shown[0]
    assert f"absolute: {tmp_path / 'etc' / 'x.png'}" in shown[0]
