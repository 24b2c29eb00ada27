"""The multi-planar steps of bench/bench_gui_session.py: the user opens networks/mpr_mri_head.json
(Ctrl+O, the path typed into the dialog), goes to the views perspective (F9) and, in the axial slice
view, left-drags (the cursor follows the mouse, the linked slices follow), right-drags (window/level)
and turns the wheel three notches (pages through the volume); then F9 back to the editor. Each
gesture must change what it drives in the network (and the linked viewers with it), else the
session fails; the wait is from the release (the last notch) to the coronal view's refined image.
The window is grabbed in the views perspective after the gestures (``shots["mpr"]``)."""

from __future__ import annotations

import time
from pathlib import Path

from PySide6.QtCore import QPointF

from gui_session_log import FrameLog, Wait

MPR_CANVASES = ("axial_canvas", "coronal_canvas", "sagittal_canvas", "canvas")
AXIAL, LINKED = "axial", "coronal"   # the viewer the gestures are made in, one linked to it
WHEEL_NOTCHES = 3


def _rounded(value) -> str:
    return "None" if value is None else "(" + ", ".join(f"{x:.1f}" for x in value) + ")"


def _all_final(window) -> bool:
    return window.evaluation.idle() and all(v.is_final and v.frame() is not None
                                            for v in window.canvases.views.values())


def mpr_steps(window, user, network: Path, waits: list[Wait], shots: dict, quick: bool, size: int | None):
    """The steps (session generator); ``network``: a copy of mpr_mri_head.json; ``size``: the
    canvases' pixels (None: the network's)."""
    from PySide6.QtWidgets import QApplication, QFileDialog
    view = window.view
    yield from user.click(view.viewport(), QPointF(8, 8))
    yield from user.keys(view.viewport(), "ctrl+o")
    yield lambda: isinstance(QApplication.activeModalWidget(), QFileDialog)
    dialog = QApplication.activeModalWidget()
    yield from user.keys(dialog, "ctrl+a")
    yield from user.type(dialog, str(network))
    mark = time.monotonic()
    yield from user.keys(dialog, "Return")
    yield lambda: window.workspace.path == network and "axial_canvas" in window.canvases.views
    if size is not None:
        for canvas in MPR_CANVASES:   # the bench's, not an edit
            window.workspace.network.set(f"{canvas}.size", [size, size])
    yield lambda: _all_final(window)
    waits.append(Wait("Ctrl+O + Return", "MPR images", round(time.monotonic() - mark, 3),
                      f"{network.name}: all four canvases refined"))

    yield from user.click(view.viewport(), QPointF(8, 8))
    window.activateWindow()   # a click does that under X; Qt events after the closed dialog do not
    yield lambda: QApplication.activeWindow() is window
    mark = time.monotonic()
    yield from user.keys(view.viewport(), "F9")
    axial = window.canvases.views["axial_canvas"]
    yield lambda: window.perspectives.current == "views" and axial.isVisible() and _all_final(window)
    seconds = round(time.monotonic() - mark, 3)
    yield 0.3   # the re-tiled docks settle (an X server resizes them later) before the mouse goes to them
    share = sum(v.width() * v.height() for v in window.canvases.views.values()) / (window.width() * window.height())
    waits.append(Wait("F9", "views perspective (MPR)", seconds, f"the four canvases take {share:.0%} of the window"))

    yield from _cursor_drag(window, user, axial, waits, quick)
    yield from _window_drag(window, user, axial, waits, quick)
    yield from _page(window, user, axial, waits)
    shots["mpr"] = window.grab()

    mark = time.monotonic()
    yield from user.keys(axial, "F9")
    yield lambda: window.perspectives.current == "editing" and view.isVisible()
    waits.append(Wait("F9 again", "network editor", round(time.monotonic() - mark, 3)))


def _cursor_drag(window, user, axial, waits, quick):
    network, linked = window.workspace.network, FrameLog(window, f"{LINKED}_canvas")
    rect = axial.image_rect()
    start = rect.center()
    end = start + QPointF(rect.width() * 0.15, -rect.height() * 0.1)
    before = network.get(f"{AXIAL}.cursor")
    began = time.monotonic()
    yield from user.press_and_move(axial, start, end, 0.3 if quick else 1.0, button=1)
    mark = time.monotonic()
    yield from user.release(axial, end, button=1)
    yield 0.05
    after = network.get(f"{AXIAL}.cursor")
    if after is None or after == before or network.get(f"{LINKED}.cursor") != after:
        raise RuntimeError(f"the left drag in the axial slice did not move the cursor ({before} -> {after})")
    yield from linked.refined(window, waits, "left drag (axial): cursor", mark,
                              f"cursor {_rounded(before)} -> {_rounded(after)}; "
                              f"{linked.shown_between(began, mark)} coronal frames during the drag")


def _window_drag(window, user, axial, waits, quick):
    network, linked = window.workspace.network, FrameLog(window, f"{LINKED}_canvas")
    rect = axial.image_rect()
    start = rect.center()
    end = start + QPointF(rect.width() * 0.2, -rect.height() * 0.1)
    before = network.get(f"{AXIAL}.window")
    yield from user.press_and_move(axial, start, end, 0.3 if quick else 1.0, button=3)
    mark = time.monotonic()
    yield from user.release(axial, end, button=3)
    yield 0.05
    after = network.get(f"{AXIAL}.window")
    if after is None or after == before or network.get(f"{LINKED}.window") != after:
        raise RuntimeError(f"the right drag in the axial slice did not change window/level ({before} -> {after})")
    yield from linked.refined(window, waits, "right drag (axial): window/level", mark,
                              f"(level, width) {_rounded(before)} -> {_rounded(after)}")


def _page(window, user, axial, waits):
    network, linked = window.workspace.network, FrameLog(window, f"{LINKED}_canvas")
    before = network.get(f"{AXIAL}.cursor")
    yield from user.wheel(axial, axial.image_rect().center(), WHEEL_NOTCHES)
    mark = time.monotonic()
    yield lambda: network.get(f"{AXIAL}.cursor") != before
    yield 0.4   # the wheel burst ends (canvas_mouse.WHEEL_IDLE_MS) before the refined frame counts
    after = network.get(f"{AXIAL}.cursor")
    moved = [round(b - a, 2) for a, b in zip(before, after)]
    if network.get(f"{LINKED}.cursor") != after:
        raise RuntimeError("paging the axial slice did not move the linked cursor")
    yield from linked.refined(window, waits, f"wheel x{WHEEL_NOTCHES} (axial): page", mark,
                              f"cursor moved by {moved}")
