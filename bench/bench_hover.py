"""Hover readout rate (issue 36: >= 30 updates a second on the CT head): probes sent one after
another to a real render process, each answered before the next is sent, as the GUI does while
the mouse moves (vgraph.gui.hover: one probe in flight). The frame is rendered once first, with
the ray caster's depth drawn in the same pass (the job names the canvas as hovered, as the GUI's
do while the mouse is over it); every probe reads it. ``--cold``: a frame without the depth, so
the first probe draws it.

    .venv/bin/python bench/bench_hover.py [--network networks/raycast_head.json] [--size 512]
        [--probes 300] [--iso] [--cold] [--gui]

``--gui``: through the window (QT_QPA_PLATFORM=offscreen): each synthetic mouse move is timed
until the status bar and corner annotation show its answer (the readout polls every 5 ms).

Prints probes per second (the updates a second the hover can show), over the probes after the
first, and the first probe's time. Numbers on a shared machine: label them so.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import vgraph
from vgraph.fileformat import network_document
from vgraph.live.probes import Probe, status_text
from vgraph.live.render_messages import RenderJob
from vgraph.live.render_process import RenderProcess

ROOT = Path(__file__).resolve().parent.parent


def gui_rate(args) -> None:
    """The same through the GUI: an offscreen main window, mouse moves sent to the canvas view, each
    waited for until the readout shows its answer (status bar and corner annotation)."""
    import os
    import tempfile
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtCore import QEvent, QPointF, QSettings, Qt
    from PySide6.QtGui import QMouseEvent
    from PySide6.QtWidgets import QApplication
    from vgraph.gui.app import MainWindow

    app = QApplication.instance() or QApplication(["bench_hover"])
    with tempfile.TemporaryDirectory() as folder:
        window = MainWindow(QSettings(str(Path(folder) / "settings.ini"), QSettings.IniFormat))
        window.show()
        window.workspace.open(Path(args.network))
        window.workspace.set_property(f"{args.canvas}.size", [args.size, args.size])
        if args.iso:
            window.workspace.set_property("rc.compositing", "iso")
        window.canvases.hover.corner_action.setChecked(True)
        view = window.canvases.views[args.canvas]
        hover = window.canvases.hover
        window.evaluation.hovered = (args.canvas,)  # as after the mouse entered it
        window.evaluation.schedule()
        window.evaluation.run(wait=True)
        app.processEvents()
        rect = view.image_rect()
        rng = np.random.default_rng(0)
        times = []
        for u, v in rng.uniform(0.3, 0.7, size=(args.probes, 2)):
            point = QPointF(rect.left() + u * rect.width(), rect.top() + v * rect.height())
            before, start = hover.answers, time.perf_counter()
            QApplication.sendEvent(view, QMouseEvent(QEvent.MouseMove, point, view.mapToGlobal(point),
                                                     Qt.NoButton, Qt.NoButton, Qt.NoModifier))
            while hover.answers == before:
                app.processEvents()
            times.append(time.perf_counter() - start)
        steady = np.array(times[1:])
        print(f"GUI, {args.network} at {args.size}x{args.size}{' (iso)' if args.iso else ''}: first "
              f"update {times[0] * 1e3:.1f} ms, then {1.0 / steady.mean():.0f} updates/s (median "
              f"{np.median(steady) * 1e3:.2f} ms, max {steady.max() * 1e3:.2f} ms)")
        print("last readout:", window.statusBar().currentMessage())
        window.workspace.undo_stack.setClean()
        window.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--network", default=str(ROOT / "networks" / "raycast_head.json"))
    parser.add_argument("--canvas", default="canvas")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--probes", type=int, default=300)
    parser.add_argument("--iso", action="store_true", help="the ray caster in iso mode (tricubic refinement)")
    parser.add_argument("--cold", action="store_true",
                        help="the frame drawn without the hover's depth: the first probe draws it")
    parser.add_argument("--gui", action="store_true",
                        help="through an offscreen main window: mouse moves to shown answers")
    args = parser.parse_args()
    if args.gui:
        gui_rate(args)
        return

    network = vgraph.load(args.network)
    network.set(f"{args.canvas}.size", (args.size, args.size))
    if args.iso:
        network.set("rc.compositing", "iso")
    renderer = RenderProcess()
    try:
        renderer.submit(RenderJob(1, network_document(network), str(Path(args.network).parent), fresh=True,
                                  hovered=() if args.cold else (args.canvas,)))
        result = renderer.wait(timeout=300)
        if result.error or result.outcome.failed:
            raise SystemExit(f"the frame failed: {result.error or result.outcome.failed}")
        rng = np.random.default_rng(0)
        pixels = rng.uniform(0.3 * args.size, 0.7 * args.size, size=(args.probes, 2))
        times, hits, last = [], 0, None
        for serial, (x, y) in enumerate(pixels):
            start = time.perf_counter()
            renderer.send_probe(Probe(args.canvas, float(x), float(y), (args.size, args.size), serial))
            answer = None
            while answer is None:
                answer = renderer.probe_answer(timeout=5.0)
            times.append(time.perf_counter() - start)
            hits += answer.result is not None and answer.result.hit
            last = answer
        steady = np.array(times[1:])
        print(f"{args.network} at {args.size}x{args.size}{' (iso)' if args.iso else ''}: "
              f"first probe {times[0] * 1e3:.1f} ms, then "
              f"{1.0 / steady.mean():.0f} probes/s (median {np.median(steady) * 1e3:.2f} ms, "
              f"max {steady.max() * 1e3:.2f} ms), {hits}/{len(times)} hits")
        print("last readout:", status_text(last))
    finally:
        renderer.stop()


if __name__ == "__main__":
    main()
