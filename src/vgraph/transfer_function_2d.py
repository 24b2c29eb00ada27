"""2D transfer functions over (value, gradient magnitude), built from primitives (Kniss, Kindlmann
& Hansen 2002; Voreen's TransFunc2D primitives).

JSON form::

    {"primitives": [
        {"kind": "rectangle", "value": [0.3, 0.5], "gradient": [0.0, 0.4], "color": [r, g, b, a]},
        {"kind": "triangle", "vertices": [[0.5, 0.0], [0.3, 1.0], [0.7, 1.0]], "color": [r, g, b, a]},
        {"kind": "gaussian", "centre": [0.6, 0.3], "width": [0.05, 0.1], "color": [r, g, b, a]}]}

The plane's axes: ``value``, a normalised intensity in [0, 1] over the volume's value range (as a
normalised 1D TF), and ``gradient``, the gradient fraction in [0, 1] (the gradient magnitude over
the volume's largest, vgraph.gradient_opacity). Colours are RGBA in [0, 1], alpha the opacity of one
sample at sampling rate 1, as in a 1D TF.

- rectangle: ``color`` on the closed box value x gradient;
- triangle: ``color`` on the closed triangle (Kniss's boundary widget: apex at gradient 0, the
  material's value, opening towards high gradients);
- gaussian: ``color`` with alpha ``a * exp(-d^2 / 2)``, ``d^2 = ((v - cv) / wv)^2 + ((g - cg) / wg)^2``
  (d: the distance from the centre in widths), cut to 0 beyond ``d = 3`` (GAUSSIAN_REACH).

Where primitives overlap they combine as independent absorbers, in any order: alpha
``1 - prod(1 - a_i)``, colour the alpha-weighted mean of their colours. Renderers use ``lut()``:
the function at a grid of LUT_SIZE x LUT_SIZE points (entry [j, i] at gradient j / (LUT_SIZE - 1),
value i / (LUT_SIZE - 1)), premultiplied by alpha, looked up bilinearly and divided by the alpha
read (vgraph.numerics.reference_classification).
A 2D-TF property also accepts a preset's name (``PRESETS``).
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

LUT_SIZE = 256  # per axis, as Voreen's TransFunc2D texture
# A Gaussian is cut to 0 beyond this many widths (1.1 % of its peak there): elsewhere the plane
# stays empty, so empty-space skipping keeps its blocks and nearly flat regions their colour.
GAUSSIAN_REACH = 3.0
MIN_WIDTH = 1e-3  # the narrowest Gaussian an editor's handle makes (the table's step is 1 / 255)

Unit = Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)]
Color = tuple[Unit, Unit, Unit, Unit]
Pair = tuple[Unit, Unit]


class _Primitive(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    color: Color

    def alpha(self, value: np.ndarray, gradient: np.ndarray) -> np.ndarray:
        """The primitive's alpha at the grid points (its colour is constant)."""
        raise NotImplementedError

    def corners(self) -> list[tuple[float, float]]:
        """The (value, gradient) points that place the primitive (what a move shifts)."""
        raise NotImplementedError

    def covers(self, value: float, gradient: float) -> bool:
        """Whether a point lies on the primitive (an editor picks it there), whatever its alpha."""
        raise NotImplementedError

    def moved(self, d_value: float, d_gradient: float) -> "_Primitive":
        """A copy shifted by (d_value, d_gradient), the shift cut so every corner stays in [0, 1]."""
        corners = np.asarray(self.corners())
        d_value = float(np.clip(d_value, -corners[:, 0].min(), 1.0 - corners[:, 0].max()))
        d_gradient = float(np.clip(d_gradient, -corners[:, 1].min(), 1.0 - corners[:, 1].max()))
        return self._shifted(d_value, d_gradient)

    def _shifted(self, d_value: float, d_gradient: float) -> "_Primitive":
        raise NotImplementedError

    def handles(self) -> list[tuple[float, float]]:
        """The points an editor drags to reshape the primitive (its corners by default)."""
        return self.corners()

    def with_handle(self, index: int, value: float, gradient: float) -> "_Primitive":
        """A copy with handle ``index`` at (value, gradient), clamped to the plane; the primitive
        itself where that would make it invalid (a triangle on one line)."""
        value, gradient = min(max(float(value), 0.0), 1.0), min(max(float(gradient), 0.0), 1.0)
        try:
            return self._reshaped(index, value, gradient)
        except ValueError:  # pydantic's ValidationError is one
            return self

    def _reshaped(self, index: int, value: float, gradient: float) -> "_Primitive":
        raise NotImplementedError

    def with_color(self, color) -> "_Primitive":
        return self.model_copy(update={"color": tuple(float(c) for c in color)})


class Rectangle(_Primitive):
    kind: Literal["rectangle"] = "rectangle"
    value: Pair
    gradient: Pair

    @model_validator(mode="after")
    def _ordered(self) -> "Rectangle":
        for name in ("value", "gradient"):
            low, high = getattr(self, name)
            if low > high:
                raise ValueError(f"rectangle {name} range must be [low, high] with low <= high, got [{low}, {high}]")
        return self

    def alpha(self, value, gradient):
        inside = ((self.value[0] <= value) & (value <= self.value[1])
                  & (self.gradient[0] <= gradient) & (gradient <= self.gradient[1]))
        return np.where(inside, self.color[3], 0.0)

    def corners(self):
        return [(self.value[0], self.gradient[0]), (self.value[1], self.gradient[1])]

    def covers(self, value, gradient):
        return bool(self.value[0] <= value <= self.value[1] and self.gradient[0] <= gradient <= self.gradient[1])

    def _shifted(self, d_value, d_gradient):
        return self.model_copy(update={"value": _plus(self.value, d_value), "gradient": _plus(self.gradient, d_gradient)})

    def _reshaped(self, index, value, gradient):
        (v0, v1), (g0, g1) = self.value, self.gradient
        if index == 0:  # the low corner stays at or below the high one
            return Rectangle(value=(min(value, v1), v1), gradient=(min(gradient, g1), g1), color=self.color)
        return Rectangle(value=(v0, max(value, v0)), gradient=(g0, max(gradient, g0)), color=self.color)


def _plus(pair, delta):
    return tuple(min(max(v + delta, 0.0), 1.0) for v in pair)


class Triangle(_Primitive):
    kind: Literal["triangle"] = "triangle"
    vertices: tuple[Pair, Pair, Pair]

    @model_validator(mode="after")
    def _not_degenerate(self) -> "Triangle":
        if abs(_twice_area(*self.vertices)) < 1e-9:
            raise ValueError(f"triangle vertices {[list(v) for v in self.vertices]} lie on one line")
        return self

    def alpha(self, value, gradient):
        a, b, c = self.vertices
        area = _twice_area(a, b, c)
        # Barycentric weights with the triangle's orientation; inside where all are >= 0.
        slack = -1e-12 * abs(area)
        inside = np.ones(np.broadcast(value, gradient).shape, dtype=bool)
        for p, q in ((a, b), (b, c), (c, a)):
            edge = (q[0] - p[0]) * (gradient - p[1]) - (q[1] - p[1]) * (value - p[0])
            inside &= edge * np.sign(area) >= slack
        return np.where(inside, self.color[3], 0.0)

    def corners(self):
        return list(self.vertices)

    def covers(self, value, gradient):
        return bool(Triangle.alpha(self.with_color((0, 0, 0, 1)), np.array(value), np.array(gradient)) > 0.0)

    def _reshaped(self, index, value, gradient):
        vertices = list(self.vertices)
        vertices[index] = (value, gradient)
        return Triangle(vertices=tuple(vertices), color=self.color)

    def _shifted(self, d_value, d_gradient):
        return self.model_copy(update={"vertices": tuple((min(max(v + d_value, 0.0), 1.0),
                                                          min(max(g + d_gradient, 0.0), 1.0))
                                                         for v, g in self.vertices)})


class Gaussian(_Primitive):
    kind: Literal["gaussian"] = "gaussian"
    centre: Pair
    width: tuple[Annotated[float, Field(gt=0.0, le=1.0)], Annotated[float, Field(gt=0.0, le=1.0)]]

    def alpha(self, value, gradient):
        (cv, cg), (wv, wg) = self.centre, self.width
        distance = ((value - cv) / wv) ** 2 + ((gradient - cg) / wg) ** 2  # squared, in widths
        return np.where(distance <= GAUSSIAN_REACH ** 2, self.color[3] * np.exp(-0.5 * distance), 0.0)

    def corners(self):
        return [self.centre]

    def covers(self, value, gradient):  # within one width: the ellipse an editor draws
        (cv, cg), (wv, wg) = self.centre, self.width
        return ((value - cv) / wv) ** 2 + ((gradient - cg) / wg) ** 2 <= 1.0

    def handles(self):  # the centre, and a corner of its box of one width (what sets the widths)
        (cv, cg), (wv, wg) = self.centre, self.width
        return [self.centre, (cv + wv, cg + wg)]

    def _reshaped(self, index, value, gradient):
        if index == 0:
            return self.model_copy(update={"centre": (value, gradient)})
        (cv, cg) = self.centre
        return Gaussian(centre=self.centre, width=(min(max(abs(value - cv), MIN_WIDTH), 1.0),
                                                   min(max(abs(gradient - cg), MIN_WIDTH), 1.0)), color=self.color)

    def _shifted(self, d_value, d_gradient):
        return self.model_copy(update={"centre": (min(max(self.centre[0] + d_value, 0.0), 1.0),
                                                  min(max(self.centre[1] + d_gradient, 0.0), 1.0))})


def _twice_area(a, b, c) -> float:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


Primitive = Annotated[Union[Rectangle, Triangle, Gaussian], Field(discriminator="kind")]


class TransferFunction2D(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    primitives: list[Primitive] = Field(min_length=1)

    def __call__(self, value, gradient) -> np.ndarray:
        """Exact RGBA at (value, gradient fraction) points (broadcast shapes) -> shape + (4,)."""
        value = np.clip(np.asarray(value, dtype=np.float64), 0.0, 1.0)
        gradient = np.clip(np.asarray(gradient, dtype=np.float64), 0.0, 1.0)
        shape = np.broadcast(value, gradient).shape
        transparency = np.ones(shape)
        weighted = np.zeros(shape + (3,))
        total = np.zeros(shape)
        for primitive in self.primitives:
            alpha = primitive.alpha(value, gradient)
            transparency *= 1.0 - alpha
            weighted += alpha[..., None] * np.asarray(primitive.color[:3])
            total += alpha
        rgb = np.divide(weighted, total[..., None], out=np.zeros_like(weighted), where=total[..., None] > 0.0)
        return np.concatenate([rgb, (1.0 - transparency)[..., None]], axis=-1)

    def lut(self, size: int = LUT_SIZE) -> np.ndarray:
        """(size, size, 4) float32 premultiplied RGBA (a r, a g, a b, a), [gradient, value]: entry
        [j, i] at gradient j / (size - 1), value i / (size - 1). Premultiplied, so that reading
        between an entry inside a primitive and one outside it (colour 0) keeps the primitive's
        colour instead of darkening it; readers divide rgb by a."""
        axis = np.linspace(0.0, 1.0, size)
        rgba = self(axis[None, :], axis[:, None])
        rgba[..., :3] *= rgba[..., 3:]
        return rgba.astype(np.float32)


def new_primitive(kind: str, value: float, gradient: float, color=(1.0, 1.0, 1.0, 0.5)):
    """A primitive of ``kind`` about one fifth of the plane wide, centred near (value, gradient)
    (moved inside the plane): what an editor's Add puts down."""
    half = 0.1
    shapes = {"rectangle": lambda: Rectangle(value=(0.5 - half, 0.5 + half), gradient=(0.5 - half, 0.5 + half), color=color),
              "triangle": lambda: Triangle(vertices=((0.5, 0.5 - half), (0.5 - half, 0.5 + half), (0.5 + half, 0.5 + half)),
                                           color=color),
              "gaussian": lambda: Gaussian(centre=(0.5, 0.5), width=(half / 2, half / 2), color=color)}
    if kind not in shapes:
        raise ValueError(f"a 2D TF primitive is one of {', '.join(shapes)}, not {kind!r}")
    return shapes[kind]().moved(value - 0.5, gradient - 0.5)


_WHITE_BONE = (1.0, 0.95, 0.85, 0.8)

PRESETS: dict[str, TransferFunction2D] = {
    # Boundaries of any material: a soft band over all values at high gradient fractions.
    "boundaries": TransferFunction2D(primitives=[
        Rectangle(value=(0.05, 1.0), gradient=(0.2, 1.0), color=(0.9, 0.85, 0.75, 0.25)),
        Gaussian(centre=(0.5, 0.6), width=(0.3, 0.2), color=(1.0, 0.7, 0.4, 0.3))]),
    # Kniss's arches: the boundary between background and a medium material, and between that and
    # a dense one, each a triangle standing on its value at gradient 0.
    "two-materials": TransferFunction2D(primitives=[
        Triangle(vertices=((0.35, 0.0), (0.2, 1.0), (0.5, 1.0)), color=(0.85, 0.45, 0.3, 0.12)),
        Triangle(vertices=((0.75, 0.0), (0.55, 1.0), (0.95, 1.0)), color=_WHITE_BONE)]),
}


def preset(value):
    """A preset's model for its name; any other value unchanged (for the property's validation)."""
    if isinstance(value, str):
        if value not in PRESETS:
            raise ValueError(f"{value!r} is not a 2D transfer-function preset ({', '.join(PRESETS)})")
        return PRESETS[value]
    return value
