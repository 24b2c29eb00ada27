"""The markups-in-slices picture of docs/guide/measuring.md (docs/images/markups_slices.png): the
main window with networks/mpr_mri_head.json, its canvases tiled, a Markups processor holding a
ruler, an angle and a closed curve drawn in the axial slice (so they show whole there, and the
ruler's and the curve's crossings show in the coronal and sagittal slices), the Markups dock shown
below with the ruler's row selected (so the inspector shows the Markups node).

    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/make_slice_markups_screenshot.py
        [--out docs/images/markups_slices.png] [--size 1920x1080]
"""

from __future__ import annotations

from pathlib import Path

from gui_window import fresh_window, screenshot_main

REPO = Path(__file__).resolve().parent.parent


def markups_in(plane):
    """A ruler, an angle and a closed curve at image coordinates of the axial slice's plane."""
    from vgraph.markups import Markup, Markups

    def at(*uvs):
        return tuple(tuple(float(v) for v in plane.world_at(u, v)) for u, v in uvs)
    return Markups(markups=(
        Markup(name="width", kind="ruler", points=at((0.25, 0.42), (0.75, 0.42))),
        Markup(name="nose", kind="angle", points=at((0.40, 0.80), (0.50, 0.92), (0.60, 0.80))),
        Markup(name="region", kind="closed_curve", points=at((0.35, 0.25), (0.65, 0.25), (0.60, 0.12),
                                                             (0.40, 0.12)))))


def shoot(out: Path, size: tuple[int, int]) -> None:
    from PySide6.QtCore import Qt

    from vgraph.gui.app import save_screenshot
    from vgraph.gui.canvas_grid import tile_canvases

    with fresh_window(size, REPO / "networks" / "mpr_mri_head.json") as (app, window):
        docks = [window.canvases.docks[i] for i in ("axial_canvas", "coronal_canvas", "sagittal_canvas", "canvas")]
        tile_canvases(window, docks)
        window.resizeDocks([window.palette_dock], [int(size[0] * 0.5)], Qt.Horizontal)
        window.resizeDocks([window.palette_dock], [int(size[1] * 0.12)], Qt.Vertical)
        window.evaluation.run(wait=True)
        for _ in range(5):
            app.processEvents()
        workspace = window.workspace
        workspace.add_processor("Markups", (420, 0), id="markups")
        workspace.set_property("markups.units", "mm")
        workspace.set_property("markups.markups", markups_in(window.evaluation.view_cameras["axial.slice_plane"]))
        window.markups_dock.show()
        window.markups_dock.raise_()
        window.resizeDocks([window.markups_dock], [int(size[1] * 0.2)], Qt.Vertical)
        window.markups_dock.widget().select("markups.markups", "width")
        save_screenshot(window, out)
        print(f"wrote {out}")


def main(argv=None) -> int:
    return screenshot_main(__doc__, REPO / "docs" / "images" / "markups_slices.png", "1920x1080", shoot, argv)


if __name__ == "__main__":
    raise SystemExit(main())
