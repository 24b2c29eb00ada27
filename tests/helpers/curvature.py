"""Shared helpers of the curvature ray caster tests: networks, CPU references of the derivative
modes and of the colour pass, and a small GLSL preprocessor that keeps the lines a define set
compiles."""

import itertools
import re

import numpy as np

from vgraph.camera import Camera
from vgraph.gl.curvature import colormap_table
from vgraph.numerics.bspline import evaluate, prefilter
from vgraph.numerics.finite_differences import gradient_at, hessian_at, trilinear
from vgraph.testing import ray_caster_network

TORUS_CAMERA = Camera.looking_at_box((-0.8, -0.8, -0.25), (0.8, 0.8, 0.25), direction=(-0.3, -0.5, -1.0))


def coefficients_of(samples):
    """What the CubicSplineProcessor makes of ``samples``."""
    return samples.with_data(prefilter(samples.data), is_spline_coefficients=True,
                             declared_range=samples.value_range)


def curvature_network(volume, camera, processor="CurvatureRaycaster", **properties):
    """GivenVolume -> EntryExitPoints -> curvature ray caster 'cr', cameras linked."""
    return ray_caster_network(volume, camera, processor, id="cr", **properties)


def render(volume, camera, size, outputs=("curvature", "position"), **properties):
    network = curvature_network(volume, camera, **properties)
    return [network.evaluate(f"cr.{name}", size=size) for name in outputs]


# --- CPU references of the derivative modes (world points, float64) -------------------------------
def forward_derivatives(data, p, spacing):
    s = np.asarray(spacing, dtype=np.float64)
    unit = np.eye(3)

    def f(offset):
        return trilinear(data, p + offset)

    here = f(np.zeros(3))
    one = [f(unit[a]) for a in range(3)]
    gradient = np.stack([one[a] - here for a in range(3)], -1) / s
    hessian = np.empty(p.shape[:-1] + (3, 3))
    for a, b in itertools.product(range(3), repeat=2):
        hessian[..., a, b] = (f(unit[a] + unit[b]) - one[a] - one[b] + here) / (s[a] * s[b])
    return gradient, hessian


def filtered_hessian(data, p, spacing):
    diagonals = [hessian_at(data, p + np.array(d), spacing)
                 for d in itertools.product((-1.0, 1.0), repeat=3)]
    return 0.25 * hessian_at(data, p, spacing) + 0.75 * np.mean(diagonals, axis=0)


def reference_derivatives(mode, volume, world_points):
    """(gradient, Hessian) of derivative mode ``mode`` at world points, in raw units."""
    p = volume.world_to_voxel(world_points)
    data, spacing = volume.data, volume.spacing
    if mode.startswith("tricubic"):
        spline = evaluate(data, p, spacing, derivatives=2)
        return spline.gradient, spline.hessian
    if mode == "forward":
        return forward_derivatives(data, p, spacing)
    if mode == "central":
        return gradient_at(data, p, spacing), hessian_at(data, p, spacing)
    return gradient_at(data, p, spacing, "filtered"), filtered_hessian(data, p, spacing)


# --- CPU reference of the colour pass --------------------------------------------------------------
def measure(curvature, name, zero=0.0):
    """The measure shown, with measure.glsl's zero floor ``zero`` (1/world units)."""
    k1, k2 = curvature[..., 0].astype(np.float64), curvature[..., 1].astype(np.float64)
    curvedness = np.sqrt(0.5 * (k1 * k1 + k2 * k2))
    value = {"k1": k1, "k2": k2, "gaussian": curvature[..., 2].astype(np.float64),
             "mean": 0.5 * (k1 + k2), "curvedness": curvedness,
             "shape_index": (2 / np.pi) * np.arctan2(k1 + k2, k1 - k2)}[name]
    if name == "shape_index":
        return np.where(curvedness <= zero, 0.0, value)
    return np.where(np.abs(value) <= (zero * zero if name == "gaussian" else zero), 0.0, value)


def normalize(k, name, normalization, kmin, kmax, attenuation=1.0):
    if name == "shape_index":
        return np.clip(0.5 * (k + 1.0), 0.0, 1.0)
    if normalization == "linear":
        if name == "curvedness":
            return np.clip(k / kmax, 0.0, 1.0) if kmax > 0 else np.zeros_like(k)
        with np.errstate(divide="ignore", invalid="ignore"):
            positive = np.where(kmax > 0, 0.5 + 0.5 * k / kmax, 0.5)
            negative = np.where(kmin < 0, 0.5 - 0.5 * k / kmin, 0.5)
        return np.clip(np.where(k >= 0, positive, negative), 0.0, 1.0)
    if name == "curvedness":
        return 1.0 - np.exp(-np.maximum(k, 0.0) * attenuation)
    with np.errstate(over="ignore"):
        return np.where(k >= 0, 1.0 - 0.5 * np.exp(-k * attenuation), 0.5 * np.exp(k * attenuation))


def colormap(values, name):
    table = colormap_table(name).astype(np.float64)
    knots = np.linspace(0.0, 1.0, len(table))
    return np.stack([np.interp(values, knots, table[:, c]) for c in range(3)], -1)


def contour_weight(k, defined, width):
    """The shader's contour weight (contour.glsl) from the measure image (rows top to bottom)."""
    if width <= 0:
        return np.zeros_like(k)
    padded_k = np.pad(k, 1)
    padded_ok = np.pad(defined, 1)

    def derivative(dy, dx):
        h, w = k.shape
        up = padded_k[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        up_ok = padded_ok[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        down = padded_k[1 - dy:1 - dy + h, 1 - dx:1 - dx + w]
        down_ok = padded_ok[1 - dy:1 - dy + h, 1 - dx:1 - dx + w]
        return np.where(up_ok & down_ok, 0.5 * (up - down),
                        np.where(up_ok, up - k, np.where(down_ok, k - down, 0.0)))

    steepness = np.hypot(derivative(0, 1), derivative(1, 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = np.where(k == 0, 0.0, np.where(steepness > 0, np.abs(k) / steepness, 1e30))
    return 1.0 - np.clip(distance - (0.5 * width - 0.5), 0.0, 1.0)


def reference_colours(curvature, name, normalization="linear", colormap_name="jet",
                      contour_width=2.0, attenuation=1.0, zero=0.0):
    """Unshaded colour of every pixel with defined curvature, as curvature_color.frag.glsl
    (``zero``: the volume's zero-curvature floor, vgraph.gl.curvature.measure_uniforms)."""
    defined = curvature[..., 3] == 1.0
    k = np.where(defined, measure(curvature, name, zero), 0.0)
    kmin = min(float(k[defined].min()), 0.0) if defined.any() else 0.0
    kmax = max(float(k[defined].max()), 0.0) if defined.any() else 0.0
    rgb = colormap(normalize(k, name, normalization, kmin, kmax, attenuation), colormap_name)
    return rgb * (1.0 - contour_weight(k, defined, contour_width))[..., None]


# --- which lines a define set compiles -------------------------------------------------------------
_DIRECTIVE = re.compile(r"^\s*#\s*(ifdef|ifndef|if|elif|else|endif|define)\b\s*(.*)$")


def active_source(text: str) -> str:
    """The code a composed shader compiles: the lines the GLSL preprocessor keeps (#ifdef, #ifndef,
    #if with defined(), !, &&, || and integer macros; #elif, #else, #endif; #define), without
    // comments."""
    macros: dict[str, str] = {}
    stack: list[tuple[bool, bool]] = []  # (this branch active, some branch taken)
    kept = []
    for line in text.splitlines():
        match = _DIRECTIVE.match(line)
        active = all(a for a, _ in stack)
        if not match:
            if active:
                kept.append(line.split("//")[0].rstrip())
            continue
        kind, rest = match.group(1), match.group(2).split("//")[0].strip()
        if kind == "define" and active:
            name, _, value = rest.partition(" ")
            macros[name] = value.strip()
        elif kind in ("ifdef", "ifndef"):
            value = (rest in macros) == (kind == "ifdef")
            stack.append((value, value))
        elif kind == "if":
            value = _evaluate(rest, macros)
            stack.append((value, value))
        elif kind == "elif":
            _, taken = stack.pop()
            value = not taken and _evaluate(rest, macros)
            stack.append((value, taken or value))
        elif kind == "else":
            _, taken = stack.pop()
            stack.append((not taken, True))
        elif kind == "endif":
            stack.pop()
    return "\n".join(kept)


def _evaluate(expression: str, macros: dict) -> bool:
    expression = re.sub(r"defined\s*\(\s*(\w+)\s*\)|defined\s+(\w+)",
                        lambda m: "1" if (m.group(1) or m.group(2)) in macros else "0", expression)
    expression = expression.replace("&&", " and ").replace("||", " or ")
    expression = re.sub(r"!(?!=)", " not ", expression)
    expression = re.sub(r"[A-Za-z_]\w*", lambda m: m.group(0) if m.group(0) in ("and", "or", "not")
                        else (macros.get(m.group(0)) or "0"), expression)
    return bool(eval(expression, {"__builtins__": {}}))
