"""TextOverlay: a caption and a scale bar in world units, drawn over an image.

Conventions:
- Text and bar are rasterised on the CPU by Pillow into a coverage mask (its bundled default
  font, ``ImageFont.load_default(size)``, as ColorBar's labels: nothing is read or downloaded at
  run time), then one GL pass (shaders/image/coverage_over.frag.glsl) composites ``text_color``
  with that coverage "over" the image (premultiplied, as ImageCompositor). Pixels the mask does not
  touch are the input's, bit for bit.
- Sizes follow the image: the text is ``font_size`` times the image's shorter side high, at a
  margin of 3 % of it from the corner; several lines are separated by "\\n".
- The scale bar is ``scale_bar_length`` world units long (0: the 1, 2 or 5 times a power of ten
  nearest below a quarter of the image's width), ``length * height / (2 parallel_scale)`` pixels
  of the camera's view, rounded to whole pixels, labelled "<length> <units>" above it. The camera
  is the ``camera`` property (link it to the ray caster's); one that fits the data (fit_to_data,
  the default) is resolved on the connected ``volume`` as the ray casters resolve it
  (vgraph.gl.raycasting.framed_view). Only an orthographic view has one scale everywhere: under
  perspective a world length spans fewer pixels the farther it lies, so a scale bar there is
  refused by name (``<id>.camera``), never drawn wrong.
- ``last_layout`` holds where the caption and bar went (pixels, row 0 at the top), for tests and tools.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from PIL import Image as PILImage
from PIL import ImageDraw, ImageFont

from vgraph import (BoolProperty, CameraProperty, ColorProperty, FloatProperty, Inport, OptionProperty, Outport,
                    Processor, PropertyError, StringProperty, VGraphError)
from vgraph.camera import Camera
from vgraph.gl.coverage import CoverageOverlay, overlay_font
from vgraph.gl.raycasting.framed_view import framed_view
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
from vgraph.image import Image
from vgraph.volume import Volume

POSITIONS = ("top_left", "top_center", "top_right", "bottom_left", "bottom_center", "bottom_right")
CORNERS = ("top_left", "top_right", "bottom_left", "bottom_right")
# Pillow anchors: horizontal l/m/r, vertical a (ascender, the top) or d (descender, the bottom);
# the two multi-line text accepts.
_ANCHOR_X = {"left": "l", "center": "m", "right": "r"}


@dataclass(frozen=True)
class TextLayout:
    """Where the last frame drew (pixels, row 0 at the top; boxes as left, top, right, bottom, exclusive)."""
    caption: tuple[int, int, int, int] | None
    bar: tuple[int, int, int, int] | None   # the bar itself, without its label
    bar_world_length: float | None
    bar_label: str | None


class TextOverlay(Processor):
    """A caption and a scale bar in world units (orthographic views) drawn over an image."""

    category = "Image"
    inports = [Inport("image", Image),
               Inport("volume", Volume, "the rendered volume: resolves a camera that fits the data "
                                        "(fit_to_data) for the scale bar", optional=True)]
    outports = [Outport("image", Image)]
    text = StringProperty("", doc="the caption; \\n starts a new line; empty: none")
    caption_position = OptionProperty("top_left", choices=list(POSITIONS), doc="where the caption goes")
    font_size = FloatProperty(0.05, min=0.01, max=0.5, doc="text height as a fraction of the image's shorter side")
    text_color = ColorProperty((1.0, 1.0, 1.0, 1.0), doc="colour of caption, scale bar and its label")
    scale_bar = BoolProperty(False, doc="draw a scale bar (needs an orthographic camera)")
    scale_bar_length = FloatProperty(0.0, min=0.0, max=1e15,
                                     doc="the bar's length in world units; 0: 1, 2 or 5 x 10^k near a quarter "
                                         "of the image's width")
    units = StringProperty("", doc="written after the bar's length, e.g. mm")
    scale_bar_position = OptionProperty("bottom_right", choices=list(CORNERS), doc="where the scale bar goes")
    camera = CameraProperty(DEFAULT_CAMERA, doc="link it to the ray caster's camera (the scale bar's scale)")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._overlay = CoverageOverlay()  # the mask's texture and the result's target (vgraph.gl.coverage)
        self.last_layout: TextLayout | None = None

    def process(self, image: Image, volume: Volume | None = None) -> Image:
        width, height = image.size
        mask = PILImage.new("L", (width, height), 0)
        draw = ImageDraw.Draw(mask)
        caption = self._draw_caption(draw, width, height) if self.text else None
        bar = self._draw_scale_bar(draw, width, height, volume) if self.scale_bar else (None, None, None)
        self.last_layout = TextLayout(caption, *bar)
        return self._overlay.composite(self.gl, image, mask, self.text_color, self.id)

    # --- caption --------------------------------------------------------------------------------
    def _font(self, height_px: int) -> ImageFont.FreeTypeFont:
        return overlay_font(height_px)

    def _font_px(self, width: int, height: int) -> int:
        return max(10, round(self.font_size * min(width, height)))  # smaller is unreadable

    def _draw_caption(self, draw: ImageDraw.ImageDraw, width: int, height: int) -> tuple[int, int, int, int]:
        vertical, horizontal = self.caption_position.split("_")
        margin = _margin(width, height)
        x = {"left": margin, "center": width / 2, "right": width - margin}[horizontal]
        y = margin if vertical == "top" else height - margin
        anchor = _ANCHOR_X[horizontal] + ("a" if vertical == "top" else "d")
        font = self._font(self._font_px(width, height))
        align = {"left": "left", "center": "center", "right": "right"}[horizontal]
        draw.multiline_text((x, y), self.text, fill=255, font=font, anchor=anchor, align=align)
        return _box(draw.multiline_textbbox((x, y), self.text, font=font, anchor=anchor, align=align))

    # --- scale bar ------------------------------------------------------------------------------
    def _draw_scale_bar(self, draw, width: int, height: int, volume: Volume | None):
        world_per_pixel = 2.0 * self._view_camera(width, height, volume).parallel_scale / height
        length = self.scale_bar_length or nice_length(0.25 * width * world_per_pixel)
        pixels = round(length / world_per_pixel)
        margin = _margin(width, height)
        if pixels < 1 or pixels > width - 2 * margin:
            raise PropertyError(f"{self.id}.scale_bar_length",
                                f"a bar of {length:g} world units is {length / world_per_pixel:.3g} pixels long "
                                f"at this view ({world_per_pixel:.4g} world units per pixel); it must lie "
                                f"between 1 and {width - 2 * margin} pixels")
        font_px = self._font_px(width, height)
        thickness = max(2, round(font_px / 4))
        top = margin if self.scale_bar_position.startswith("top") else height - margin - thickness
        left = margin if self.scale_bar_position.endswith("left") else width - margin - pixels
        bar = (left, top, left + pixels, top + thickness)
        draw.rectangle((bar[0], bar[1], bar[2] - 1, bar[3] - 1), fill=255)  # Pillow's corners are inclusive
        label = f"{length:g} {self.units}".strip()
        font = self._font(font_px)
        if self.scale_bar_position.startswith("top"):
            draw.text((left + pixels / 2, bar[3] + thickness), label, fill=255, font=font, anchor="ma")
        else:
            draw.text((left + pixels / 2, top - thickness), label, fill=255, font=font, anchor="md")
        return bar, float(length), label

    def _view_camera(self, width: int, height: int, volume: Volume | None) -> Camera:
        """The camera the ray casters draw with at this size, in world units."""
        camera = self.camera
        if camera.fit_to_data:
            if volume is None:
                raise VGraphError(f"{self.id}.camera: it fits the data (fit_to_data), so its scale depends on "
                                  f"the volume: connect the rendered volume to {self.id}.volume, or link a "
                                  f"stored camera")
            camera = framed_view(camera, (volume,), (width, height), self.id).world_camera
            if camera is None:
                raise VGraphError(f"{self.id}.camera: the view of this volume cannot be held in world units "
                                  f"(a box near 1e15); no scale bar can be drawn")
        if camera.projection != "orthographic":
            raise PropertyError(f"{self.id}.camera", "a scale bar in world units is exact only for an orthographic "
                                                     "camera: under perspective a length spans fewer pixels the "
                                                     "farther it lies; set the camera's projection to orthographic "
                                                     "or turn scale_bar off")
        return camera


def nice_length(at_most: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``at_most`` (> 0)."""
    power = 10.0 ** math.floor(math.log10(at_most))
    return max(step * power for step in (1.0, 2.0, 5.0) if step * power <= at_most * (1 + 1e-12))


def _margin(width: int, height: int) -> int:
    return max(2, round(0.03 * min(width, height)))


def _box(bbox) -> tuple[int, int, int, int]:
    left, top, right, bottom = bbox
    return (math.floor(left), math.floor(top), math.ceil(right), math.ceil(bottom))
