"""Pictures of the docs that set renderings side by side: a row of panels (RGBA float arrays of one
height) with a white gap of 8 pixels between them, written as a PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vgraph.imagefile import write_png

GAP = 8  # pixels of white between panels


def write_panel_row(out: Path, panels: list[np.ndarray]) -> None:
    gap = np.ones((panels[0].shape[0], GAP, 4), dtype=np.float32)
    row = [item for panel in panels for item in (panel, gap)][:-1]
    write_png(out, np.concatenate(row, axis=1))
