"""A user's session in the GUI, scripted: the times the user waits for the window, the first image,
each edit's refined image and each save.

    .venv/bin/python bench/bench_gui_session.py --xvfb          # a real X server, xdotool input
    .venv/bin/python bench/bench_gui_session.py --quick          # offscreen, Qt events, ~15 s
        [--network networks/raycast_head.json] [--size 512] [--out bench/results]

The session (on a copy of the network in a temporary folder, so Save writes there):

1. starts the window as ``vgraph gui NETWORK`` does and waits for it to be shown, then for the first
   image (the full-resolution frame painted on the canvas);
2. clicks the RayCaster ``rc`` in the network editor, clicks its sampling-rate box in the
   inspector, selects all, types a new rate and presses Return; waits for the refined image;
3. drags a transfer-function control point up with the mouse; waits for the refined image;
4. orbits the camera with a mouse drag on the canvas; waits for the refined image after release;
5. presses Ctrl+S; waits until the file is written; then Ctrl+Shift+S, waits for the dialog, types
   a new file name, presses Return and waits until that file is written;
6. presses F9: waits for the views perspective (gui/perspectives.py; the canvas's share of the
   window is noted), and F9 again: waits for the network editor;
7. MPR (gui_session_mpr.py): Ctrl+O, types the path of a copy of networks/mpr_mri_head.json, waits
   for its four images; F9; in the axial slice view a left drag (the cursor follows), a right drag
   (window/level) and three wheel notches (paging), each waited for until the linked coronal view's
   refined image; the window is grabbed; F9 back;
8. placement (gui_session_placement.py): Ctrl+S, Ctrl+N, then double-clicks VolumeSource,
   EntryExitPoints, RayCaster and Canvas in the palette: each must land below the one before and
   connect to it.

With ``--xvfb`` the script runs itself again on a private Xvfb display with Qt's xcb platform, and
the input is real X input from ``xdotool`` (mouse moves, button and key presses, typed text), as a
person's would be; without it (Qt's offscreen platform, no X server) the same steps are Qt events
sent to the same widgets. Each wait is timed from the moment the input is sent (the button
released, Return or the shortcut pressed) to the moment the result is there (the refined frame
painted: LiveEvaluation.frames with final=True and the canvas's next paint; a saved file: the
workspace clean and the file on disk). The table is printed and written to
bench/results/gui_session_<time>.json, .csv and .png (a bar per wait) with grabs of the window: at
the end (_window.png) and in the views perspective after the MPR gestures (_mpr.png). The input,
the timed log and the MPR and placement steps are the gui_session_*.py modules beside this one.
"""

from __future__ import annotations

import time

LAUNCHED = time.monotonic()  # before the heavy imports: "window shown" counts them, as a user does

import argparse  # noqa: E402
import csv  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from dataclasses import asdict  # noqa: E402
from pathlib import Path  # noqa: E402

from gui_session_input import QtInput, XdotoolInput  # noqa: E402
from gui_session_log import FrameLog, Wait  # noqa: E402
from gui_session_mpr import mpr_steps  # noqa: E402
from gui_session_placement import placement_steps  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
NETWORK = REPO / "networks" / "raycast_head.json"
MPR_NETWORK = REPO / "networks" / "mpr_mri_head.json"
CANVAS, RAY_CASTER = "canvas", "rc"
WAIT_TIMEOUT_S = 180.0  # a step that takes longer has failed (60 s with --quick)


# --- the session ---------------------------------------------------------------------------------
def session(window, user, frames: FrameLog, folder: Path, quick: bool, waits: list[Wait],
            opened: float = LAUNCHED, shots: dict | None = None):
    """The user's steps (a generator: yields what to wait for; see ``Stepper``); ``opened``: when
    the network was opened; ``shots``: grabs of the window taken on the way (name: QPixmap)."""
    from PySide6.QtCore import QPointF
    from PySide6.QtWidgets import QApplication, QFileDialog, QScrollArea
    from vgraph.gui.items import NODE_HEIGHT, NODE_WIDTH

    def refined(step: str, mark: float, detail: str = ""):
        yield from frames.refined(window, waits, step, mark, detail)

    yield lambda: frames.refined_after(LAUNCHED) is not None
    first = frames.refined_after(LAUNCHED)
    waits.append(Wait("launch", "first image", round(first - LAUNCHED, 3),
                      f"{first - opened:.1f} s after the network was opened; {frames.render_time_of(first)}"))

    # Edit a property: the RayCaster in the editor, its sampling rate in the inspector.
    view = window.view
    node = window.scene.nodes[RAY_CASTER]
    centre = view.mapFromScene(node.scenePos() + QPointF(NODE_WIDTH / 2, NODE_HEIGHT / 3))
    yield from user.click(view.viewport(), QPointF(centre))
    yield lambda: window.inspector.processor_id == RAY_CASTER
    spin = window.inspector.editors["sampling_rate"].spin
    scroll = next((w for w in _ancestors(spin) if isinstance(w, QScrollArea)), None)
    if scroll is not None:
        scroll.ensureWidgetVisible(spin)   # as a user scrolls to it
    yield 0.05
    rate = 0.5 if spin.value() >= 1.0 else 2.0
    yield from user.click(spin, QPointF(spin.width() / 3, spin.height() / 2))
    yield from user.keys(spin, "ctrl+a")
    yield from user.type(spin, f"{rate:g}")
    mark = time.monotonic()
    yield from user.keys(spin, "Return")
    yield lambda: window.workspace.network.get(f"{RAY_CASTER}.sampling_rate") == rate
    yield from refined("sampling rate typed in", mark, f"rc.sampling_rate = {rate:g}")

    # Drag a transfer-function point up.
    plot = window.inspector.editors["transfer_function"].plot
    if scroll is not None:
        scroll.ensureWidgetVisible(plot)
    yield 0.05
    index = max(1, len(plot.points) // 2)
    position, *_, opacity = plot.points[index]
    before = list(plot.points[index])
    target = min(opacity + 0.25, 1.0)
    yield from user.press_and_move(plot, plot.to_pixel(position, opacity), plot.to_pixel(position, target),
                                   0.3 if quick else 0.8)
    mark = time.monotonic()
    yield from user.release(plot, plot.to_pixel(position, target))
    after = window.workspace.network.get(f"{RAY_CASTER}.transfer_function")
    if abs(_opacity_near(after, position) - before[-1]) < 0.05:
        raise RuntimeError("the drag on the transfer-function plot did not move its point")
    yield from refined("TF point dragged", mark, f"point {index}: opacity {before[-1]:.2f} -> {target:.2f}")

    # Orbit: a trackball drag on the canvas.
    canvas = window.canvases.views[CANVAS]
    middle = QPointF(canvas.width() / 2, canvas.height() / 2)
    turn = QPointF(canvas.height() * 0.4, canvas.height() * 0.1)
    camera = window.workspace.network.get(f"{RAY_CASTER}.camera")
    start = time.monotonic()
    yield from user.press_and_move(canvas, middle, middle + turn, 0.5 if quick else 1.5)
    mark = time.monotonic()
    yield from user.release(canvas, middle + turn)
    if window.workspace.network.get(f"{RAY_CASTER}.camera") == camera:
        raise RuntimeError("the drag on the canvas did not turn the camera")
    yield from refined("camera orbited", mark, f"{frames.shown_between(start, mark)} frames shown during "
                       f"the {mark - start:.1f} s drag")

    # Save (Ctrl+S) over the copy, then Save As under a new name (typed into the dialog).
    path = window.workspace.path
    written = path.stat().st_mtime_ns
    yield from user.click(view.viewport(), QPointF(8, 8))   # focus in the window, off any node
    mark = time.monotonic()
    yield from user.keys(view.viewport(), "ctrl+s")
    yield lambda: window.workspace.undo_stack.isClean() and path.stat().st_mtime_ns != written
    waits.append(Wait("Ctrl+S", "saved", round(time.monotonic() - mark, 3), path.name))
    copy = folder / "session_copy.json"
    mark = time.monotonic()
    yield from user.keys(view.viewport(), "ctrl+shift+s")
    yield lambda: isinstance(QApplication.activeModalWidget(), QFileDialog)
    waits.append(Wait("Ctrl+Shift+S", "Save As dialog", round(time.monotonic() - mark, 3)))
    dialog = QApplication.activeModalWidget()
    yield from user.keys(dialog, "ctrl+a")
    yield from user.type(dialog, str(copy))
    mark = time.monotonic()
    yield from user.keys(dialog, "Return")
    yield lambda: copy.exists() and window.workspace.path == copy and window.workspace.undo_stack.isClean()
    waits.append(Wait("Save As + Return", "saved", round(time.monotonic() - mark, 3), copy.name))

    # F9: the views perspective (the canvas takes the window), then F9 back to the editor.
    yield from user.click(view.viewport(), QPointF(8, 8))
    window.activateWindow()   # a click does that under X; Qt events after the closed dialog do not
    yield lambda: QApplication.activeWindow() is window
    mark = time.monotonic()
    yield from user.keys(view.viewport(), "F9")
    yield lambda: window.perspectives.current == "views" and window.evaluation.idle() and canvas.isVisible()
    share = canvas.width() * canvas.height() / (window.width() * window.height())
    waits.append(Wait("F9", "views perspective", round(time.monotonic() - mark, 3),
                      f"the canvas takes {share:.0%} of the window"))
    mark = time.monotonic()
    yield from user.keys(canvas, "F9")
    yield lambda: window.perspectives.current == "editing" and view.isVisible()
    waits.append(Wait("F9 again", "network editor", round(time.monotonic() - mark, 3)))

    # MPR: open the multi-planar network, drag, window/level and page in a slice (gui_session_mpr.py);
    # then a new network built by double-clicks in the palette (gui_session_placement.py).
    mpr_size = window.workspace.network.get(f"{CANVAS}.size")[0] if quick else None
    yield from mpr_steps(window, user, copy_network(MPR_NETWORK, folder), waits,
                         {} if shots is None else shots, quick, mpr_size)
    yield from placement_steps(window, user, waits)


def _opacity_near(transfer_function, position: float) -> float:
    """The opacity of the transfer function's control point nearest ``position``."""
    points = transfer_function.points if hasattr(transfer_function, "points") else transfer_function["points"]
    return min(points, key=lambda p: abs(p[0] - position))[-1]


def _ancestors(widget):
    while widget is not None:
        widget = widget.parentWidget()
        yield widget


class Stepper:
    """Runs the session generator from a timer, so it goes on inside nested event loops (the
    Save As dialog's). It yields a number (seconds to wait), a subprocess (wait until it exits) or
    a callable (wait until it returns true); a wait longer than ``timeout`` fails the session."""

    def __init__(self, steps, timeout: float = WAIT_TIMEOUT_S):
        from PySide6.QtCore import QEventLoop, QTimer
        self.steps, self.waiting, self.since = steps, None, 0.0
        self.timeout = timeout
        self.error: BaseException | None = None
        self.done, self._busy = False, False
        self.loop = QEventLoop()
        self.timer = QTimer()
        self.timer.setInterval(2)
        self.timer.timeout.connect(self._tick)

    def run(self) -> None:
        self.timer.start()
        self._advance()
        if not self.done:
            self.loop.exec()
        self.timer.stop()
        if self.error is not None:
            raise self.error

    def _ready(self) -> bool:
        waiting = self.waiting
        if isinstance(waiting, subprocess.Popen):
            return waiting.poll() is not None
        if isinstance(waiting, (int, float)):
            return time.monotonic() >= self.since + waiting
        return bool(waiting())

    def _tick(self) -> None:
        if self._busy or self.done:
            return
        if self._ready():
            self._advance()
        elif time.monotonic() - self.since > self.timeout:
            self._advance(TimeoutError(f"waited {self.timeout:.0f} s for {self.waiting!r}"))

    def _advance(self, error: BaseException | None = None) -> None:
        self._busy = True
        try:
            self.waiting = self.steps.throw(error) if error else next(self.steps)
            self.since = time.monotonic()
        except StopIteration:
            self._finish()
        except BaseException as failure:  # reported by run()
            self.error = failure
            self._finish()
        finally:
            self._busy = False

    def _finish(self) -> None:
        from PySide6.QtWidgets import QApplication
        self.done = True
        dialog = QApplication.activeModalWidget()
        if dialog is not None:   # a failure while a dialog is up: its event loop would keep ours
            dialog.close()
        self.loop.quit()


# --- running it ----------------------------------------------------------------------------------
def copy_network(source: Path, folder: Path) -> Path:
    """The network in ``folder`` with its file paths made absolute (they are relative to its own)."""
    document = json.loads(source.read_text())
    for processor in document["processors"]:
        path = processor.get("properties", {}).get("path")
        if isinstance(path, str) and not Path(path).is_absolute():
            processor["properties"]["path"] = str((source.parent / path).resolve())
    target = folder / source.name
    target.write_text(json.dumps(document, indent=1))
    return target


def run_session(args, folder: Path) -> tuple[list[Wait], dict]:
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication
    from vgraph.gui.app import MainWindow
    from vgraph.live.render_process import RenderProcess
    app = QApplication.instance() or QApplication(["vgraph"])
    imported = time.monotonic()
    renderer = RenderProcess()
    started = time.monotonic()
    user = XdotoolInput() if os.environ.get("QT_QPA_PLATFORM") == "xcb" else QtInput()
    network = copy_network(args.network, folder)
    settings = QSettings(str(folder / "settings.ini"), QSettings.IniFormat)
    waits: list[Wait] = []
    window = MainWindow(settings, renderer)
    window.remember_layout = False
    window.move(0, 0)
    window.resize(1600, 1000)
    window.show()
    window.activateWindow()
    while not (window.windowHandle() and window.windowHandle().isExposed()):
        app.processEvents()
    shown = time.monotonic()
    waits.append(Wait("launch", "window shown", round(shown - LAUNCHED, 3),
                      f"imports {imported - LAUNCHED:.1f} s, render process {started - imported:.1f} s, "
                      f"window {shown - started:.1f} s; input: {user.__class__.__name__}"))
    opened = time.monotonic()
    if not window.open_network(network):            # as `vgraph gui NETWORK` does
        raise SystemExit(f"cannot open {network}")
    waits.append(Wait("launch", "network opened", round(time.monotonic() - opened, 3), args.network.name))
    window.workspace.network.set(f"{CANVAS}.size", [args.size, args.size])  # the bench's, not an edit
    frames = FrameLog(window, CANVAS)
    shots: dict = {}
    try:
        Stepper(session(window, user, frames, folder, args.quick, waits, opened, shots),
                60.0 if args.quick else WAIT_TIMEOUT_S).run()
        shots["window"] = window.grab()
    finally:
        window.workspace.undo_stack.setClean()
        window.close()
        window.evaluation.shutdown()
    return waits, shots


def report(waits: list[Wait], out: Path, shots: dict, platform: str) -> Path:
    width = max(len(f"{w.step}: {w.waits_for}") for w in waits)
    print(f"platform: {platform}")
    print(f"{'what the user waits for':<{width}}  {'seconds':>8}  detail")
    for w in waits:
        print(f"{w.step + ': ' + w.waits_for:<{width}}  {w.seconds:>8.3f}  {w.detail}")
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"gui_session_{time.strftime('%Y%m%d_%H%M%S')}"
    stem.with_suffix(".json").write_text(json.dumps({"platform": platform, "waits": [asdict(w) for w in waits]},
                                                    indent=1))
    with open(stem.with_suffix(".csv"), "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(asdict(waits[0])))
        writer.writeheader()
        writer.writerows(asdict(w) for w in waits)
    plot(waits, stem.with_suffix(".png"), platform)
    for name, shot in shots.items():
        shot.save(f"{stem}_{name}.png")
    print(f"wrote {stem}.json, .csv, .png and " + ", ".join(f"_{name}.png" for name in shots))
    return stem


def plot(waits: list[Wait], path: Path, platform: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    labels = [f"{w.step}: {w.waits_for}" for w in waits][::-1]
    figure, axes = plt.subplots(figsize=(8, 0.4 * len(waits) + 1.2))
    axes.barh(labels, [w.seconds for w in waits][::-1], color="#2f6fd6")
    axes.set_xlabel("seconds the user waits")
    axes.set_title(f"bench_gui_session ({platform})")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def under_xvfb(argv: list[str]) -> int:
    """Run this script again on a private Xvfb display with Qt's xcb platform (input by xdotool)."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        raise SystemExit("--xvfb: Xvfb is not installed (apt install xvfb xauth)")
    if shutil.which("xdotool") is None:
        raise SystemExit("--xvfb: xdotool is not installed (apt install xdotool)")
    display = f":{150 + os.getpid() % 100}"
    server = subprocess.Popen([xvfb, display, "-screen", "0", "1600x1000x24", "-nolisten", "tcp"],
                              stderr=subprocess.DEVNULL)
    try:
        time.sleep(1.0)
        if server.poll() is not None:
            raise SystemExit(f"Xvfb could not start on {display}")
        env = dict(os.environ, DISPLAY=display, QT_QPA_PLATFORM="xcb")
        return subprocess.call([sys.executable, __file__, *[a for a in argv if a != "--xvfb"]], env=env)
    finally:
        server.terminate()
        server.wait(timeout=10)


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--network", type=Path, default=NETWORK, help="a network with rc (RayCaster) -> canvas")
    parser.add_argument("--size", type=int, default=None, help="canvas pixels (default 512, 256 with --quick)")
    parser.add_argument("--quick", action="store_true", help="shorter drags and a 256^2 canvas")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    parser.add_argument("--xvfb", action="store_true", help="run under Xvfb with xdotool input")
    args = parser.parse_args(argv)
    args.size = args.size or (256 if args.quick else 512)
    return args


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    if args.xvfb:
        return under_xvfb(argv)
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    with tempfile.TemporaryDirectory() as folder:
        waits, shots = run_session(args, Path(folder))
    report(waits, args.out, shots, os.environ["QT_QPA_PLATFORM"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
