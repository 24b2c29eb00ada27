"""The scripted session of bench/bench_gui_session.py, run in the test window with Qt events (no X
server): every step must take effect (the edits reach the network and the saved files; the MPR
gestures move the cursor and the window; the palette's double-clicks place and connect), so the
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


def test_the_scripted_session_edits_orbits_saves_drives_mpr_and_places(window, jobs, tmp_path, data_dir):
    bench = load_bench()
    network = bench.copy_network(REPO / "networks" / "raycast_head.json", tmp_path)
    original = json.loads(network.read_text())
    assert window.open_network(network)
    window.workspace.network.set("canvas.size", [96, 96])
    frames, waits, shots = bench.FrameLog(window, "canvas"), [], {}

    bench.Stepper(bench.session(window, bench.QtInput(), frames, tmp_path, True, waits, shots=shots)).run()

    assert [(w.step, w.waits_for) for w in waits] == [
        ("launch", "first image"), ("sampling rate typed in", "refined image"),
        ("TF point dragged", "refined image"), ("camera orbited", "refined image"),
        ("Ctrl+S", "saved"), ("Ctrl+Shift+S", "Save As dialog"), ("Save As + Return", "saved"),
        ("F9", "views perspective"), ("F9 again", "network editor"),
        ("Ctrl+O + Return", "MPR images"), ("F9", "views perspective (MPR)"),
        ("left drag (axial): cursor", "refined image"), ("right drag (axial): window/level", "refined image"),
        ("wheel x3 (axial): page", "refined image"), ("F9 again", "network editor"),
        ("double-click VolumeSource", "placed"), ("double-click EntryExitPoints", "placed and connected"),
        ("double-click RayCaster", "placed and connected"), ("double-click Canvas", "placed and connected")]
    assert all(math.isfinite(w.seconds) and w.seconds >= 0 for w in waits)
    assert not shots["mpr"].isNull()
    # the MPR gestures were saved (Ctrl+S before Ctrl+N) into the copy of mpr_mri_head.json
    mpr = {p["id"]: p["properties"] for p in json.loads((tmp_path / "mpr_mri_head.json").read_text())["processors"]}
    assert mpr["axial"]["cursor"] is not None and mpr["axial"]["window"] is not None
    assert mpr["coronal"]["cursor"] == mpr["axial"]["cursor"]
    built = window.workspace.network   # the new network: four processors in a chain, connected
    assert [(built[c.source].type_name, c.outport, built[c.target].type_name, c.inport) for c in built.connections] == [
        ("VolumeSource", "volume", "EntryExitPoints", "volume"), ("EntryExitPoints", "entry", "RayCaster", "entry"),
        ("EntryExitPoints", "exit", "RayCaster", "exit"), ("RayCaster", "image", "Canvas", "image")]
    saved, copy = json.loads(network.read_text()), json.loads((tmp_path / "session_copy.json").read_text())
    rc = {p["id"]: p for p in saved["processors"]}["rc"]["properties"]
    before = {p["id"]: p for p in original["processors"]}["rc"]["properties"]
    assert rc["sampling_rate"] == 0.5 != before["sampling_rate"]
    assert rc["transfer_function"] != before["transfer_function"]
    assert rc["camera"]["position"] != before["camera"]["position"]
    assert copy["processors"] == saved["processors"]
    assert window.log.messages("error") == []
