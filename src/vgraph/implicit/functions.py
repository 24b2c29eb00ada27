"""The implicit functions: frozen dataclasses with validated parameters and exact derivatives.

Every function is written once, in ``_field``, on jets (see jets.py); ``value`` evaluates it
value-only, ``jet``/``gradient``/``hessian`` to second order. Points are (N, 3) arrays in (x, y, z)
world order, float64. The interior has HIGHER values than the exterior and the surface is f = 0.
Forms are distance-like near the surface; singular sets (|p| = 0, axes, core circles) lie at least
0.05 world units off the surface for every allowed parameter set, and their derivatives read 0.
The formulas, defaults, ranges and boxes are listed in docs/reference/general/functions.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from vgraph.errors import PropertyError
from vgraph.implicit.jets import (Jet, as_points, coordinate_jets, cos, cos_half_pi_sqrt, int_power,
                                  power, sin, smooth_max, sqrt, tanh)

Box = tuple[tuple[float, float, float], tuple[float, float, float]]
UNIT_BOX: Box = ((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))


class Range(NamedTuple):
    """Allowed values of one parameter; printed as [lo, hi] with ( ) for open ends."""
    lo: float
    hi: float
    lo_open: bool = False
    hi_open: bool = False

    def __contains__(self, v) -> bool:
        return ((self.lo < v if self.lo_open else self.lo <= v)
                and (v < self.hi if self.hi_open else v <= self.hi))

    def __str__(self) -> str:
        return f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}{')' if self.hi_open else ']'}"


LENGTH = Range(0.05, 0.9)  # fits [-1, 1]^3 with margin 0.1; >= 0.05 keeps singular sets off surfaces


# --- the functions ------------------------------------------------------------------------------
@dataclass(frozen=True)
class ImplicitFunction:
    """Base of all implicit functions: frozen parameters, validated on construction."""

    name: ClassVar[str] = ""
    ranges: ClassVar[dict[str, Range]] = {}
    box: ClassVar[Box] = UNIT_BOX

    def __post_init__(self):
        for param, allowed in self.ranges.items():
            value = getattr(self, param)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
                self._fail(param, f"must be a number, got {value!r}")
            if not math.isfinite(value) or value not in allowed:
                self._fail(param, f"must be in {allowed}, got {value!r}")
            object.__setattr__(self, param, float(value))
        self._check_relations()

    def _fail(self, param: str, reason: str):
        raise PropertyError(f"function '{self.name}', parameter '{param}'", reason)

    def _check_relations(self):
        """Constraints between parameters (overridden where there are any)."""

    def _field(self, x: Jet, y: Jet, z: Jet) -> Jet:
        raise NotImplementedError

    def parameters(self) -> dict:
        return dataclasses.asdict(self)

    def value(self, p) -> np.ndarray:
        """f at world points p (N, 3) -> (N,)."""
        pts = as_points(p)
        return np.asarray(self._field(*(Jet(pts[:, i]) for i in range(3))).v, dtype=np.float64)

    def jet(self, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(f (N,), gradient (N, 3), Hessian (N, 3, 3)) at world points p (N, 3)."""
        pts = as_points(p)
        j = self._field(*coordinate_jets(pts))
        n = pts.shape[0]
        return (np.broadcast_to(j.v, (n,)).copy(), np.broadcast_to(j.g, (n, 3)).copy(),
                np.broadcast_to(j.h, (n, 3, 3)).copy())

    def gradient(self, p) -> np.ndarray:
        return self.jet(p)[1]

    def hessian(self, p) -> np.ndarray:
        return self.jet(p)[2]

    def value_on_grid(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """f on the grid z[:, None, None], y[None, :, None], x[None, None, :] -> [z, y, x]."""
        v = self._field(Jet(x[None, None, :]), Jet(y[None, :, None]), Jet(z[:, None, None])).v
        return np.broadcast_to(v, (z.size, y.size, x.size))


def _torus_distance(rho2: Jet, z: Jet, major: float, minor: float) -> Jet:
    """minor - distance to the core circle (radius major, axis z); rho2 = squared axis distance."""
    u = sqrt(rho2) - major
    return minor - sqrt(u * u + z * z)


@dataclass(frozen=True)
class Sphere(ImplicitFunction):
    """f = r - |p|."""
    name: ClassVar[str] = "sphere"
    ranges: ClassVar[dict[str, Range]] = {"radius": LENGTH}
    radius: float = 0.7

    def _field(self, x, y, z):
        return self.radius - sqrt(x * x + y * y + z * z)


@dataclass(frozen=True)
class Ellipsoid(ImplicitFunction):
    """f = min(a, b, c) (1 - sqrt(x^2/a^2 + y^2/b^2 + z^2/c^2))."""
    name: ClassVar[str] = "ellipsoid"
    ranges: ClassVar[dict[str, Range]] = {"a": LENGTH, "b": LENGTH, "c": LENGTH}
    a: float = 0.8
    b: float = 0.6
    c: float = 0.4

    def _field(self, x, y, z):
        q = x * x / self.a**2 + y * y / self.b**2 + z * z / self.c**2
        return min(self.a, self.b, self.c) * (1.0 - sqrt(q))


@dataclass(frozen=True)
class Torus(ImplicitFunction):
    """f = r - sqrt((sqrt(x^2 + y^2) - R)^2 + z^2), axis z."""
    name: ClassVar[str] = "torus"
    ranges: ClassVar[dict[str, Range]] = {"major_radius": LENGTH, "minor_radius": LENGTH}
    major_radius: float = 0.55
    minor_radius: float = 0.25

    def _check_relations(self):
        if self.minor_radius > self.major_radius - 0.05:
            self._fail("minor_radius", f"must be <= major_radius - 0.05 ({self.major_radius - 0.05:g})"
                                       f" so the hole stays open, got {self.minor_radius:g}")
        if self.major_radius + self.minor_radius > 0.9:
            self._fail("major_radius", "major_radius + minor_radius must be <= 0.9 to fit the box"
                                       f" [-1, 1]^3, got {self.major_radius + self.minor_radius:g}")

    def _field(self, x, y, z):
        return _torus_distance(x * x + y * y, z, self.major_radius, self.minor_radius)


@dataclass(frozen=True)
class RoundedCube(ImplicitFunction):
    """f = h - (x^n + y^n + z^n)^(1/n), n even: every level set is a scaled rounded cube."""
    name: ClassVar[str] = "rounded_cube"
    ranges: ClassVar[dict[str, Range]] = {"half_width": LENGTH}
    half_width: float = 0.65
    exponent: int = 4

    def _check_relations(self):
        n = self.exponent
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2 or n > 16 or n % 2:
            self._fail("exponent", f"must be an even integer in [2, 16], got {n!r}")
        object.__setattr__(self, "exponent", int(n))

    def _field(self, x, y, z):
        n = self.exponent
        return self.half_width - power(int_power(x, n) + int_power(y, n) + int_power(z, n), 1 / n)


@dataclass(frozen=True)
class Saddle(ImplicitFunction):
    """f = (x^2 - y^2) / (2a) - z: the hyperbolic paraboloid, interior below it."""
    name: ClassVar[str] = "saddle"
    ranges: ClassVar[dict[str, Range]] = {"curvature_radius": Range(0.1, 100.0)}
    curvature_radius: float = 0.75

    def _field(self, x, y, z):
        return (x * x - y * y) / (2.0 * self.curvature_radius) - z


@dataclass(frozen=True)
class Hyperboloid(ImplicitFunction):
    """f = min(a, b) / 2 (1 - x^2/a^2 - y^2/b^2 + z^2/c^2): one sheet around the z axis."""
    name: ClassVar[str] = "hyperboloid"
    ranges: ClassVar[dict[str, Range]] = {"a": LENGTH, "b": LENGTH, "c": Range(0.05, 10.0)}
    a: float = 0.45
    b: float = 0.35
    c: float = 0.5

    def _field(self, x, y, z):
        q = x * x / self.a**2 + y * y / self.b**2 - z * z / self.c**2
        return 0.5 * min(self.a, self.b) * (1.0 - q)


@dataclass(frozen=True)
class MarschnerLobb(ImplicitFunction):
    """f = rho - 1/2, rho = (1 - sin(pi z/2) + alpha (1 + cos(2 pi f_M cos(pi r/2)))) / (2 (1 + alpha))."""
    name: ClassVar[str] = "marschner_lobb"
    ranges: ClassVar[dict[str, Range]] = {"alpha": Range(0.0, 1.0, hi_open=True),
                                          "f_m": Range(0.0, 50.0, lo_open=True)}
    alpha: float = 0.25
    f_m: float = 6.0

    def _field(self, x, y, z):
        radial = cos(2.0 * math.pi * self.f_m * cos_half_pi_sqrt(x * x + y * y))
        rho = (1.0 - sin(0.5 * math.pi * z) + self.alpha * (1.0 + radial)) / (2.0 * (1.0 + self.alpha))
        return rho - 0.5


@dataclass(frozen=True)
class Genus2(ImplicitFunction):
    """Two tori (axis z, centres (+-d/2, 0, 0)) joined by a smooth maximum of width k."""
    name: ClassVar[str] = "genus2"
    ranges: ClassVar[dict[str, Range]] = {"major_radius": LENGTH, "minor_radius": LENGTH,
                                          "separation": Range(0.0, 1.8, lo_open=True),
                                          "blend": Range(0.0, 0.1, lo_open=True)}
    major_radius: float = 0.35
    minor_radius: float = 0.15
    separation: float = 0.8
    blend: float = 0.03

    def _check_relations(self):
        big, small, d, k = self.major_radius, self.minor_radius, self.separation, self.blend
        if small + k + 0.05 > big:
            self._fail("minor_radius", f"minor_radius + blend must be <= major_radius - 0.05"
                                       f" ({big - 0.05:g}) so the holes stay open, got {small + k:g}")
        if not big + small + k + 0.05 <= d < 2.0 * (big + small):
            self._fail("separation", f"must be in [major_radius + minor_radius + blend + 0.05,"
                                     f" 2 (major_radius + minor_radius)) = [{big + small + k + 0.05:g},"
                                     f" {2 * (big + small):g}) for two open holes in one solid,"
                                     f" got {d:g}")
        if d / 2 + big + small > 0.9:
            self._fail("separation", f"separation/2 + major_radius + minor_radius must be <= 0.9"
                                     f" to fit the box [-1, 1]^3, got {d / 2 + big + small:g}")

    def _field(self, x, y, z):
        yy = y * y
        half = 0.5 * self.separation
        left = _torus_distance((x + half) * (x + half) + yy, z, self.major_radius, self.minor_radius)
        right = _torus_distance((x - half) * (x - half) + yy, z, self.major_radius, self.minor_radius)
        return smooth_max(left, right, self.blend)


@dataclass(frozen=True)
class StiffShell(ImplicitFunction):
    """f = tanh(s u), u = ((w/2)^2 - (|p| - r)^2) / w: a spherical shell of thickness w."""
    name: ClassVar[str] = "stiff_shell"
    ranges: ClassVar[dict[str, Range]] = {"radius": LENGTH, "thickness": LENGTH,
                                          "sharpness": Range(0.0, 1000.0, lo_open=True)}
    radius: float = 0.6
    thickness: float = 0.2
    sharpness: float = 20.0

    def _check_relations(self):
        half = self.thickness / 2
        if self.radius - half < 0.05:
            self._fail("thickness", f"radius - thickness/2 must be >= 0.05 (an inner surface),"
                                    f" got {self.radius - half:g}")
        if self.radius + half > 0.9:
            self._fail("thickness", "radius + thickness/2 must be <= 0.9 to fit the box"
                                    f" [-1, 1]^3, got {self.radius + half:g}")

    def _field(self, x, y, z):
        off = sqrt(x * x + y * y + z * z) - self.radius
        u = ((self.thickness / 2) ** 2 - off * off) / self.thickness
        return tanh(self.sharpness * u)


@dataclass(frozen=True)
class Cylinder(ImplicitFunction):
    """f = r - sqrt(x^2 + y^2), axis z (K = 0)."""
    name: ClassVar[str] = "cylinder"
    ranges: ClassVar[dict[str, Range]] = {"radius": LENGTH}
    radius: float = 0.5

    def _field(self, x, y, z):
        return self.radius - sqrt(x * x + y * y)


@dataclass(frozen=True)
class Plane(ImplicitFunction):
    """f = offset - n.p with n the unit normal: interior on the side opposite to n (k1 = k2 = 0)."""
    name: ClassVar[str] = "plane"
    ranges: ClassVar[dict[str, Range]] = {"offset": Range(-0.9, 0.9)}
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0

    def _check_relations(self):
        try:
            n = np.array([float(v) for v in self.normal])
        except (TypeError, ValueError):
            self._fail("normal", f"must be three numbers (x, y, z), got {self.normal!r}")
        if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
            self._fail("normal", f"must be three finite numbers, not all 0, got {self.normal!r}")
        object.__setattr__(self, "normal", tuple(float(v) for v in n / np.linalg.norm(n)))

    def _field(self, x, y, z):
        nx, ny, nz = self.normal
        return self.offset - (nx * x + ny * y + nz * z)


FUNCTIONS: dict[str, type[ImplicitFunction]] = {cls.name: cls for cls in (
    Sphere, Torus, Ellipsoid, RoundedCube, Saddle, Hyperboloid, MarschnerLobb, Genus2, StiffShell,
    Cylinder, Plane)}


def make_function(name: str, **params) -> ImplicitFunction:
    """The registered function ``name`` with ``params`` (defaults for the others)."""
    if name not in FUNCTIONS:
        raise PropertyError("function", f"unknown function {name!r}; known: {', '.join(FUNCTIONS)}")
    cls = FUNCTIONS[name]
    known = [f.name for f in dataclasses.fields(cls)]
    for param in params:
        if param not in known:
            raise PropertyError(f"function '{name}', parameter '{param}'",
                                f"unknown parameter; {name} has: {', '.join(known)}")
    return cls(**params)
