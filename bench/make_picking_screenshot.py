"""The hover readout's picture of docs/guide/picking.md (docs/images/picking_hover.png): the main
window with networks/raycast_head.json in iso mode (the Views perspective), View > Corner Annotation on and the mouse over
the head (a cross marks where: an offscreen window draws no cursor), so the canvas's corner and
the status bar show the picked point, voxel, value and curvatures.

    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/make_picking_screenshot.py
        [--out docs/images/picking_hover.png] [--size 1200x760] [--at 0.45 0.40]

``--at U V``: where the mouse is over the canvas's frame (u right, v down, in [0, 1]).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from gui_window import fresh_window, screenshot_parser, window_size

REPO = Path(__file__).resolve().parent.parent


def shoot(out: Path, size: tuple[int, int], at: tuple[float, float]) -> None:
    from PySide6.QtCore import QEvent, QPointF, Qt
    from PySide6.QtGui import QColor, QMouseEvent, QPainter, QPen
    from PySide6.QtWidgets import QApplication

    with fresh_window(size, REPO / "networks" / "raycast_head.json") as (app, window):
        window.workspace.set_property("rc.compositing", "iso")
        window.perspectives.switch("views")  # the canvas large, beside the properties
        window.canvases.hover.corner_action.setChecked(True)
        window.evaluation.run(wait=True)
        for _ in range(5):
            app.processEvents()
        view = window.canvases.views["canvas"]
        rect = view.image_rect()
        point = QPointF(rect.left() + at[0] * rect.width(), rect.top() + at[1] * rect.height())
        hover = window.canvases.hover
        QApplication.sendEvent(view, QMouseEvent(QEvent.MouseMove, point, view.mapToGlobal(point),
                                                 Qt.NoButton, Qt.NoButton, Qt.NoModifier))
        deadline = time.monotonic() + 120
        while hover.answers == 0 and time.monotonic() < deadline:
            app.processEvents()
            time.sleep(0.01)
        if hover.answers == 0:
            raise SystemExit("the render process gave no answer to the hover's probe")
        print(window.statusBar().currentMessage())
        app.processEvents()
        picture = window.grab()
        painter = QPainter(picture)
        painter.setPen(QPen(QColor(255, 80, 60), 2))
        centre = view.mapTo(window, point.toPoint())
        painter.drawLine(centre.x() - 8, centre.y(), centre.x() + 8, centre.y())
        painter.drawLine(centre.x(), centre.y() - 8, centre.x(), centre.y() + 8)
        painter.end()
        out.parent.mkdir(parents=True, exist_ok=True)
        if not picture.save(str(out)):
            raise SystemExit(f"could not write {out}")
        print(f"wrote {out}")
        window.workspace.undo_stack.setClean()
        window.close()


def main(argv=None) -> int:
    parser = screenshot_parser(__doc__, REPO / "docs" / "images" / "picking_hover.png", "1200x760")
    parser.add_argument("--at", type=float, nargs=2, default=(0.45, 0.40), metavar=("U", "V"))
    args = parser.parse_args(argv)
    shoot(args.out, window_size(args.size), tuple(args.at))
    return 0


if __name__ == "__main__":
    sys.exit(main())
