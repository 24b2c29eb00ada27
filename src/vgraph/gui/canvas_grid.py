"""Canvases side by side: the canvas docks in a grid instead of tabbed together.

A multi-planar layout (networks/mpr_mri_head.json) shows its axial, coronal and sagittal slices
and the 3D view at once; canvas docks are tabbed by default (layout.place_canvas), so View > Tile
Canvases lays them out in a grid, row by row in network order, in the dock area of the first:
2 canvases side by side, 3 or 4 in two rows of two, and so on (columns = ceil(sqrt(n))). The docks
stay ordinary docks: the user can tab, float or move them again, and the layout is remembered
like any other.
"""

from __future__ import annotations

import math

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QApplication, QDockWidget, QMainWindow


def grid_shape(count: int) -> tuple[int, int]:
    """(rows, columns) of the grid for ``count`` canvases."""
    columns = max(1, math.ceil(math.sqrt(count)))
    return max(1, math.ceil(count / columns)), columns


def tile_canvases(window: QMainWindow, docks: list[QDockWidget]) -> None:
    """Lay ``docks`` out in a grid in the dock area of the first (module docstring)."""
    if len(docks) < 2:
        return
    area = window.dockWidgetArea(docks[0])
    extent = docks[0].size()  # the tabbed docks' space, which the grid shares out
    if area == Qt.NoDockWidgetArea:
        area = Qt.LeftDockWidgetArea
    # splitDockWidget adds a tab instead when the first dock is tabbed: take them all out first.
    for dock in docks:
        window.removeDockWidget(dock)
    QApplication.processEvents()  # lets the emptied tab bar go; it stays drawn over the grid otherwise
    window.addDockWidget(area, docks[0])
    rows, columns = grid_shape(len(docks))
    grid = [docks[r * columns:(r + 1) * columns] for r in range(rows)]
    for above, below in zip(grid, grid[1:]):
        window.splitDockWidget(above[0], below[0], Qt.Vertical)
    for row in grid:
        for left, right in zip(row, row[1:]):
            window.splitDockWidget(left, right, Qt.Horizontal)
    for dock in docks:
        dock.setFloating(False)
        dock.show()
    # Equal shares of that space: the rows, then the columns of each row.
    window.resizeDocks([row[0] for row in grid], [extent.height() // rows] * rows, Qt.Vertical)
    for row in grid:
        window.resizeDocks(row, [extent.width() // len(row)] * len(row), Qt.Horizontal)
