"""The scripted session of bench/bench_gui_session.py, run in the test window with Qt events (no X
server): every step must take effect (the edits reach the network and the saved files), so the
bench's timings time real work. The launch itself (a fresh process) is the bench's own."""

import importlib.util
import json
import math
import sys

from helpers.paths import REPO


def load_bench():
    spec = importlib.util.spec_from_file_location("bench_gui_session", REPO / "bench" / "bench_gui_session.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module   # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_the_scripted_session_edits_orbits_and_saves(window, jobs, tmp_path, data_dir):
    bench = load_bench()
    network = bench.copy_network(REPO / "networks" / "raycast_head.json", tmp_path)
    original = json.loads(network.read_text())
    assert window.open_network(network)
    window.workspace.network.set("canvas.size", [96, 96])
    frames, waits = bench.FrameLog(window), []

    bench.Stepper(bench.session(window, bench.QtInput(), frames, tmp_path, True, waits)).run()

    assert [(w.step, w.waits_for) for w in waits] == [
        ("launch", "first image"), ("sampling rate typed in", "refined image"),
        ("TF point dragged", "refined image"), ("camera orbited", "refined image"),
        ("Ctrl+S", "saved"), ("Ctrl+Shift+S", "Save As dialog"), ("Save As + Return", "saved"),
        ("F9", "views perspective"), ("F9 again", "network editor")]
    assert all(math.isfinite(w.seconds) and w.seconds >= 0 for w in waits)
    saved, copy = json.loads(network.read_text()), json.loads((tmp_path / "session_copy.json").read_text())
    rc = {p["id"]: p for p in saved["processors"]}["rc"]["properties"]
    before = {p["id"]: p for p in original["processors"]}["rc"]["properties"]
    assert rc["sampling_rate"] == 0.5 != before["sampling_rate"]
    assert rc["transfer_function"] != before["transfer_function"]
    assert rc["camera"]["position"] != before["camera"]["position"]
    assert copy["processors"] == saved["processors"]
    assert window.workspace.path == tmp_path / "session_copy.json" and not window.workspace.is_modified()
    assert window.log.messages("error") == []
