"""Make docs/images/animation_timeline.png: frames of networks/animation_torus.json's keyframe
tracks (docs/guide/animation.md), rendered as `vgraph animate --timeline` renders them, side by
side with their times, plus a screenshot of the GUI's Timeline dock holding the same tracks.

    .venv/bin/python bench/make_animation_figure.py [--out docs/images/animation_timeline.png]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import PIL.Image
import PIL.ImageDraw

import vgraph
from vgraph.animation import animate
from vgraph.tracks import frame_times

REPO = Path(__file__).resolve().parents[1]
NETWORK = REPO / "networks" / "animation_torus.json"
OUT = REPO / "docs" / "images" / "animation_timeline.png"
FRAMES, SIZE, GAP = 5, 192, 6


def frame_strip() -> PIL.Image.Image:
    network = vgraph.load(NETWORK)
    times = frame_times(network.tracks, 30.0, FRAMES)
    with tempfile.TemporaryDirectory() as folder:
        animate(network, folder, timeline=True, frames=FRAMES, size=(SIZE, SIZE))
        frames = [PIL.Image.open(Path(folder) / f"frame_{i:04d}.png").convert("RGB") for i in range(FRAMES)]
    strip = PIL.Image.new("RGB", (FRAMES * SIZE + (FRAMES - 1) * GAP, SIZE + 22), "white")
    draw = PIL.ImageDraw.Draw(strip)
    for index, (frame, time) in enumerate(zip(frames, times)):
        x = index * (SIZE + GAP)
        strip.paste(frame, (x, 0))
        draw.text((x + SIZE // 2 - 12, SIZE + 5), f"{time:g} s", fill="black")
    return strip


def dock_screenshot(width: int) -> PIL.Image.Image:
    import os
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication
    from vgraph.gui.app import MainWindow
    app = QApplication.instance() or QApplication([])
    with tempfile.TemporaryDirectory() as folder:
        window = MainWindow(QSettings(str(Path(folder) / "settings.ini"), QSettings.IniFormat))
        window.remember_layout = False
        window.show()
        window.open_network(NETWORK)
        window.timeline_dock.show()
        window.timeline_dock.setFloating(True)
        window.timeline_dock.resize(width, 190)
        panel = window.timeline_dock.widget()
        window.scene.select_processor("eep")   # the property box shows its camera
        panel.scrub(2.0)
        for _ in range(5):
            app.processEvents()
        path = Path(folder) / "dock.png"
        panel.grab().save(str(path), "PNG")
        image = PIL.Image.open(path).convert("RGB")
        window.workspace.undo_stack.setClean()
        window.close()
    return image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    strip = frame_strip()
    dock = dock_screenshot(strip.width)
    figure = PIL.Image.new("RGB", (strip.width, strip.height + dock.height + GAP), "white")
    figure.paste(strip, (0, 0))
    figure.paste(dock, (0, strip.height + GAP))
    figure.save(args.out, optimize=True)
    print(f"wrote {args.out} ({figure.width}x{figure.height}); frames at {np.round(frame_times(vgraph.load(NETWORK).tracks, 30.0, FRAMES), 3).tolist()} s")


if __name__ == "__main__":
    main()
