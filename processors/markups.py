"""Markups: point lists, rulers, angles and closed curves (world coordinates, stored in the network
file) drawn over a rendered image, depth-tested against the renderer's depth, and listed with
their lengths and angles as a table: 3D Slicer's Markups, ParaView's Ruler and Protractor.

Conventions (docs/guide/measuring.md, "Markups", shows them with examples):
- ``markups`` is a MarkupsProperty (vgraph.markups: the kinds, their point counts, the names,
  what is refused); edit it as any property (``processor.markups = ...``, or vgraph.edits'
  SetProperty in the GUI, which makes the edit undoable). vgraph.markups_files reads and writes
  CSV, JSON and 3D Slicer's markups JSON.
- ``camera``: link it to the renderer's camera. One that fits the data (fit_to_data) or has
  automatic near and far planes is resolved on the volumes connected to ``volume`` (several
  allowed: connect every volume a MultiVolumeRayCaster draws) as the ray casters resolve it, on
  the union of their boxes (vgraph.gl.raycasting.framed_view), so the markups land on the
  renderer's pixels; without a volume such a camera is refused by name (``<id>.volume``).
- ``depth`` (optional): the renderer's depth outport. Where it is connected and ``depth_test`` is
  on, the parts of the markups behind what the renderer drew are hidden (vgraph.markups_drawing:
  the test and its ``depth_tolerance``) or drawn at ``hidden_opacity`` (0.3 by default, as Slicer
  shows occluded markups faintly; 0 hides them); without it everything is drawn fully on top.
- Drawing: lines ``line_width`` pixels wide, points as discs, an arc in each angle, labels with the
  name and the length (world units, followed by ``units``) or the angle (degrees), all in
  ``color``, composited over the image through a coverage mask (vgraph.gl.coverage, as
  TextOverlay). Markups with ``visible`` false are listed in the table but not drawn.
- ``table``: one row per markup: name, kind, points, length (a ruler's, a closed curve's
  perimeter; world units), angle (degrees), area (a closed curve's; world units squared), NaN where
  a kind has none. ``vgraph run net.json --port markups.table --data markups.csv`` writes it.
"""

from __future__ import annotations

import numpy as np
from PIL import Image as PILImage
from PIL import ImageDraw

from vgraph import (BoolProperty, CameraProperty, ColorProperty, FloatProperty, Inport, IntProperty, MarkupsProperty,
                    OptionProperty, Outport, Processor, StringProperty, VGraphError)
from vgraph.camera import Camera
from vgraph.gl.coverage import CoverageOverlay, overlay_font
from vgraph.gl.raycasting.framed_view import framed_view
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
from vgraph.image import Image
from vgraph.markups import KINDS, Markups as MarkupList
from vgraph.markups_drawing import MarkupView, Style, draw_markups, scene_eye_depth
from vgraph.table import Column, Table
from vgraph.volume import Volume


class Markups(Processor):
    """Rulers, angles, point lists and closed curves over an image, with their measurements."""

    category = "Measuring"
    inports = [Inport("image", Image, "the rendered image the markups are drawn over", optional=True),
               Inport("depth", Image, "the renderer's depth output: markups behind the scene are hidden",
                      optional=True),
               Inport("volume", Volume, "the rendered volumes (every one the renderer draws): resolve a camera "
                                        "that fits the data", optional=True, multiple=True)]
    outports = [Outport("image", Image, on_demand=True, description="the image with the markups drawn over it"),
                Outport("table", Table, description="name, kind, points, length, angle, area per markup")]

    markups = MarkupsProperty(MarkupList(), doc="the markups: name, kind (points, ruler, angle, closed_curve) "
                                                "and world points (x, y, z) of each")
    place_kind = OptionProperty("ruler", choices=list(KINDS), doc="the kind of markup the GUI's Add button "
                                "and the mouse's Place mode start next")
    camera = CameraProperty(DEFAULT_CAMERA, doc="link it to the renderer's camera")
    color = ColorProperty((1.0, 0.85, 0.0, 1.0), doc="colour of lines, points and labels")
    line_width = IntProperty(2, min=1, max=64, doc="line width in pixels")
    point_size = FloatProperty(0.012, min=0.0, max=0.2,
                               doc="point disc diameter as a fraction of the image's shorter side")
    labels = BoolProperty(True, doc="write each markup's name and length or angle beside it")
    font_size = FloatProperty(0.04, min=0.01, max=0.5, doc="label height as a fraction of the image's shorter side")
    units = StringProperty("", doc="written after lengths, e.g. mm")
    depth_test = BoolProperty(True, doc="hide what lies behind the renderer's depth (needs the depth inport)")
    depth_tolerance = FloatProperty(0.5, min=0.0, max=1e15, doc="world units a markup may lie behind the "
                                                                "scene's depth and still show")
    hidden_opacity = FloatProperty(0.3, min=0.0, max=1.0, doc="opacity of the parts behind the scene (0: not drawn)")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._overlay = CoverageOverlay()
        self.summary = ""

    def frame_summary(self) -> str:
        return self.summary

    def process(self, image: Image | None = None, depth: Image | None = None,
                volume: list[Volume] | None = None) -> dict:
        items = self.markups.markups
        self.summary = f"{len(items)} markups" if len(items) != 1 else "1 markup"
        outputs = {"table": measurements(self.markups, f"Markups '{self.id}'")}
        if self.wants("image"):
            if image is None:
                raise VGraphError(f"Markups '{self.id}': its image output is read but nothing is connected to "
                                  f"{self.id}.image: connect the renderer's image")
            outputs["image"] = self._overlay.composite(self.gl, image, self._mask(image.size, depth, volume),
                                                       self.color, self.id)
        return outputs

    def _mask(self, size: tuple[int, int], depth: Image | None, volumes: list[Volume] | None) -> PILImage.Image:
        width, height = size
        view = MarkupView(self._view_camera(size, volumes or []), size)
        if depth is not None and self.depth_test:
            if depth.size != size:
                raise VGraphError(f"Markups '{self.id}': the depth image is {depth.size[0]}x{depth.size[1]} but "
                                  f"the image {width}x{height}: connect the depth output of the same renderer")
            view = MarkupView(view.camera, size, scene_eye_depth(view.camera, depth.to_numpy()), self.depth_tolerance)
        shorter = min(width, height)
        font = overlay_font(max(10, round(self.font_size * shorter))) if self.labels else None
        style = Style(self.line_width, max(1.0, self.point_size * shorter / 2.0), font, self.units,
                      self.hidden_opacity)
        mask = PILImage.new("L", (width, height), 0)
        draw_markups(ImageDraw.Draw(mask), view, [m for m in self.markups.markups if m.visible], style)
        return mask

    def _view_camera(self, size: tuple[int, int], volumes: list[Volume]) -> Camera:
        """The camera the renderer drew with at this size, in world units, near and far set."""
        camera = self.camera
        if volumes:
            camera = framed_view(camera, volumes, size, self.id).world_camera
            if camera is None:
                raise VGraphError(f"{self.id}.camera: the view of this volume cannot be held in world units "
                                  f"(a box near 1e15); markups cannot be placed in it")
            return camera
        if camera.fit_to_data or camera.near is None or camera.far is None:
            raise VGraphError(f"{self.id}.volume: the camera fits the data or has automatic near and far "
                              f"planes, which depend on the volume: connect the rendered volume to "
                              f"{self.id}.volume, or link a camera with near and far set")
        return camera


def measurements(markups: MarkupList, source: str) -> Table:
    """The table of the markups' measurements (module docstring)."""
    items = markups.markups

    def numbers(name: str) -> np.ndarray:
        values = (getattr(m, name) for m in items)
        return np.array([np.nan if v is None else v for v in values], dtype=np.float64)

    return Table((Column("name", np.array([m.name for m in items], dtype=str)),
                  Column("kind", np.array([m.kind for m in items], dtype=str)),
                  Column("points", np.array([len(m.points) for m in items], dtype=np.int64)),
                  Column("length", numbers("length"), "world"),
                  Column("angle", numbers("angle"), "degrees"),
                  Column("area", numbers("area"), "world^2")), source=source)
