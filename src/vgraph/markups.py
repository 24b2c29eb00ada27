"""Markups: named point lists, rulers, angles and closed curves in world coordinates (issue 36),
the value of a ``MarkupsProperty`` (vgraph.properties), stored in the network file.

Conventions (docs/guide/measuring.md, "Markups", shows them with examples):
- Coordinates are world points (x, y, z) of the patient frame, the frame of the volumes' affines
  (RAS, as every volume vgraph reads: docs/explanations/conventions.md); lengths are in its world
  units (mm for medical data), angles in degrees.
- Kinds and their points: ``points`` (a point list, 1 or more), ``ruler`` (exactly 2), ``angle``
  (exactly 3; the angle is at the middle point, between the rays to the first and the last),
  ``closed_curve`` (3 or more points in one plane, as drawn in a slice: the polygon through them
  closes back to the first). Anything else is refused with the markup's index and reason.
- Measurements by the model (``Markup.length``, ``.angle``, ``.area``): a ruler's length is the
  distance between its points, a closed curve's the perimeter of its polygon and its area that
  of the polygon (Newell's normal, exact for a planar polygon); an angle's ``angle`` is in
  [0, 180] degrees. A ruler of zero length is allowed (length 0); an angle with a zero-length arm
  has no angle, and is refused.
- Names: 1 to 200 printable characters, unique within the markups (the table and the exports
  address markups by name).
- A value is immutable (frozen pydantic models): an edit makes a new ``Markups`` (``with_markup``,
  ``without``), so edits go through vgraph.edits like every property value and can be undone.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, model_validator

MAX_COORDINATE = 1e15  # as vgraph.camera: float32 GL matrices overflow beyond
MAX_NAME = 200
MAX_POINTS = 100_000  # per markup: a curve drawn by hand has hundreds; more is not a markup
KINDS = ("points", "ruler", "angle", "closed_curve")
POINT_COUNTS = {"points": (1, MAX_POINTS), "ruler": (2, 2), "angle": (3, 3), "closed_curve": (3, MAX_POINTS)}
PLANAR_TOLERANCE = 1e-6  # of the curve's size: farther from its plane is not "in a slice"


def _not_bool(value):
    if isinstance(value, bool):
        raise ValueError("expected a number, not a boolean")
    return value


def _check_name(name: str) -> str:
    if not name.strip():
        raise ValueError("a markup's name must not be empty")
    if not name.isprintable():
        raise ValueError("a markup's name must hold printable characters only (no control characters or line breaks)")
    return name


Coordinate = Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE, allow_inf_nan=False),
                       BeforeValidator(_not_bool)]
Point = tuple[Coordinate, Coordinate, Coordinate]
Name = Annotated[str, Field(min_length=1, max_length=MAX_NAME), AfterValidator(_check_name)]


class Markup(BaseModel):
    """One markup: a name, a kind and its world points."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    name: Name
    kind: Literal["points", "ruler", "angle", "closed_curve"]
    points: tuple[Point, ...] = Field(max_length=MAX_POINTS)
    visible: bool = True

    @model_validator(mode="after")
    def _check_points(self) -> "Markup":
        low, high = POINT_COUNTS[self.kind]
        count = len(self.points)
        if not low <= count <= high:
            wanted = f"exactly {low}" if low == high else f"at least {low}"
            article = "an" if self.kind == "angle" else "a"
            raise ValueError(f"{article} {self.kind.replace('_', ' ')} has {wanted} points, got {count}")
        if self.kind == "angle":
            vertex = np.asarray(self.points[1])
            for end in (0, 2):
                if np.array_equal(np.asarray(self.points[end]), vertex):
                    raise ValueError(f"an angle's arm has zero length: point {end} equals the vertex "
                                     f"(point 1) {list(self.points[1])}")
        if self.kind == "closed_curve":
            _check_planar(np.asarray(self.points, dtype=np.float64))
        return self

    @property
    def array(self) -> np.ndarray:
        """The points as an (n, 3) float64 array."""
        return np.asarray(self.points, dtype=np.float64).reshape(-1, 3)

    @property
    def length(self) -> float | None:
        """World units: a ruler's length, a closed curve's perimeter; None for other kinds."""
        if self.kind == "ruler":
            return float(np.linalg.norm(self.array[1] - self.array[0]))
        if self.kind == "closed_curve":
            points = self.array
            return float(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum())
        return None

    @property
    def angle(self) -> float | None:
        """Degrees in [0, 180] at the middle point of an angle; None for other kinds."""
        if self.kind != "angle":
            return None
        first, vertex, last = self.array
        return angle_between(first - vertex, last - vertex)

    @property
    def area(self) -> float | None:
        """World units squared: the area a closed curve encloses; None for other kinds."""
        if self.kind != "closed_curve":
            return None
        return float(np.linalg.norm(_newell_normal(self.array)) / 2.0)


class Markups(BaseModel):
    """The markups of one MarkupsProperty, in order; names unique."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    markups: tuple[Markup, ...] = ()

    @model_validator(mode="after")
    def _unique_names(self) -> "Markups":
        seen = set()
        for markup in self.markups:
            if markup.name in seen:
                raise ValueError(f"two markups are named {markup.name!r}: names must be unique")
            seen.add(markup.name)
        return self

    def __getitem__(self, name: str) -> Markup:
        for markup in self.markups:
            if markup.name == name:
                return markup
        raise KeyError(f"no markup named {name!r} (there are: {', '.join(self.names) or 'none'})")

    def __len__(self) -> int:
        return len(self.markups)

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.markups]

    def with_markup(self, markup: Markup) -> "Markups":
        """These markups with ``markup`` added, or replacing the one of its name in its place."""
        if markup.name in self.names:
            return Markups(markups=tuple(markup if m.name == markup.name else m for m in self.markups))
        return Markups(markups=(*self.markups, markup))

    def without(self, name: str) -> "Markups":
        self[name]  # KeyError naming the markups there are
        return Markups(markups=tuple(m for m in self.markups if m.name != name))


def free_name(markups: Markups, kind: str) -> str:
    """The first name "<kind> <n>" (n = 1, 2, ...; "closed curve 1") not taken in ``markups``."""
    taken, stem = set(markups.names), kind.replace("_", " ")
    return next(f"{stem} {n}" for n in range(1, len(taken) + 2) if f"{stem} {n}" not in taken)


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between two vectors in degrees, by atan2 of |a x b| and a . b (accurate near 0
    and 180 degrees, where acos of the cosine loses half the digits)."""
    return math.degrees(math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b))))


def _newell_normal(points: np.ndarray) -> np.ndarray:
    """Twice the polygon's vector area (Newell's method): its normal times twice its area."""
    following = np.roll(points, -1, axis=0)
    centred, following = points - points[0], following - points[0]  # fewer digits lost far from 0
    return np.cross(centred, following).sum(axis=0)


def _check_planar(points: np.ndarray) -> None:
    normal = _newell_normal(points)
    size = float(np.ptp(points, axis=0).max())
    if np.linalg.norm(normal) <= 1e-12 * max(size, 1e-300) ** 2:
        raise ValueError("a closed curve's points all lie on one line: it encloses nothing")
    distances = np.abs((points - points.mean(axis=0)) @ (normal / np.linalg.norm(normal)))
    if distances.max() > PLANAR_TOLERANCE * size:
        raise ValueError(f"a closed curve lies in one plane (a slice); its points lie up to "
                         f"{distances.max():.6g} world units off the plane of the others")
