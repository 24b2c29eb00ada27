"""Markups drawn into a coverage mask through a camera, hidden where the scene's depth lies nearer
(the Markups processor's drawing; docs/guide/measuring.md, "Markups").

Conventions:
- Projection: a world point goes through the camera the renderer drew with (its resolved
  ``view_projection`` at the image's aspect) to pixel coordinates (x, y), row 0 at the top, an
  integer being a pixel's centre (as picking and SlicePlane.pixel_to_world).
- Depth test: the renderer's depth image (its ``depth`` outport: g = distance in world units
  along the pixel's ray from the near plane, a = 1 where something was drawn; vgraph.picking reads
  the same) becomes the scene's eye depth per pixel, near + g (ray . forward). A sample of a
  markup is visible where it lies in front of the near plane, inside the image, and no farther
  than the scene's eye depth plus ``tolerance`` world units there (a point picked on a surface
  lies on it, within the renderer's sampling error; the tolerance keeps it visible). Parts behind
  the scene are drawn at ``hidden_opacity`` (0: not at all), as Slicer's occluded markups.
- Lines (ruler, angle arms and arc, closed curves) are sampled along their 3D segments at about
  two samples per pixel and only the visible runs are drawn, so a line that passes behind a
  surface is cut where it does. Points are discs; labels (name and measurement) are drawn where
  their anchor (a ruler's middle, an angle's vertex, a curve's or a point list's first point) is
  visible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from PIL import ImageDraw

from vgraph.camera import Camera
from vgraph.markups import Markup

MAX_SAMPLES_PER_SEGMENT = 8192  # two per pixel of a 4096-pixel-long line
ARC_SEGMENTS = 48


@dataclass(frozen=True)
class MarkupView:
    """A camera at an image size, with the scene's eye depth per pixel (None: no depth test)."""
    camera: Camera              # resolved: near and far set, in world units
    size: tuple[int, int]
    scene_depth: np.ndarray | None = None   # (height, width) eye depth; inf where nothing was drawn
    tolerance: float = 0.0

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(pixels (n, 2) as x, y with row 0 at the top; eye depths (n,)) of world points (n, 3)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        width, height = self.size
        clip = np.c_[points, np.ones(len(points))] @ np.asarray(self.camera.view_projection(width / height)).T
        with np.errstate(divide="ignore", invalid="ignore"):
            ndc = clip[:, :2] / clip[:, 3:4]
        pixels = np.c_[(ndc[:, 0] + 1.0) / 2.0 * width - 0.5, (1.0 - ndc[:, 1]) / 2.0 * height - 0.5]
        depth = (points - np.asarray(self.camera.position)) @ self.camera.basis()[2]
        return pixels, depth

    def visible(self, points) -> np.ndarray:
        """Per world point: in front of the near plane, inside the image and not behind the scene."""
        return self.visibility(points)[1]

    def visibility(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Per world point: (in the view: in front of the near plane and inside the image; and
        shown: in the view and not behind the scene)."""
        pixels, depth = self.project(points)
        width, height = self.size
        column, row = np.floor(pixels[:, 0] + 0.5), np.floor(pixels[:, 1] + 0.5)
        inside = (depth >= self.camera.planes()[0]) & (column >= 0) & (column < width) & (row >= 0) & (row < height)
        if self.scene_depth is None:
            return inside, inside
        shown = inside.copy()
        at = np.flatnonzero(inside)
        scene = self.scene_depth[row[at].astype(int), column[at].astype(int)]
        shown[at] = depth[at] <= scene + self.tolerance
        return inside, shown


def scene_eye_depth(camera: Camera, depth_pixels: np.ndarray) -> np.ndarray:
    """The eye depth per pixel (height, width) of a renderer's depth image read as float32
    (height, width, 4), row 0 at the top; inf where nothing was drawn (a = 0)."""
    height, width = depth_pixels.shape[:2]
    _, directions = camera.rays(width, height)
    eye = camera.planes()[0] + depth_pixels[..., 1] * (directions @ camera.basis()[2])
    return np.where(depth_pixels[..., 3] > 0.0, eye, np.inf)


def draw_markups(draw: ImageDraw.ImageDraw, view: MarkupView, markups, style: "Style") -> None:
    """The markups' lines, points and labels into the coverage mask ``draw``: first the parts
    behind the scene at ``style.hidden_opacity`` (nothing at 0), then the visible parts, fully."""
    hidden = round(255 * style.hidden_opacity)
    for fill, shown in ((hidden, False), (255, True)):
        if fill == 0:
            continue
        for markup in markups:
            _draw_markup(draw, view, markup, style, fill, shown)


def _draw_markup(draw, view: MarkupView, markup: Markup, style: "Style", fill: int, shown: bool) -> None:
    points = markup.array
    lines = {"ruler": points, "angle": points, "closed_curve": np.vstack([points, points[:1]])}.get(markup.kind)
    if lines is not None:
        _draw_polyline(draw, view, lines, style.line_width, fill, shown)
    if markup.kind == "angle":
        _draw_polyline(draw, view, angle_arc(points), style.line_width, fill, shown)
    _draw_points(draw, view, points, style.point_radius, fill, shown)
    if style.font is not None:
        _draw_label(draw, view, markup, style, fill, shown)


@dataclass(frozen=True)
class Style:
    line_width: int
    point_radius: float
    font: object | None      # a Pillow font, or None: no labels
    units: str = ""
    hidden_opacity: float = 0.0  # of the parts behind the scene


def label_text(markup: Markup, units: str = "") -> str:
    """The label of a markup: its name, and its length or angle."""
    unit = f" {units}" if units else ""
    if markup.kind == "ruler":
        return f"{markup.name}: {markup.length:.4g}{unit}"
    if markup.kind == "angle":
        return f"{markup.name}: {markup.angle:.1f}°"
    if markup.kind == "closed_curve":
        return f"{markup.name}: {markup.length:.4g}{unit}"
    return markup.name


def label_anchor(markup: Markup) -> np.ndarray:
    points = markup.array
    if markup.kind == "ruler":
        return (points[0] + points[1]) / 2.0
    if markup.kind == "angle":
        return points[1]
    return points[0]


def _draw_label(draw, view: MarkupView, markup: Markup, style: Style, fill: int, shown: bool) -> None:
    anchor = label_anchor(markup)
    if not _selected(view, anchor[None, :], shown)[0]:
        return
    pixels, _ = view.project(anchor)
    x, y = pixels[0]
    draw.text((x + style.point_radius + 2, y - style.point_radius - 2), label_text(markup, style.units),
              fill=fill, font=style.font, anchor="ld")


def _draw_points(draw, view: MarkupView, points: np.ndarray, radius: float, fill: int, shown: bool) -> None:
    pixels, _ = view.project(points)
    for (x, y), selected in zip(pixels, _selected(view, points, shown)):
        if selected:
            draw.ellipse((x - radius, y - radius, x + radius, y + radius), fill=fill)


def _draw_polyline(draw, view: MarkupView, points: np.ndarray, width: int, fill: int, shown: bool) -> None:
    for start, end in zip(points[:-1], points[1:]):
        samples = _segment_samples(view, start, end)
        pixels, _ = view.project(samples)
        for run in _runs(_selected(view, samples, shown)):
            if len(run) > 1:
                draw.line([tuple(p) for p in pixels[run]], fill=fill, width=width, joint="curve")


def _selected(view: MarkupView, points: np.ndarray, shown: bool) -> np.ndarray:
    """The points shown (``shown``) or those in the view but behind the scene (not ``shown``)."""
    inside, visible = view.visibility(points)
    return visible if shown else inside & ~visible


def _segment_samples(view: MarkupView, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Points along a 3D segment, about two per pixel of its projection (its ends included)."""
    pixels, depth = view.project(np.vstack([start, end]))
    near = view.camera.planes()[0]
    if np.all(np.isfinite(pixels)) and np.all(depth >= near):
        count = int(min(MAX_SAMPLES_PER_SEGMENT, max(2, math.ceil(2 * np.linalg.norm(pixels[1] - pixels[0])) + 1)))
    else:  # an end behind the camera: its projection says nothing of the length on screen
        count = MAX_SAMPLES_PER_SEGMENT
    t = np.linspace(0.0, 1.0, count)[:, None]
    return start + t * (end - start)


def _runs(shown: np.ndarray) -> list[np.ndarray]:
    """Index arrays of the consecutive True stretches of ``shown``."""
    indices = np.flatnonzero(shown)
    if not len(indices):
        return []
    breaks = np.flatnonzero(np.diff(indices) > 1) + 1
    return np.split(indices, breaks)


def angle_arc(points: np.ndarray) -> np.ndarray:
    """The angle's arc: around the vertex, from the first arm to the last, at a quarter of the
    shorter arm's length (no arc for a straight or zero angle)."""
    first, vertex, last = points
    a, b = first - vertex, last - vertex
    radius = 0.25 * min(np.linalg.norm(a), np.linalg.norm(b))
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    theta = math.atan2(np.linalg.norm(np.cross(a, b)), float(np.dot(a, b)))
    if math.sin(theta) < 1e-6:
        return vertex[None, :]
    t = np.linspace(0.0, 1.0, ARC_SEGMENTS + 1)[:, None]
    directions = (np.sin((1.0 - t) * theta) * a + np.sin(t * theta) * b) / math.sin(theta)
    return vertex + radius * directions
