"""Pixels of a widget as a user sees them, and where world points land on it: for the tests of
what the canvas draws over a frame (the box, the axes, the slice planes)."""

import numpy as np
from PySide6.QtGui import QImage


def grab_rgba(widget) -> np.ndarray:
    """The widget as painted, (height, width, 4) uint8 RGBA."""
    image = widget.grab().toImage().convertToFormat(QImage.Format_RGBA8888)
    array = np.frombuffer(image.constBits(), np.uint8).reshape(image.height(), image.bytesPerLine())
    return array[:, : 4 * image.width()].reshape(image.height(), image.width(), 4).copy()


def widget_points(camera, points, frame_size, rect) -> np.ndarray:
    """Where world points land on the widget, from the camera's own matrices (gluLookAt and
    gluPerspective / glOrtho) and the rectangle the frame is drawn in (pixel-centre NDC)."""
    width, height = frame_size
    clip = np.c_[np.asarray(points, float), np.ones(len(points))] @ (
        camera.projection_matrix(width / height) @ camera.view_matrix()).T
    ndc = clip[:, :2] / clip[:, 3:]
    return np.c_[rect.left() + (ndc[:, 0] + 1) / 2 * rect.width(),
                 rect.top() + (1 - ndc[:, 1]) / 2 * rect.height()]


def near_colour(pixels: np.ndarray, point, colour, reach=1, tolerance=40) -> bool:
    """Some pixel within ``reach`` of ``point`` (x, y) has ``colour`` (RGB, within tolerance)."""
    x, y = int(round(point[0])), int(round(point[1]))
    patch = pixels[max(y - reach, 0): y + reach + 1, max(x - reach, 0): x + reach + 1, :3].astype(int)
    return bool((np.abs(patch - colour).max(axis=-1) <= tolerance).any())


def rgb(qcolor) -> np.ndarray:
    return np.array([qcolor.red(), qcolor.green(), qcolor.blue()])
