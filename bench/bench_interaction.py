"""GUI interaction: frames per second while the user drags, and the time to the refined frame.

    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/bench_interaction.py
        [--networks head bonsai tets_bonsai store] [--store URL] [--canvas 512] [--drags camera property tf] [--seconds 2]
        [--coarse-tetrahedra N [N ...]] [--out bench/results] [--xvfb]

Opens each network in a MainWindow with its own render process (as ``vgraph gui`` does), the
Canvas at 512 x 512, and drives three drags with input events every 16 ms (a 60 Hz mouse):

- camera: a trackball drag on the canvas (press, moves along a line, release);
- property: the RayCaster's ``diffuse`` slider in the inspector, pressed, moved and released
  (``QSlider.setSliderDown`` / ``setValue``: the signals a mouse drag on the slider gives);
- tf: a control point of the transfer-function plot dragged up and down with the mouse.

Networks: ``head`` is networks/raycast_head.json; ``bonsai`` is the same network on
shared/data/ct_bonsai (256^3 uint8), with a camera that fits the data and a leaves-and-pot TF;
``tets_bonsai`` is networks/tets_bonsai.json (the culled bonsai as 6.2 M tetrahedra, projected),
dragged with the camera only (its other drags would cut the mesh again each frame), with its
ProjectedTetrahedra's ``coarse_tetrahedra`` at each value of ``--coarse-tetrahedra`` in turn, drag
by drag in the same window (0: the whole mesh while dragging, as before vgraph.mesh_lod; default:
the processor's own), so that the machine's load falls on every setting alike. ``store`` is the
same network on the store ``--store`` names (default the virtual 1024^3 store
``implicit:torus?size=1024&brick=64``, computed on read: no disk; or a path to an OME-Zarr store such
as the bonsai resampled to 1024^3, docs/guide/large-data.md) drawn by a BrickedRayCaster (its
``method`` auto: dvr in one pass through the page table), camera drags only; the GUI draws coarse
frames under its load limit while the mouse moves, then refines (vgraph.frame_context).

Per drag it records, at the window, every frame given to the canvas (``LiveEvaluation.frames``:
when, its size, final or not) and when it was first painted (an event filter on the canvas) and, in the render process, every job (``RenderResult``'s timestamps: submitted,
started, finished, received; one clock for both processes). It reports frames per second while
the mouse moves (at the window and jobs finished in the render process), the coarse frame size,
the mean evaluation and transfer times, the stale jobs the render process skipped (a newer one
waited behind them) and the results the window did not show (a newer one arrived with them), and
the time from the release to the refined frame (the final, full-size
frame shown at the window; and when the render process finished it). Prints a table and writes
bench/results/interaction_<time>.csv and .png.

``--overhead`` measures instead, without the GUI, the Python time per frame of the render process's
``network.update`` on a cached network when only the camera changes (the frame drawn at 8 x 8
pixels; the time inside GL draws, clears and uniform writes subtracted): the scheduler and the uniform set-up. It
is the CPU time of the calling thread (``time.thread_time``), so waiting for a core on a loaded
machine does not count; llvmpipe's own threads do not either. It also counts the Python function
calls per frame, a figure the load cannot blur.

``--xvfb`` runs the same under a real X server (Xvfb, QT_QPA_PLATFORM=xcb) if Xvfb is installed,
so frames are painted by a real window system.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data"
HEAD = REPO / "networks" / "raycast_head.json"
TETS_BONSAI = REPO / "networks" / "tets_bonsai.json"
BONSAI = DATA / "ct_bonsai" / "bonsai.nii.gz"
BONSAI_TF = [[0.0, 0, 0, 0, 0], [0.15, 0.3, 0.6, 0.2, 0.0], [0.3, 0.4, 0.8, 0.3, 0.3],
             [0.75, 0.8, 0.6, 0.4, 0.5], [1.0, 1.0, 1.0, 1.0, 0.9]]
MOVE_MS = 16
CANVAS = "canvas"
RAY_CASTER = "rc"
SLIDER_PROPERTY = "diffuse"


@dataclass
class Row:
    network: str
    drag: str
    seconds: float            # mouse down to mouse up
    moves: int                # input events sent
    window_frames: int        # frames painted on the canvas during the drag
    window_fps: float
    coarse_size: str          # width x height of the frames shown during the drag
    render_jobs: int          # jobs the render process finished during the drag
    render_fps: float
    evaluate_ms: float        # mean per job during the drag, in the render process
    transfer_ms: float        # mean: finished in the render process -> received by the window
    round_trip_ms: float      # mean: submitted -> received
    skipped: int              # jobs the render process did not render: a newer one was waiting
    dropped: int              # results not shown at the window: a newer one arrived with them
    render_refined_s: float   # release -> the render process finished the refined frame
    window_refined_s: float   # release -> the refined frame painted


def bonsai_network(folder: Path) -> Path:
    """networks/raycast_head.json on the bonsai: camera fitting the data, its own TF."""
    document = json.loads(HEAD.read_text())
    for processor in document["processors"]:
        properties = processor["properties"]
        if processor["id"] == "source":
            properties["path"] = str(BONSAI)
        if "camera" in properties:
            properties["camera"] = {"projection": "perspective", "position": [-0.45, -0.35, -1.0],
                                    "focus": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0], "fov": 30.0,
                                    "fit_to_data": True}
        if processor["id"] == RAY_CASTER:
            properties["transfer_function"] = {"points": BONSAI_TF}
            properties["sampling_rate"] = 1.0
    document["description"] = "CT bonsai (256^3) ray cast as raycast_head.json (bench_interaction)"
    path = folder / "raycast_bonsai.json"
    path.write_text(json.dumps(document, indent=1))
    return path


STORE = "implicit:torus?size=1024&brick=64"
STORE_TF = [[0.0, 0, 0, 0, 0], [0.3, 0.9, 0.6, 0.4, 0.0], [0.6, 1.0, 0.8, 0.6, 0.5], [1.0, 1.0, 1.0, 1.0, 0.9]]


def store_network(folder: Path, url: str) -> Path:
    """networks/raycast_head.json on the store ``url`` with a BrickedRayCaster in the RayCaster's
    place (its properties that the BrickedRayCaster has), a camera that fits the data, a ramp TF."""
    from vgraph.processors.bricked_raycaster import BrickedRayCaster
    document = json.loads(bonsai_network(folder).read_text())
    for processor in document["processors"]:
        if processor["id"] == "source":
            processor["properties"] = {"path": url}
        if processor["id"] == RAY_CASTER:
            processor["type"] = "BrickedRayCaster"
            kept = {name: value for name, value in processor["properties"].items()
                    if hasattr(BrickedRayCaster, name)}
            processor["properties"] = {**kept, "transfer_function": {"points": STORE_TF}}
    document["description"] = f"{url} ray cast by a BrickedRayCaster (bench_interaction)"
    path = folder / "bricked_store.json"
    path.write_text(json.dumps(document, indent=1))
    return path


def _paint_filter():
    from PySide6.QtCore import QEvent, QObject

    class PaintFilter(QObject):
        """Calls ``painted()`` when the canvas is about to paint."""

        def __init__(self, painted):
            super().__init__()
            self.painted = painted

        def eventFilter(self, watched, event):
            if event.type() == QEvent.Paint:
                self.painted()
            return False
    return PaintFilter


class Recorder:
    """Frames given to the canvas, when each was first painted, and the results received from the
    render process, timestamped. A frame replaced before a paint was never seen."""

    def __init__(self, window):
        self.window = window
        self.frames: list[list] = []   # [time given, (w, h), final, time first painted or None]
        self.results: list = []
        window.evaluation.frames.connect(self._frame)
        window.evaluation.received.connect(self.results.append)
        self.filter = _paint_filter()(self._painted)
        window.canvases.views[CANVAS].installEventFilter(self.filter)

    def _frame(self, frames: dict, final: bool) -> None:
        frame = frames.get(CANVAS)
        if frame is not None:
            self.frames.append([time.monotonic(), (frame.shape[1], frame.shape[0]), bool(final), None])

    def _painted(self) -> None:
        if self.frames and self.frames[-1][3] is None:
            self.frames[-1][3] = time.monotonic()

    def clear(self) -> None:
        self.frames.clear()
        self.results.clear()


def wait_until(deadline: float) -> None:
    from PySide6.QtWidgets import QApplication
    while True:
        QApplication.processEvents()
        left = deadline - time.monotonic()
        if left <= 0:
            return
        time.sleep(min(left, 0.001))


def settle(window, timeout: float = 120.0) -> None:
    """Until the render process has rendered the current state and the refined frame is shown."""
    deadline = time.monotonic() + timeout
    evaluation = window.evaluation
    while not (evaluation.idle() and window.canvases.views[CANVAS].is_final):
        if time.monotonic() > deadline:
            raise SystemExit("the render process did not catch up within the timeout")
        wait_until(time.monotonic() + 0.005)


def drive(seconds: float, step) -> tuple[float, float, int]:
    """Call ``step(fraction)`` every MOVE_MS for ``seconds``; returns (start, end, steps)."""
    start = time.monotonic()
    count = int(seconds * 1000 / MOVE_MS)
    for i in range(1, count + 1):
        wait_until(start + i * MOVE_MS / 1000.0)
        step(i / count)
    return start, time.monotonic(), count


def camera_drag(window, seconds: float):
    from PySide6.QtCore import QEvent, QPointF, Qt
    from scripted_user import send_mouse
    canvas = window.canvases.views[CANVAS]
    centre = QPointF(canvas.width() / 2, canvas.height() / 2)
    offset = QPointF(canvas.height() * 0.5, canvas.height() * 0.15)  # about a quarter turn
    send_mouse(canvas, QEvent.MouseButtonPress, centre, Qt.LeftButton, Qt.LeftButton)
    start, end, count = drive(seconds, lambda f: send_mouse(
        canvas, QEvent.MouseMove, centre + offset * f, Qt.NoButton, Qt.LeftButton))
    send_mouse(canvas, QEvent.MouseButtonRelease, centre + offset, Qt.LeftButton, Qt.NoButton)
    return start, end, count


def property_drag(window, seconds: float):
    window.scene.select_processor(RAY_CASTER)
    slider = window.inspector.editors[SLIDER_PROPERTY].slider
    low, high = slider.minimum(), slider.maximum()
    slider.setSliderDown(True)   # sliderPressed, as a press on the handle
    # There and back: 0.7 -> 0.2 -> 0.7 of the range, one value per move.
    start, end, count = drive(seconds, lambda f: slider.setValue(
        round(low + (high - low) * (0.7 - 1.0 * min(f, 1.0 - f)))))
    slider.setSliderDown(False)  # sliderReleased
    return start, end, count


def tf_drag(window, seconds: float):
    from PySide6.QtCore import QEvent, Qt
    from scripted_user import send_mouse
    window.scene.select_processor(RAY_CASTER)
    plot = window.inspector.editors["transfer_function"].plot
    index = max(1, len(plot.points) // 2)
    position, *_, opacity = plot.points[index]
    low, high = max(opacity - 0.25, 0.0), min(opacity + 0.25, 1.0)
    pressed = plot.to_pixel(position, opacity)
    send_mouse(plot, QEvent.MouseButtonPress, pressed, Qt.LeftButton, Qt.LeftButton)
    start, end, count = drive(seconds, lambda f: send_mouse(
        plot, QEvent.MouseMove, plot.to_pixel(position, low + (high - low) * abs(1.0 - 2.0 * f)),
        Qt.NoButton, Qt.LeftButton))
    send_mouse(plot, QEvent.MouseButtonRelease, plot.to_pixel(position, high), Qt.LeftButton, Qt.NoButton)
    return start, end, count


DRAGS = {"camera": camera_drag, "property": property_drag, "tf": tf_drag}
NETWORK_DRAGS = {"tets_bonsai": ("camera",), "store": ("camera",)}  # the drags a network is measured with, if not all


def measure(window, recorder: Recorder, network: str, drag: str, seconds: float) -> Row:
    settle(window)
    recorder.clear()
    dropped = getattr(window.evaluation, "frames_dropped", 0)  # (absent before it was counted)
    start, end, moves = DRAGS[drag](window, seconds)
    settle(window)
    wait_until(time.monotonic() + 0.2)  # the refined frame's paint
    during = [f for f in recorder.frames if f[3] is not None and start <= f[3] <= end]
    jobs = [r for r in recorder.results if start <= r.finished <= end and r.outcome.frames]
    refined_render = [r for r in recorder.results if r.finished > end and r.scale == 1.0]
    refined_window = [f for f in recorder.frames if f[0] > end and f[2] and f[3] is not None]
    sizes = sorted({f"{w}x{h}" for _, (w, h), _, _ in during})

    def mean_ms(values):
        return round(1000.0 * statistics.fmean(values), 1) if values else float("nan")
    return Row(network, drag, round(end - start, 2), moves, len(during), round(len(during) / (end - start), 1),
               "/".join(sizes) or "-", len(jobs), round(len(jobs) / (end - start), 1),
               mean_ms([r.seconds for r in jobs]), mean_ms([r.received - r.finished for r in jobs]),
               mean_ms([r.received - r.submitted for r in jobs]),
               sum(1 for r in recorder.results if getattr(r, "skipped", False)),
               getattr(window.evaluation, "frames_dropped", 0) - dropped,
               round(refined_render[-1].finished - end, 2) if refined_render else float("nan"),
               round(refined_window[-1][3] - end, 2) if refined_window else float("nan"))


def open_window(path: Path, settings_dir: Path, canvas: int = 512):
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication
    from vgraph.gui.app import MainWindow
    from vgraph.live.render_process import RenderProcess
    QApplication.instance() or QApplication([])
    settings = QSettings(str(settings_dir / "settings.ini"), QSettings.IniFormat)
    window = MainWindow(settings, RenderProcess())
    window.resize(1600, 1000)
    window.show()
    if not window.open_network(path):
        raise SystemExit(f"cannot open {path}")
    window.workspace.network.set(f"{CANVAS}.size", [canvas, canvas])
    window.evaluation.run(wait=True)
    settle(window)
    return window


HEADER = ["network", "drag", "s", "moves", "win frames", "win fps", "coarse", "rp jobs", "rp fps",
          "eval ms", "xfer ms", "trip ms", "skipped", "dropped", "rp refined s", "win refined s"]


def print_row(row: Row) -> None:
    values = list(asdict(row).values())
    print("  ".join(f"{v!s:>{max(len(h), 6)}}" for v, h in zip(values, HEADER)), flush=True)


def plot(rows: list[Row], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    labels = [f"{r.network}\n{r.drag}" for r in rows]
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    x = range(len(rows))
    left.bar([i - 0.2 for i in x], [r.window_fps for r in rows], 0.4, label="at the window")
    left.bar([i + 0.2 for i in x], [r.render_fps for r in rows], 0.4, label="render process")
    left.axhline(15, color="grey", linestyle="--", linewidth=1, label="target 15 fps")
    left.set_xticks(list(x), labels)
    left.set_ylabel("frames per second while dragging")
    left.legend()
    right.bar([i - 0.2 for i in x], [r.render_refined_s for r in rows], 0.4, label="render process")
    right.bar([i + 0.2 for i in x], [r.window_refined_s for r in rows], 0.4, label="at the window")
    right.set_xticks(list(x), labels)
    right.set_ylabel("seconds from release to the refined frame")
    right.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=100)


def python_overhead(path: Path, frames: int = 300) -> tuple[float, float, float, float]:
    """(median, 10th percentile, median GL) milliseconds per camera frame of ``network.update``,
    and the Python function calls per frame (cProfile: a count a loaded machine cannot blur)."""
    import cProfile
    import pstats

    import moderngl
    from vgraph.fileformat import load_network
    in_gl = [0.0]

    def timed(cls, name):
        original = getattr(cls, name)

        def wrapper(self, *args, **kwargs):
            start = time.thread_time()
            try:
                return original(self, *args, **kwargs)
            finally:
                in_gl[0] += time.thread_time() - start
        setattr(cls, name, wrapper)
    # GL calls: draws, clears and uniform writes (a write waits while llvmpipe still draws with the
    # program: up to 0.2 ms per frame on the bonsai, driver time, not ours).
    timed(moderngl.VertexArray, "render")
    timed(moderngl.Framebuffer, "clear")
    timed(moderngl.Uniform, "write")
    network = load_network(path)
    network.update(CANVAS, size=(8, 8))
    camera = network.get(f"{RAY_CASTER}.camera")
    python, gl = [], []
    for i in range(frames):
        network.set(f"{RAY_CASTER}.camera", camera.rotate(0.002 * (i + 1), 0.0))
        in_gl[0] = 0.0
        start = time.thread_time()
        network.update(CANVAS, size=(8, 8))
        python.append(time.thread_time() - start - in_gl[0])
        gl.append(in_gl[0])
    python, gl = python[frames // 5:], gl[frames // 5:]  # after the first frames (compiling, caches)
    profile = cProfile.Profile()
    for i in range(100):
        network.set(f"{RAY_CASTER}.camera", camera.rotate(-0.002 * (i + 1), 0.0))
        profile.enable()
        network.update(CANVAS, size=(8, 8))
        profile.disable()
    calls = sum(entry[1] for entry in pstats.Stats(profile).stats.values()) / 100
    return (1e3 * statistics.median(python), 1e3 * sorted(python)[len(python) // 10], 1e3 * statistics.median(gl),
            calls)


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--networks", nargs="+", choices=["head", "bonsai", "tets_bonsai", "store"], default=["head", "bonsai"])
    parser.add_argument("--canvas", type=int, default=512, help="the canvas's width and height in pixels")
    parser.add_argument("--store", default=STORE, help="the store of network 'store' (a path or implicit: URL)")
    parser.add_argument("--drags", nargs="+", choices=list(DRAGS), default=list(DRAGS))
    parser.add_argument("--seconds", type=float, default=2.0, help="length of each drag")
    parser.add_argument("--repeat", type=int, default=1, help="drags of each kind per network")
    parser.add_argument("--coarse-tetrahedra", type=int, nargs="+", default=None,
                        help="tets_bonsai: the ProjectedTetrahedra's coarse_tetrahedra, each in turn "
                             "(0: the whole mesh while dragging)")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    parser.add_argument("--xvfb", action="store_true", help="run under Xvfb (a real X server)")
    parser.add_argument("--overhead", action="store_true",
                        help="only the Python time per camera frame of network.update (no GUI)")
    return parser.parse_args(argv)


def under_xvfb(argv: list[str]) -> int:
    """Run this script again on a private Xvfb display with Qt's xcb platform."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        raise SystemExit("--xvfb: Xvfb is not installed (apt install xvfb xauth)")
    display = f":{90 + os.getpid() % 100}"
    server = subprocess.Popen([xvfb, display, "-screen", "0", "1600x1000x24", "-nolisten", "tcp"])
    try:
        time.sleep(1.0)
        env = dict(os.environ, DISPLAY=display, QT_QPA_PLATFORM="xcb")
        return subprocess.call([sys.executable, __file__, *[a for a in argv if a != "--xvfb"]], env=env)
    finally:
        server.terminate()
        server.wait(timeout=10)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    if args.xvfb:
        return under_xvfb(argv)
    if args.overhead:
        with tempfile.TemporaryDirectory() as folder:
            paths = {"head": HEAD, "bonsai": bonsai_network(Path(folder))}
            for name in args.networks:
                median, low, gl, calls = python_overhead(paths[name])
                print(f"{name}: Python per camera frame {median:.3f} ms (10th percentile {low:.3f} ms), "
                      f"{calls:.0f} function calls; GL draws and clears {gl:.3f} ms", flush=True)
        return 0
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    rows = []
    print("platform:", os.environ.get("QT_QPA_PLATFORM"), flush=True)
    print("  ".join(f"{h:>{max(len(h), 6)}}" for h in HEADER), flush=True)
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        paths = {"head": HEAD, "bonsai": bonsai_network(folder), "tets_bonsai": TETS_BONSAI,
                 "store": store_network(folder, args.store)}
        for name in args.networks:
            window = open_window(paths[name], folder, args.canvas)
            recorder = Recorder(window)
            settings = [None] if name != "tets_bonsai" or not args.coarse_tetrahedra else args.coarse_tetrahedra
            try:
                for drag in [d for d in args.drags if d in NETWORK_DRAGS.get(name, DRAGS)]:
                    for _ in range(args.repeat):
                        for setting in settings:  # in turn: the load drifts over every setting alike
                            label = name
                            if setting is not None:
                                window.workspace.set_property("pt.coarse_tetrahedra", setting)
                                label = f"{name} coarse={setting}"
                            row = measure(window, recorder, label, drag, args.seconds)
                            rows.append(row)
                            print_row(row)
            finally:
                window.workspace.undo_stack.setClean()
                window.close()
                window.evaluation.shutdown()
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.out / f"interaction_{time.strftime('%Y%m%d_%H%M%S')}"
    with open(stem.with_suffix(".csv"), "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(asdict(rows[0])))
        writer.writeheader()
        writer.writerows(asdict(r) for r in rows)
    plot(rows, stem.with_suffix(".png"))
    print(f"wrote {stem}.csv and .png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
