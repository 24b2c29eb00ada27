"""Saving a canvas's frame: where the dialog starts and what it writes (no widgets here).

- The file is the frame exactly as rendered (the pixels ``vgraph run`` writes for the same network),
  RGBA, written atomically; overlays are drawn by the widget and never saved.
- The dialog starts in the network's folder with ``<network>_<canvas>.png`` (``<canvas>.png`` in
  the current folder for an untitled network); if that file exists, the first free
  ``<name>_2.png``, ``<name>_3.png``, ..., so repeated screenshots do not overwrite each other.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vgraph.imagefile import write_png

IMAGE_FILTER = "PNG images (*.png)"


def suggested_image_path(network_path: str | Path | None, canvas_id: str,
                         folder: str | Path | None = None) -> Path:
    """Where Save Image / Export Image starts for ``canvas_id`` of the network saved at
    ``network_path`` (None: untitled, in ``folder``, by default the current folder)."""
    if network_path is not None:
        network_path = Path(network_path)
        folder, stem = network_path.resolve().parent, f"{network_path.stem}_{canvas_id}"
    else:
        folder, stem = Path(folder) if folder is not None else Path.cwd(), canvas_id
    candidate, number = folder / f"{stem}.png", 2
    while candidate.exists():
        candidate, number = folder / f"{stem}_{number}.png", number + 1
    return candidate


def write_frame(frame: np.ndarray, path: str | Path) -> Path:
    """Write a uint8 RGBA frame (row 0 at the top) as a PNG; a path without suffix gets .png.
    Raises OutputFileError when the file cannot be written."""
    path = Path(path)
    if not path.suffix:
        path = path.with_suffix(".png")
    # write_png takes floats in [0, 1]; k / 255 rounds back to exactly k.
    write_png(path, np.asarray(frame).astype(np.float64) / 255.0)
    return path
