"""The multi-planar picture of docs/guide/exploring.md (docs/images/exploring_mpr.png): the main window
with networks/mpr_mri_head.json, its canvases tiled (View > Tile Canvases), a click in the axial
slice that moved the shared cursor (the coronal and sagittal planes follow), the axial viewer
selected so the inspector shows the SliceViewer's properties.

    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/make_mpr_screenshot.py
        [--out docs/images/exploring_mpr.png] [--size 1600x1000] [--click 0.40 0.62]

``--click U V``: where the axial slice is clicked, as image coordinates (u right, v up, in [0, 1]).
"""

from __future__ import annotations

import sys
from pathlib import Path

from gui_window import fresh_window, screenshot_parser, window_size

REPO = Path(__file__).resolve().parent.parent


def shoot(out: Path, size: tuple[int, int], click: tuple[float, float]) -> None:
    from PySide6.QtCore import QPointF, Qt

    from vgraph.live import slice_clicks
    from vgraph.gui.app import save_screenshot
    from vgraph.gui.canvas_grid import tile_canvases

    with fresh_window(size, REPO / "networks" / "mpr_mri_head.json") as (app, window):
        docks = [window.canvases.docks[i] for i in ("axial_canvas", "coronal_canvas",
                                                      "sagittal_canvas", "canvas")]
        tile_canvases(window, docks)
        window.resizeDocks([window.palette_dock], [int(size[0] * 0.5)], Qt.Horizontal)  # room for four
        window.resizeDocks([window.palette_dock], [int(size[1] * 0.12)], Qt.Vertical)
        window.scene.select_processor("axial")
        window.evaluation.run(wait=True)
        for _ in range(5):
            app.processEvents()
        axial = window.canvases.views["axial_canvas"]
        rect = axial.image_rect()
        point = QPointF(rect.left() + click[0] * rect.width(), rect.top() + (1 - click[1]) * rect.height())
        if not slice_clicks.click(axial, point):
            raise SystemExit("the axial canvas does not show a slice")
        print("cursor:", window.workspace.network.get("axial.cursor"))
        save_screenshot(window, out)
        print(f"wrote {out}")


def main(argv=None) -> int:
    parser = screenshot_parser(__doc__, REPO / "docs" / "images" / "exploring_mpr.png", "1920x1080")
    parser.add_argument("--click", type=float, nargs=2, default=(0.40, 0.62), metavar=("U", "V"))
    args = parser.parse_args(argv)
    shoot(args.out, window_size(args.size), tuple(args.click))
    return 0


if __name__ == "__main__":
    sys.exit(main())
