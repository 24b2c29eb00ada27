"""Autosave and crash recovery: unsaved changes are written aside while the user works, removed
when saved or left on purpose, and offered back after a crash."""

import json
import os
import subprocess
import sys
import time

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QMessageBox

from vgraph.fileformat import load_network, network_document
from vgraph.gui.autosave import INTERVAL_KEY, Autosave, read_autosave
from vgraph.gui.workspace import Workspace



def build_and_save(window, path):
    window.workspace.add_processor("Number", (0, 0), id="a")
    window.workspace.add_processor("Collect", (0, 120), id="sink")
    window.workspace.connect("a.value", "sink.value")
    window.workspace.set_property("a.value", 1.0)
    assert window.save_network_as(path)
    past = time.time() - 60   # the file is clearly older than any autosave made in the test
    os.utime(path, (past, past))


def dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def crash(window):
    """Leave the autosave behind as a window that crashed would: written by a process now gone."""
    path = window.autosave.write()
    data = json.loads(path.read_text())
    data["pid"] = dead_pid()
    path.write_text(json.dumps(data))
    os.utime(path, None)
    window.autosave.current = None      # the crashed window no longer removes it
    window.workspace.undo_stack.setClean()
    return path


def test_unsaved_changes_are_autosaved_without_touching_the_file_and_saving_removes_them(window, tmp_path):
    network_file = tmp_path / "net.json"
    build_and_save(window, network_file)
    on_disk = network_file.read_text()
    autosave = window.autosave
    assert autosave.timer.isActive() and autosave.timer.interval() == 60_000
    assert autosave.folder == tmp_path / "autosave"   # beside the (test's) settings file
    assert autosave.write_if_needed() is None         # nothing unsaved, nothing written

    window.workspace.set_property("a.value", 7.0)
    written = autosave.write_if_needed()              # what the timer does every interval
    assert written.parent == tmp_path / "autosave" and written.exists()
    found = read_autosave(written)
    assert found.original == network_file.resolve() and found.pid == os.getpid()
    assert found.document == network_document(window.workspace.network)
    assert network_file.read_text() == on_disk        # the network's file is not touched
    assert window.workspace.is_modified() and window.workspace.path == network_file
    assert autosave.write_if_needed() is None         # unchanged since: not written again

    assert window.save_network()
    assert not written.exists()
    assert list((tmp_path / "autosave").iterdir()) == []


def test_a_clean_close_removes_the_autosave(window, tmp_path, monkeypatch):
    build_and_save(window, tmp_path / "net.json")
    window.workspace.set_property("a.value", 7.0)
    written = window.autosave.write_if_needed()
    monkeypatch.setattr(window, "ask_save_changes", lambda: QMessageBox.Discard)
    assert window.close()
    assert not written.exists()


def test_undo_back_to_the_saved_state_removes_the_autosave(window, tmp_path):
    build_and_save(window, tmp_path / "net.json")
    window.workspace.set_property("a.value", 7.0)
    written = window.autosave.write_if_needed()
    window.workspace.undo_stack.undo()
    assert not window.workspace.is_modified() and not written.exists()


def test_after_a_crash_opening_the_network_offers_the_autosave_and_restore_gives_the_edits(
        window, tmp_path, monkeypatch):
    network_file = tmp_path / "net.json"
    build_and_save(window, network_file)
    window.workspace.set_property("a.value", 7.0)
    window.workspace.add_processor("Number", (200, 0), id="b")
    edited = network_document(window.workspace.network)
    left = crash(window)
    offered = []
    monkeypatch.setattr(window, "ask_recover", lambda found: offered.append(found) or "restore")

    assert window.open_network(network_file)
    assert [f.path for f in offered] == [left]
    workspace = window.workspace
    assert network_document(workspace.network) == edited
    assert workspace.is_modified() and workspace.path == network_file
    assert "*" in window.windowTitle() or window.isWindowModified()
    assert load_network(network_file).get("a.value") == 1.0     # the file still holds the old state
    assert not left.exists() or read_autosave(left).pid == os.getpid()   # now this window's own
    assert window.autosave.current is not None and window.autosave.current.exists()
    assert window.save_network()
    assert load_network(network_file).get("a.value") == 7.0 and "b" in load_network(network_file)


@pytest.mark.parametrize("answer, kept", [("discard", False), ("later", True)])
def test_declining_the_recovery_discards_the_autosave_or_keeps_it_for_later(
        window, tmp_path, monkeypatch, answer, kept):
    network_file = tmp_path / "net.json"
    build_and_save(window, network_file)
    window.workspace.set_property("a.value", 7.0)
    left = crash(window)
    monkeypatch.setattr(window, "ask_recover", lambda found: answer)

    assert window.open_network(network_file)
    assert window.workspace.network.get("a.value") == 1.0 and not window.workspace.is_modified()
    assert left.exists() == kept
    offered = []
    monkeypatch.setattr(window, "ask_recover", lambda found: offered.append(found) or "later")
    window.open_network(network_file)
    assert len(offered) == int(kept)                  # "later" asks again next time


def test_an_autosave_older_than_the_file_is_not_offered(window, tmp_path, monkeypatch):
    network_file = tmp_path / "net.json"
    build_and_save(window, network_file)
    window.workspace.set_property("a.value", 7.0)
    left = crash(window)
    os.utime(network_file, None)                      # saved again after the autosave
    os.utime(left, (time.time() - 3600,) * 2)
    monkeypatch.setattr(window, "ask_recover", lambda found: pytest.fail("offered a stale autosave"))
    assert window.open_network(network_file)
    assert not left.exists()


def test_an_autosave_of_a_running_window_is_not_offered(window, tmp_path, monkeypatch):
    network_file = tmp_path / "net.json"
    build_and_save(window, network_file)
    window.workspace.set_property("a.value", 7.0)
    window.autosave.write()                           # this process is alive: not a crash
    monkeypatch.setattr(window, "ask_recover", lambda found: pytest.fail("offered a live autosave"))
    assert window.autosave.find_for(network_file) is None
    assert window.autosave.newest_orphan() is None


def test_at_start_up_an_untitled_network_left_by_a_crash_is_offered(window, monkeypatch):
    window.workspace.add_processor("Number", (0, 0), id="lost")
    window.workspace.set_property("lost.value", 3.0)
    crash(window)
    window.new_network()
    monkeypatch.setattr(window, "ask_recover", lambda found: "restore")

    assert window.offer_recovery(window.autosave.newest_orphan())   # what run_gui does without a file
    assert window.workspace.path is None and window.workspace.is_modified()
    assert window.workspace.network.get("lost.value") == 3.0


def test_the_interval_comes_from_the_settings_and_zero_turns_autosave_off(qtbot, tmp_path):
    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)
    settings.setValue(INTERVAL_KEY, 5)
    assert Autosave(Workspace(settings), settings).timer.interval() == 5_000
    settings.setValue(INTERVAL_KEY, 0)
    assert not Autosave(Workspace(settings), settings).timer.isActive()


@pytest.mark.parametrize("button, answer", [("Restore", "restore"), ("Discard", "discard"), ("Later", "later")])
def test_the_recovery_dialog_names_the_network_and_maps_its_buttons(window, tmp_path, button, answer):
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication
    network_file = tmp_path / "net.json"
    build_and_save(window, network_file)
    window.workspace.set_property("a.value", 7.0)
    found = read_autosave(crash(window))
    shown = []

    def click():
        box = QApplication.activeModalWidget()
        shown.append(box.text())
        next(b for b in box.buttons() if b.text() == button).click()

    QTimer.singleShot(0, click)
    assert window.ask_recover(found) == answer
    assert "net.json" in shown[0]
