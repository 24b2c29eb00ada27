"""The GUI screenshots of docs/guide/gui.md: the whole main window at 1280 x 800 and 1920 x 1080 with
networks/raycast_head.json loaded, rendered and its RayCaster selected (the inspector shows the
camera and the transfer-function editor), the canvas with its toolbar and the axes and box overlays.

    xvfb-run -s "-screen 0 1920x1080x24" .venv/bin/python bench/make_gui_screenshots.py
    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/make_gui_screenshots.py   # no X server
        [--network networks/raycast_head.json] [--select rc] [--out docs/images]
        [--sizes 1280x800 1920x1080] [--perspective views] [--welcome]

``--perspective views`` shoots the views perspective (gui/perspectives.py) instead, to
<out>/gui_views_<W>x<H>.png (the docs use networks/mpr_mri_head.json with --select canvas), and
prints which share of the window's area the canvases take. ``--welcome`` shoots the first window
a user sees, without a network (the welcome page: gui/welcome.py), to <out>/gui_welcome_<W>x<H>.png,
with two of the shipped networks as its recent files (``WELCOME_RECENT``); the docs use 1280x800.

Each size gets a fresh window with its own settings file (the user's remembered layout is not
used), laid out as a first run on a screen of that size (``layout.arrange``), so the pictures show
what a new user sees. Writes <out>/gui_<W>x<H>.png and prints, per size, whether the inspector
needed a horizontal scroll bar and whether the TF editor and the camera editor are fully visible.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from gui_window import fresh_window

REPO = Path(__file__).resolve().parent.parent
WELCOME_RECENT = ("networks/mpr_mri_head.json", "networks/raycast_head.json")   # most recent first


def canvas_share(window) -> float:
    """The canvases' visible area over the window's (tests/test_gui_perspectives.py measures the same)."""
    area = sum(view.width() * view.height() for view in window.canvases.views.values()
               if view.isVisible() and not view.visibleRegion().isEmpty())
    return area / (window.width() * window.height())


def shoot(network: Path, select: str, size: tuple[int, int], out: Path, perspective: str = "editing") -> dict:
    from PySide6.QtWidgets import QScrollArea

    from vgraph.gui.app import save_screenshot
    from vgraph.gui.layout import shown_whole
    from vgraph.gui.canvas_toolbar import overlay_setting
    from vgraph.gui.transfer_function_editor import TransferFunctionEditor

    both_overlays = {overlay_setting("canvas", "box"): True}
    with fresh_window(size, network, settings_values=both_overlays) as (app, window):
        window.scene.select_processor(select)
        if perspective != "editing":
            window.perspectives.switch(perspective)
        window.evaluation.run(wait=True)
        for _ in range(5):
            app.processEvents()
        if perspective != "editing":
            path = out / f"gui_{perspective}_{size[0]}x{size[1]}.png"
            report = {"window": (window.width(), window.height()),
                      "canvases' share of the window": f"{canvas_share(window):.0%}"}
            save_screenshot(window, path)
            window.deleteLater()
            app.processEvents()
            return report
        scroll = window.inspector.findChild(QScrollArea)
        editors = window.inspector.findChildren(TransferFunctionEditor)
        report = {
            "window": (window.width(), window.height()),
            "inspector horizontal scroll bar": bool(scroll and scroll.horizontalScrollBar().isVisible()),
            "TF editor fully visible": bool(editors) and all(shown_whole(e) for e in editors),
            "camera editor fully visible": shown_whole(window.inspector.editors.get("camera")),
            "canvas shows its frame": all(v.frame() is not None and shown_whole(v)
                                          for v in window.canvases.views.values()),
        }
        path = out / f"gui_{size[0]}x{size[1]}.png"
        save_screenshot(window, path)
        window.deleteLater()
        app.processEvents()
    return report


def shoot_welcome(size: tuple[int, int], out: Path) -> dict:
    """The window as it opens without a network: the welcome page in the middle (module docstring)."""
    from vgraph.gui.app import save_screenshot

    with fresh_window(size, recent=tuple(REPO / name for name in WELCOME_RECENT)) as (app, window):
        for _ in range(5):
            app.processEvents()
        page = window.welcome.page
        report = {"window": (window.width(), window.height()), "welcome page shown": window.welcome.showing(),
                  "page's share of the window": f"{page.width() * page.height() / (window.width() * window.height()):.0%}"}
        path = out / f"gui_welcome_{size[0]}x{size[1]}.png"
        save_screenshot(window, path)
        window.deleteLater()
        app.processEvents()
    return report


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--network", type=Path, default=REPO / "networks" / "raycast_head.json")
    parser.add_argument("--select", default="rc", help="processor shown in the inspector")
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images")
    parser.add_argument("--sizes", nargs="+", default=["1280x800", "1920x1080"])
    parser.add_argument("--perspective", choices=["editing", "views"], default="editing")
    parser.add_argument("--welcome", action="store_true", help="the window without a network: the welcome page")
    args = parser.parse_args(argv)
    if not os.environ.get("DISPLAY") and "QT_QPA_PLATFORM" not in os.environ:
        os.environ["QT_QPA_PLATFORM"] = "offscreen"
    args.out.mkdir(parents=True, exist_ok=True)
    for text in args.sizes:
        width, height = (int(v) for v in text.lower().split("x"))
        if args.welcome:
            report = shoot_welcome((width, height), args.out)
        else:
            report = shoot(args.network.resolve(), args.select, (width, height), args.out, args.perspective)
        print(f"{width}x{height}: " + ", ".join(f"{k}: {v}" for k, v in report.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
