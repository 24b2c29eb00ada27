"""Pictures of the docs that set renderings side by side: a row of panels (RGBA float arrays of one
height) with a white gap of 8 pixels between them, written as a PNG; and the command line of the
scripts that make nothing else."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from vgraph.imagefile import write_png

GAP = 8  # pixels of white between panels


def write_panel_row(out: Path, panels: list[np.ndarray]) -> None:
    gap = np.ones((panels[0].shape[0], GAP, 4), dtype=np.float32)
    row = [item for panel in panels for item in (panel, gap)][:-1]
    write_png(out, np.concatenate(row, axis=1))


def panel_row_main(doc: str, out: Path, panels, argv=None) -> int:
    """The main() of a script whose picture is one row: ``--out`` (default ``out``) gets
    ``panels()``'s row; described by the first line of the script's ``doc``."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=out)
    args = parser.parse_args(argv)
    write_panel_row(args.out, panels())
    print(args.out)
    return 0
