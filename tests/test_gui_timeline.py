"""The Timeline dock (gui/timeline_dock.py): a keyframed camera + transfer function + clip plane
animation shows in the GUI the frames `vgraph animate --timeline` writes; keyframes are added from
the current state and removed as undo steps, saved with the network; scrubbing renders coarse
frames while the slider is held; Play runs to the end; a keyframe that cannot be interpolated is
refused with the reason."""

import json
import math

import numpy as np
import PIL.Image
import pytest

import vgraph
from vgraph import cli
from vgraph.camera import Camera
from vgraph.gui.timeline_dock import FPS
from vgraph.tracks import value_at

from helpers.gui import settle
from helpers.paths import REPO

ANIMATION = REPO / "networks" / "animation_torus.json"
SPHERE = REPO / "networks" / "raycast_sphere.json"


def panel_of(window):
    window.timeline_dock.show()
    return window.timeline_dock.widget()


@pytest.fixture
def animation_panel(window):
    """networks/animation_torus.json open in the window: its Timeline panel."""
    assert window.open_network(ANIMATION)
    return panel_of(window)


@pytest.fixture
def sphere_panel(window):
    """networks/raycast_sphere.json open in the window: its Timeline panel and network."""
    assert window.open_network(SPHERE)
    return panel_of(window), window.workspace.network


def cli_frames(out, *options) -> None:
    """The frames `vgraph animate --timeline` writes of networks/animation_torus.json into ``out``."""
    assert cli.main(["animate", str(ANIMATION), "--timeline", *options, "-o", str(out), "--quiet"]) == 0


def test_the_gui_shows_the_frames_the_cli_renders_of_a_camera_tf_and_clip_animation(window, animation_panel, qtbot, tmp_path):
    # times 0, 1, 2, 3, 4 s: at 1 s and 3 s the camera, the TF and the clip plane are all between keyframes
    cli_frames(tmp_path / "frames", "--frames", "5")
    panel = animation_panel
    view = window.canvases.views["canvas"]
    for index in (1, 3):
        panel.scrub(float(index))
        assert panel.time() == index
        window.evaluation.run(wait=True)
        settle(window, qtbot)
        expected = np.asarray(PIL.Image.open(tmp_path / "frames" / f"frame_000{index}.png")).astype(int)
        assert view.frame().shape == expected.shape
        assert np.abs(view.frame().astype(int) - expected).max() <= 1   # as vgraph run and the GUI agree
    first = np.asarray(PIL.Image.open(tmp_path / "frames" / "frame_0000.png")).astype(int)
    assert np.abs(view.frame().astype(int) - first).max() > 50  # the frames differ: something moved


def test_keyframes_come_from_the_current_state_and_are_undoable(window, sphere_panel, tmp_path):
    panel, network = sphere_panel
    window.scene.select_processor("eep")
    assert panel.property_box.currentText() == "eep.camera"   # the selected processor's camera
    start = network.get("eep.camera")
    assert panel.add_keyframe()
    panel.scrub(2.0)   # first the time, then the state (scrubbing sets the tracked properties)
    turned = start.rotate(math.radians(90), 0.0)
    window.workspace.set_property("eep.camera", turned)
    panel.easing_box.setCurrentText("step")
    assert panel.add_keyframe()
    (track,) = network.tracks
    assert [(k.time, k.easing) for k in track.keyframes] == [(0.0, "linear"), (2.0, "step")]
    assert track.keyframes[1].value == turned

    panel.scrub(1.0)  # scrubbing sets the property (and the link carries it to the ray caster)
    halfway = value_at(track, network._property("eep.camera"), 1.0)
    assert network.get("eep.camera") == halfway == network.get("rc.camera")
    assert halfway.distance == pytest.approx(start.distance)
    assert "eep.camera: 0 s (linear), 2 s (step)" == panel.track_list.item(0).text()

    window.workspace.undo_stack.undo()
    assert [k.time for k in network.tracks[0].keyframes] == [0.0]
    window.workspace.undo_stack.redo()
    assert [k.time for k in network.tracks[0].keyframes] == [0.0, 2.0]
    panel.scrub(2.0)
    assert panel.remove_keyframe()
    assert [k.time for k in network.tracks[0].keyframes] == [0.0]
    window.workspace.undo_stack.undo()

    window.workspace.save_as(tmp_path / "saved.json")
    saved = json.loads((tmp_path / "saved.json").read_text())
    assert [k["time"] for k in saved["tracks"][0]["keyframes"]] == [0.0, 2.0]
    assert vgraph.load(tmp_path / "saved.json").tracks == network.tracks

    window.scene.select_processor("eep")
    window.scene.delete_selected()   # its track stays in the network (for undo) but is not saved
    assert panel.track_list.item(0).text().endswith("(processor removed: not saved)")
    window.workspace.save_as(tmp_path / "removed.json")
    assert "tracks" not in json.loads((tmp_path / "removed.json").read_text())
    assert vgraph.load(tmp_path / "removed.json").tracks == ()
    window.workspace.undo_stack.undo()
    assert panel.track_list.item(0).text() == "eep.camera: 0 s (linear), 2 s (step)"
    panel.scrub(1.0)
    assert network.get("eep.camera") == halfway


def test_a_keyframe_that_cannot_be_interpolated_is_refused_with_the_reason(window, sphere_panel):
    panel, network = sphere_panel
    panel.property_box.setCurrentText("rc.transfer_function")
    assert panel.add_keyframe()
    steps = window.workspace.undo_stack.count()
    panel.scrub(1.0)
    window.workspace.set_property("rc.transfer_function", {"points": [[0, 0, 0, 0, 0], [1, 1, 1, 1, 1]]})
    assert not panel.add_keyframe()
    assert "the transfer functions have 4 and 2 points" in window.statusBar().currentMessage()
    assert len(network.tracks[0].keyframes) == 1
    assert window.workspace.undo_stack.count() == steps + 1   # the TF edit, no keyframe step


def test_scrubbing_renders_coarse_frames_and_the_full_frame_on_release(window, animation_panel, qtbot):
    panel = animation_panel
    window.evaluation.run(wait=True)
    settle(window, qtbot)
    width, height = window.workspace.network.get("canvas.size")
    sizes = []
    window.evaluation.frames.connect(lambda frames, final: sizes.append((frames["canvas"].shape[:2], final)))
    panel.slider.setSliderDown(True)    # the mouse holds the slider
    with qtbot.waitSignal(window.evaluation.frames, timeout=20000):
        panel.slider.setValue(FPS)
    with qtbot.waitSignal(window.evaluation.frames, timeout=20000, check_params_cb=lambda f, final: final):
        panel.slider.setSliderDown(False)
    assert sizes[0] == ((height // 4, width // 4), False)
    assert sizes[-1] == ((height, width), True)


def test_play_runs_to_the_end_of_the_tracks_and_stops(window, sphere_panel, qtbot):
    panel, network = sphere_panel
    panel.property_box.setCurrentText("rc.sampling_rate")
    assert panel.add_keyframe()
    panel.scrub(0.2)
    window.workspace.set_property("rc.sampling_rate", 2.0)
    assert panel.add_keyframe()
    panel.play_button.setChecked(True)   # at the end: plays from the start again
    assert panel.time() == 0.0 and network.get("rc.sampling_rate") == 1.0
    qtbot.waitUntil(lambda: not panel.play_button.isChecked(), timeout=10000)
    assert panel.time() == pytest.approx(0.2) and network.get("rc.sampling_rate") == 2.0
    assert isinstance(network.get("eep.camera"), Camera)


def test_the_view_menu_shows_the_hidden_timeline(window):
    assert not window.timeline_dock.isVisible()   # hidden at first: the canvases keep their size
    window.refresh_dock_menu()
    (action,) = [a for a in window.view_menu.actions() if a.text() == "Timeline"]
    action.trigger()
    assert window.timeline_dock.isVisible()


def test_export_writes_the_frames_vgraph_animate_writes(window, animation_panel, qtbot, tmp_path):
    cli_frames(tmp_path / "cli", "--fps", "1")
    panel = animation_panel
    panel.scrub(2.5)
    assert panel.export(str(tmp_path / "gui"), fps=1) == 5   # one frame a second, as --fps 1
    for index in range(5):
        name = f"frame_{index:04d}.png"
        gui = np.asarray(PIL.Image.open(tmp_path / "gui" / name)).astype(int)
        cli_frame = np.asarray(PIL.Image.open(tmp_path / "cli" / name)).astype(int)
        assert np.abs(gui - cli_frame).max() <= 1
    assert panel.time() == 2.5    # the time shown before, and its state
    assert "Exported 5 frames" in window.statusBar().currentMessage()
    assert panel.export(str(tmp_path / "x.avi")) == 0
    assert "cannot write '.avi' animations" in window.statusBar().currentMessage()
