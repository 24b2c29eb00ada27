"""Writing images to disk: float RGBA in [0, 1] -> 8-bit PNG, atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import PIL.Image

from vgraph.atomic import atomic_path


def to_uint8(rgba: np.ndarray) -> np.ndarray:
    """Round to nearest after clamping to [0, 1]; NaN becomes 0."""
    values = np.nan_to_num(np.asarray(rgba, dtype=np.float32), nan=0.0)
    return np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def write_png(path: str | Path, rgba: np.ndarray, inside=None) -> None:
    """Write an (H, W, 4) float image (row 0 at the top) as an RGBA PNG (``inside``: the folders
    the write must stay in, vgraph.atomic)."""
    with atomic_path(path, suffix=".png", inside=inside) as temporary:
        PIL.Image.fromarray(to_uint8(rgba)).save(temporary, format="PNG")
