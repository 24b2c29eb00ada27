"""The Timeline dock's Export: the tracks rendered by the window's render process into an MP4, a
GIF or PNG frames (vgraph.animation_output, the writers of `vgraph animate`), one canvas at its
size, one frame every 1/fps seconds from 0 to the end of the tracks.

Conventions:
- Each frame is the canvas's final frame of the moment (every tracked property set to its value
  then, ``tracks.apply_tracks``), waited for as `vgraph gui --screenshot` waits: the frames are the
  ones the window shows, so they equal `vgraph animate --timeline`'s within one 8-bit step
  (tests/test_gui_timeline.py).
- The window stays responsive between frames (events are processed while a frame renders); the
  status bar counts the frames. The time shown before the export is shown again afterwards.
- A bad path, no canvas or no tracks: VGraphError naming the reason, nothing written (the
  writers are atomic: a failure halfway leaves no partial video).
"""

from __future__ import annotations

import time

import numpy as np
from PySide6.QtWidgets import QApplication

from vgraph.animation_output import Output
from vgraph.errors import VGraphError
from vgraph.tracks import apply_tracks, frame_times

FRAME_TIMEOUT_SECONDS = 600.0


def export_timeline(window, path, fps: float, canvas_id: str | None = None, progress=None) -> int:
    """Write the frames of the window's network's tracks from canvas ``canvas_id`` (default the
    first) to ``path``; returns the number of frames. ``progress(done, total)`` after each."""
    network, views = window.workspace.network, window.canvases.views
    if not network.tracks:
        raise VGraphError("the network has no tracks to export: add keyframes first")
    if not views:
        raise VGraphError("the network has no canvas to export frames of")
    view = views[canvas_id or next(iter(views))]
    output = Output.of(path)
    output.check()
    times = frame_times(network.tracks, fps)
    with output.writer(fps) as write:
        for index, seconds in enumerate(times):
            apply_tracks(network, network.tracks, seconds)
            write(final_frame(window, view).astype(np.float32) / 255.0, index)
            if progress is not None:
                progress(index + 1, len(times))
    return len(times)


def final_frame(window, view) -> np.ndarray:
    """The view's frame once the render process has drawn the current state in full."""
    evaluation = window.evaluation
    evaluation.run(wait=True)
    deadline = time.monotonic() + FRAME_TIMEOUT_SECONDS
    while not (evaluation.idle() and view.is_final and view.frame() is not None):
        if time.monotonic() > deadline:
            raise VGraphError(f"no final frame within {FRAME_TIMEOUT_SECONDS:g} s: export stopped")
        QApplication.processEvents()  # a refining frame is rendered again by LiveEvaluation itself
        time.sleep(0.005)
    return view.frame()
