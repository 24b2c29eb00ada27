"""A line plot drawn on the CPU into an RGBA array (matplotlib's Agg canvas; no window, no Qt), as
the LineProfile processor's ``plot`` outport shows a profile.

The figure is made with matplotlib.figure.Figure, not pyplot: pyplot keeps figures in a global
registry (a leak in a long GUI session, and not thread safe). matplotlib is imported when a plot is
drawn: it takes a second to import and a network without a plot never needs it.
"""

from __future__ import annotations

import numpy as np

DPI = 100.0
MIN_SIZE = (64, 48)  # pixels: smaller plots leave no room for the axes
SMALL = 200  # pixels: a plot narrower or lower than this (a thumbnail) shows the curve and ticks only


def line_plot(x: np.ndarray, y: np.ndarray, size: tuple[int, int], *, title: str, x_label: str,
              y_label: str) -> np.ndarray:
    """(height, width, 4) float32 RGBA in [0, 1], row 0 at the top, of y against x on white; NaN
    values leave gaps in the line. ``size`` is (width, height), at least MIN_SIZE; below SMALL
    pixels the title and axis labels are left out, which would cover the curve."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    width, height = max(size[0], MIN_SIZE[0]), max(size[1], MIN_SIZE[1])
    figure = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    canvas = FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    axes.plot(x, y, color="#1f77b4", linewidth=1.5)
    if min(width, height) >= SMALL:
        axes.set_title(title, fontsize="medium")
        axes.set_xlabel(x_label)
        axes.set_ylabel(y_label)
    else:
        axes.tick_params(labelsize=6)
    axes.grid(True, alpha=0.3)
    if len(x):
        axes.set_xlim(float(x[0]), float(x[-1]))
    figure.tight_layout()
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba(), dtype=np.float32) / 255.0
    return rgba
