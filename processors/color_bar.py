"""ColorBar: a labelled colour scale composited over an image, for pictures people share.

Conventions (docs/guide/outputs.md shows them with commands):
- The colours are the ``transfer_function`` property's (link it to the ray caster's) or, with
  ``colormap`` set to a name, that colour map as the curvature ray casters sample it (the 256-entry
  LUT with linear interpolation).
- The bar's axis is the normalised position ``t`` in [0, 1] that indexes the colours; the labels are
  data values. Without a curvature input ``t`` maps linearly onto the value range: the connected
  volume's ``value_range`` (the range transfer-function positions are normalised over), else the
  ``value_range`` property.
- With the optional ``curvature`` inport connected (a CurvatureRaycaster's ``curvature`` outport,
  with ``measure``, ``normalization`` and ``attenuation`` linked to its ``curvature``,
  ``normalization`` and ``attenuation``), the scale is the ray caster's: kmin and kmax come from the
  same pixels and rule as its GPU reduction (vgraph.gl.curvature.RangeReduction; the zero floor too
  when the volume is connected), and the bar shows the part of the colour map the image uses, with
  zero at 0.5 (shaders/curvature/normalization.glsl). Ticks are evenly spaced along the bar, so
  they are evenly spaced in value only for a linear scale.
- Everything is drawn on the CPU (Pillow for text) into a float RGBA overlay that is composited
  "over" the input (straight alpha); pixels outside the bar, its labels and panel are copied
  unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from PIL import Image as PILImage
from PIL import ImageDraw, ImageFont

from vgraph import (BoolProperty, ColorProperty, FloatProperty, Inport, IntProperty, OptionProperty,
                    Outport, Processor, PropertyError, StringProperty, TransferFunctionProperty,
                    VectorProperty)
from vgraph.gl.curvature import COLORMAPS, CURVATURES, NORMALIZATIONS, colormap_table, measure_uniforms
from vgraph.image import Image
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

CORNERS = ("top_left", "top_right", "bottom_left", "bottom_right")
MEASURE_NAMES = {"k1": "Principal curvature k1", "k2": "Principal curvature k2",
                 "gaussian": "Gaussian curvature", "mean": "Mean curvature",
                 "curvedness": "Curvedness", "shape_index": "Shape index"}
CHECKER = (0.8, 0.55)  # light and dark grey of the opacity checkerboard
GRAYSCALE = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0, 1.0)])


class ColorBar(Processor):
    """Composites a colour bar with tick labels, title and units over an image."""

    category = "Image"
    inports = [Inport("image", Image), Inport("volume", Volume, optional=True),
               Inport("curvature", Image, optional=True)]
    outports = [Outport("image", Image)]

    colormap = OptionProperty("transfer_function", choices=["transfer_function", *COLORMAPS],
                              doc="transfer_function: the transfer_function property's colours; a "
                                  "name: that colour map (link it to a curvature ray caster's)")
    transfer_function = TransferFunctionProperty(GRAYSCALE,
                                                 doc="link it to the ray caster's transfer function")
    value_range = VectorProperty((0.0, 1.0), size=2,
                                 doc="data values at the ends of the bar when no volume or curvature "
                                     "image is connected")
    measure = OptionProperty("gaussian", choices=list(CURVATURES),
                             doc="with a curvature image: link it to the ray caster's curvature")
    normalization = OptionProperty("linear", choices=list(NORMALIZATIONS),
                                   doc="with a curvature image: link it to the ray caster's")
    attenuation = FloatProperty(1.0, min=1e-6, max=1e6,
                                doc="with a curvature image: link it to the ray caster's")
    title = StringProperty("", doc="above the bar; empty: the curvature measure's name, if any")
    units = StringProperty("", doc="shown after the title in parentheses, e.g. 1/mm")
    corner = OptionProperty("top_right", choices=list(CORNERS), doc="where in the image the bar goes")
    orientation = OptionProperty("vertical", choices=["vertical", "horizontal"])
    length = FloatProperty(0.5, min=0.05, max=1.0,
                           doc="bar length as a fraction of the image height (vertical) or width")
    thickness = FloatProperty(0.04, min=0.005, max=0.5,
                              doc="bar thickness as a fraction of the image's shorter side")
    font_size = FloatProperty(0.04, min=0.01, max=0.5,
                              doc="text height as a fraction of the image's shorter side")
    tick_count = IntProperty(5, min=2, max=21, doc="labelled ticks, evenly spaced, ends included")
    text_color = ColorProperty((1.0, 1.0, 1.0, 1.0), doc="colour of labels, title and ticks")
    background = ColorProperty((0.0, 0.0, 0.0, 0.0), doc="a panel behind bar and text")
    show_opacity = BoolProperty(False, doc="the transfer function's opacity over a checkerboard")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.last_layout: Layout | None = None

    def check(self) -> None:
        low, high = self.value_range
        if not low < high:
            raise PropertyError(f"{self.id}.value_range",
                                f"the low end must be below the high end, got {list(self.value_range)}")

    def process(self, image: Image, volume: Volume | None, curvature: Image | None) -> Image:
        self.check()
        if curvature is not None and self.colormap == "transfer_function":
            raise PropertyError(f"{self.id}.colormap", "a curvature image is connected: choose the "
                                "ray caster's colour map (link its colormap to this one)")
        scale = self._scale(volume, curvature)
        colors = self.color_function(volume)
        pixels = image.to_numpy()
        overlay, self.last_layout = draw_overlay(self, pixels.shape[1], pixels.shape[0], scale, colors)
        return Image.from_numpy(self.gl, composite_over(overlay, pixels))

    # --- colours and scale ----------------------------------------------------------------------
    def color_function(self, volume: Volume | None) -> Callable[[np.ndarray], np.ndarray]:
        """RGBA at normalised positions t (the bar's axis): the one place that knows how the
        colours are looked up, so it follows the renderers when they change."""
        if self.colormap != "transfer_function":
            table = colormap_table(self.colormap).astype(np.float64)
            knots = np.linspace(0.0, 1.0, len(table))  # the shader's LUT with linear filtering
            return lambda t: np.stack([np.interp(t, knots, table[:, c]) for c in range(4)], axis=-1)
        return resolved_transfer_function(self.transfer_function, volume, self.value_range,
                                          f"{self.id}.transfer_function")

    def _scale(self, volume: Volume | None, curvature: Image | None) -> "Scale":
        if curvature is not None:
            zero = measure_uniforms(volume)["zero_curvature"] if volume is not None else 0.0
            k = measure_values(curvature.to_numpy(), self.measure, zero)
            return curvature_scale(k, self.measure, self.normalization, self.attenuation)
        low, high = volume.value_range if volume is not None else self.value_range
        return Scale(0.0, 1.0, lambda t: low + t * (high - low))

    def title_text(self, has_curvature: bool) -> str:
        title = self.title or (MEASURE_NAMES[self.measure] if has_curvature else "")
        if self.units:
            return f"{title} ({self.units})" if title else f"({self.units})"
        return title


def resolved_transfer_function(tf: TransferFunction, volume: Volume | None, value_range,
                               where: str) -> TransferFunction:
    """The TF over normalised intensity, as the ray caster evaluates it for this volume: a TF in
    data units is placed on the volume's value range (or the value_range property without a
    volume); one in percentiles needs the volume's values."""
    if volume is not None:
        return tf.for_volume(volume)
    if tf.space != "percentile":  # data units (or a shift in them) land on the value_range property
        return tf.over_range(*value_range)
    raise PropertyError(where, f"its positions are {tf.space} values: connect the volume so the "
                               "colour bar knows them")


# --- scales ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scale:
    """The bar runs from colour position t_low to t_high; ``value(t)`` is the data value there."""
    t_low: float
    t_high: float
    value: Callable[[np.ndarray], np.ndarray]
    is_curvature: bool = False


def measure_values(pixels: np.ndarray, measure: str, zero: float = 0.0) -> np.ndarray:
    """The measure at the pixels where curvature is defined (alpha 1), as measure.glsl computes it
    in float32, with |k| <= ``zero`` (zero**2 for K) read as 0."""
    c = pixels[pixels[..., 3] == 1.0].astype(np.float32)
    k1, k2 = c[:, 0], c[:, 1]
    curvedness = np.sqrt(np.float32(0.5) * (k1 * k1 + k2 * k2))
    if measure == "shape_index":
        shape = np.float32(2 / np.pi) * np.arctan2(k1 + k2, k1 - k2)
        return np.where(curvedness <= zero, np.float32(0.0), shape)
    values = {"k1": k1, "k2": k2, "gaussian": c[:, 2], "mean": np.float32(0.5) * (k1 + k2),
              "curvedness": curvedness}[measure]
    floor = zero * zero if measure == "gaussian" else zero
    return np.where(np.abs(values) <= floor, np.float32(0.0), values)


def curvature_scale(k: np.ndarray, measure: str, normalization: str, attenuation: float) -> Scale:
    """The colour positions the ray caster gives kmin .. kmax and the inverse mapping, following
    shaders/curvature/normalization.glsl (kmin <= 0 <= kmax, as the GPU reduction returns them)."""
    kmin = min(float(k.min()), 0.0) if k.size else 0.0
    kmax = max(float(k.max()), 0.0) if k.size else 0.0
    if measure == "shape_index":
        return Scale((kmin + 1) / 2, (kmax + 1) / 2, lambda t: 2 * t - 1, True)
    if normalization == "exponential":
        a = attenuation
        if measure == "curvedness":
            return Scale(0.0, 1 - math.exp(-kmax * a), lambda t: -np.log1p(-t) / a, True)
        position = (lambda v: 1 - 0.5 * math.exp(-v * a) if v >= 0 else 0.5 * math.exp(v * a))
        inverse = (lambda t: np.where(t >= 0.5, -np.log(2 * np.maximum(1 - t, 1e-300)) / a,
                                      np.log(2 * np.maximum(t, 1e-300)) / a))
        return Scale(position(kmin), position(kmax), inverse, True)
    if measure == "curvedness":
        return Scale(0.0, 1.0 if kmax > 0 else 0.0, lambda t: t * kmax, True)
    return Scale(0.0 if kmin < 0 else 0.5, 1.0 if kmax > 0 else 0.5,
                 lambda t: np.where(t >= 0.5, (2 * t - 1) * kmax, (1 - 2 * t) * kmin), True)


def format_ticks(values) -> list[str]:
    """Labels with one number of decimals for all: three significant digits of the largest, enough
    to tell neighbouring ticks apart, scientific notation outside 1e-3 .. 1e5; never '-0'."""
    values = np.asarray(values, dtype=np.float64)
    largest = float(np.abs(values).max()) if values.size else 0.0
    if largest == 0.0:
        return ["0"] * len(values)
    steps = np.abs(np.diff(values))
    step = float(steps[steps > 0].min()) if np.any(steps > 0) else largest
    if not 1e-3 <= largest < 1e5:
        digits = max(2, math.floor(math.log10(largest)) - math.floor(math.log10(step)) + 1)
        texts = [f"{v:.{min(digits, 6)}e}" for v in values]
    else:
        decimals = max(2 - math.floor(math.log10(largest)), -math.floor(math.log10(step)), 0)
        texts = [f"{v:.{min(decimals, 9)}f}" for v in values]
    return [text.lstrip("-") if float(text) == 0.0 else text for text in texts]


# --- drawing --------------------------------------------------------------------------------------
@dataclass
class Layout:
    """Pixel geometry relative to the bar's top-left corner, then shifted into the corner."""
    bar: tuple[int, int, int, int]          # x, y, width, height
    ticks: list[tuple[float, float, float, float]]  # line end points
    texts: list[tuple[ImageFont.FreeTypeFont, float, float, str, str]]  # font, x, y, anchor, text
    line_width: int
    padding: int


def layout(bar: ColorBar, width: int, height: int, labels: list[str], title: str) -> Layout:
    """Place bar, ticks, labels and title; shrink the bar if the whole does not fit the image."""
    short = min(width, height)
    vertical = bar.orientation == "vertical"
    length = round(bar.length * (height if vertical else width))
    for _ in range(2):
        parts = _parts(bar, width, short, max(2, length), labels, title)
        x0, y0, x1, y1 = _extent(parts)
        room = (height if vertical else width) - 2 * (_margin(short) + parts.padding)
        excess = (y1 - y0 if vertical else x1 - x0) - room
        if excess <= 0:
            break
        length -= math.ceil(excess)
    inset = _margin(short) + parts.padding
    dx = width - inset - x1 if bar.corner.endswith("right") else inset - x0
    dy = inset - y0 if bar.corner.startswith("top") else height - inset - y1
    return _shifted(parts, round(dx), round(dy))


def _margin(short: int) -> int:
    return max(2, round(0.03 * short))


def _fitting_font(text: str, size: int, room: float) -> ImageFont.FreeTypeFont:
    """The default font at ``size`` pixels, smaller (down to 8) while ``text`` is wider than ``room``."""
    font = ImageFont.load_default(size=size)
    while size > 8 and font.getlength(text) > room:
        size -= 1
        font = ImageFont.load_default(size=size)
    return font


def _parts(bar: ColorBar, width: int, short: int, length: int, labels: list[str], title: str) -> Layout:
    font_px = max(10, round(bar.font_size * short))  # smaller is unreadable
    font = ImageFont.load_default(size=font_px)
    thick = max(2, round(bar.thickness * short))
    tick, gap = max(2, font_px // 3), max(2, font_px // 4)
    n = len(labels)
    ticks, texts = [], []
    title_font = _fitting_font(title, font_px, width - 2 * (_margin(short) + gap))
    if bar.orientation == "vertical":
        size = (thick, length)
        for i, label in enumerate(labels):  # low values at the bottom
            y = (length - 1) * (1 - i / (n - 1)) + 0.5
            ticks.append((thick, y, thick + tick, y))
            texts.append((font, thick + tick + gap, y, "lm", label))
        label_right = thick + tick + gap + max(font.getlength(t) for t in labels)
        if title:
            right = bar.corner.endswith("right")
            texts.append((title_font, label_right if right else 0, -gap, "rd" if right else "ld", title))
    else:
        size = (length, thick)
        for i, label in enumerate(labels):
            x = (length - 1) * i / (n - 1) + 0.5
            ticks.append((x, thick, x, thick + tick))
            texts.append((font, x, thick + tick + gap, "mt", label))
        if title:
            texts.append((title_font, length / 2, -gap, "md", title))
    return Layout((0, 0, *size), ticks, texts, max(1, font_px // 12), gap)


def _extent(parts: Layout) -> tuple[float, float, float, float]:
    x, y, w, h = parts.bar
    boxes = [(x, y, x + w, y + h)] + [(a, b, c + 1, d + 1) for a, b, c, d in parts.ticks]
    for font, tx, ty, anchor, text in parts.texts:
        left, top, right, bottom = font.getbbox(text, anchor=anchor)
        boxes.append((tx + left, ty + top, tx + right, ty + bottom))
    return (min(b[0] for b in boxes), min(b[1] for b in boxes),
            max(b[2] for b in boxes), max(b[3] for b in boxes))


def _shifted(parts: Layout, dx: int, dy: int) -> Layout:
    x, y, w, h = parts.bar
    return Layout((x + dx, y + dy, w, h), [(a + dx, b + dy, c + dx, d + dy) for a, b, c, d in parts.ticks],
                  [(font, tx + dx, ty + dy, anchor, text) for font, tx, ty, anchor, text in parts.texts],
                  parts.line_width, parts.padding)


def draw_overlay(bar: ColorBar, width: int, height: int, scale: Scale, colors) -> tuple[np.ndarray, Layout]:
    """Float RGBA (height, width, 4), row 0 at the top: panel, bar, ticks and text; alpha 0
    elsewhere. Also the layout (where the bar and each text went: tests and tools read it)."""
    ticks_t = scale.t_low + np.linspace(0.0, 1.0, bar.tick_count) * (scale.t_high - scale.t_low)
    labels = format_ticks(scale.value(ticks_t))
    parts = layout(bar, width, height, labels, bar.title_text(scale.is_curvature))
    overlay = np.zeros((height, width, 4), dtype=np.float32)
    if bar.background[3] > 0:
        x0, y0, x1, y1 = (round(v) for v in _extent(parts))
        pad = parts.padding
        overlay[max(0, y0 - pad):max(0, y1 + pad), max(0, x0 - pad):max(0, x1 + pad)] = bar.background
    _paint_bar(overlay, bar, parts.bar, scale, colors)
    mask = PILImage.new("L", (width, height), 0)
    draw = ImageDraw.Draw(mask)
    for line in parts.ticks:
        draw.line(line, fill=255, width=parts.line_width)
    for font, x, y, anchor, text in parts.texts:
        draw.text((x, y), text, fill=255, font=font, anchor=anchor)
    text = np.zeros_like(overlay)
    text[..., :3] = bar.text_color[:3]
    text[..., 3] = bar.text_color[3] * np.asarray(mask, dtype=np.float32) / 255.0
    return composite_over(text, overlay), parts


def _paint_bar(overlay: np.ndarray, bar: ColorBar, rect, scale: Scale, colors) -> None:
    """The bar's colours, one per row (vertical, low at the bottom) or column; both ends exact."""
    x, y, w, h = rect
    vertical = bar.orientation == "vertical"
    steps = h if vertical else w
    s = np.linspace(0.0, 1.0, steps)[::-1] if vertical else np.linspace(0.0, 1.0, steps)
    rgba = colors(scale.t_low + s * (scale.t_high - scale.t_low))
    block = np.broadcast_to(rgba[:, None, :] if vertical else rgba[None, :, :], (h, w, 4)).copy()
    if bar.show_opacity and bar.colormap == "transfer_function":
        cell = max(2, w // 2 if vertical else h // 2)
        rows, cols = np.indices((h, w)) // cell
        checker = np.where((rows + cols) % 2 == 0, CHECKER[0], CHECKER[1])[..., None]
        block[..., :3] = block[..., 3:] * block[..., :3] + (1 - block[..., 3:]) * checker
    block[..., 3] = 1.0
    top, left = max(0, y), max(0, x)  # a bar partly outside a tiny image is clipped
    bottom, right = min(overlay.shape[0], y + h), min(overlay.shape[1], x + w)
    if bottom > top and right > left:
        overlay[top:bottom, left:right] = block[top - y:bottom - y, left - x:right - x]


def composite_over(front: np.ndarray, back: np.ndarray) -> np.ndarray:
    """Porter-Duff "over" of straight-alpha float RGBA images; pixels where ``front`` has alpha 0
    are ``back``'s, bit for bit."""
    result = back.copy()
    covered = front[..., 3] > 0
    f, b = front[covered].astype(np.float64), back[covered].astype(np.float64)
    alpha = f[:, 3:] + b[:, 3:] * (1 - f[:, 3:])
    rgb = (f[:, :3] * f[:, 3:] + b[:, :3] * b[:, 3:] * (1 - f[:, 3:])) / np.maximum(alpha, 1e-12)
    result[covered] = np.concatenate([rgb, alpha], axis=1)
    return result
