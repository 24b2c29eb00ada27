"""The Tables dock picture of docs/guide/measuring.md (docs/images/table_dock.png): the main
window with networks/measure_engine.json, the LineProfile selected, so the Tables dock (shown below,
tabbed with the Log) lists its samples, sorted by value, highest first, the first rows selected
as for Ctrl+C; the canvas shows the profile's plot.

    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/make_table_dock_screenshot.py
        [--out docs/images/table_dock.png] [--size 1600x900]
"""

from __future__ import annotations

from pathlib import Path

from gui_window import fresh_window, screenshot_main

REPO = Path(__file__).resolve().parent.parent


def shoot(out: Path, size: tuple[int, int]) -> None:
    from PySide6.QtCore import Qt

    from vgraph.gui.app import save_screenshot

    with fresh_window(size, REPO / "networks" / "measure_engine.json") as (app, window):
        window.evaluation.run(wait=True)
        window.scene.select_processor("profile")
        dock = window.table_dock
        dock.show()
        dock.raise_()
        window.resizeDocks([dock], [int(size[1] * 0.35)], Qt.Vertical)
        panel = dock.widget()
        panel.view.sortByColumn(4, Qt.DescendingOrder)   # value
        panel.view.selectRow(0)
        for row in (1, 2):
            panel.view.selectionModel().select(panel.model.index(row, 0),
                                               panel.view.selectionModel().SelectionFlag.Select
                                               | panel.view.selectionModel().SelectionFlag.Rows)
        for _ in range(5):
            app.processEvents()
        save_screenshot(window, out)
        print(f"wrote {out}")


def main(argv=None) -> int:
    return screenshot_main(__doc__, REPO / "docs" / "images" / "table_dock.png", "1600x900", shoot, argv)


if __name__ == "__main__":
    raise SystemExit(main())
