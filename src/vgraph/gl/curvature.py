"""What the curvature ray casters (CurvatureRaycaster, CurvatureVolumeRaycaster) share: their two
ray-casting components (CurvatureField, CurvatureColoring) and the GPU range reduction.

Conventions (docs/explanations/curvature.md explains them for users):
- Derivative modes and the volume kind they need: ``forward``, ``central`` and ``filtered`` finite
  differences work on voxel SAMPLES (trilinear texture fetches one voxel apart); ``tricubic`` and
  ``tricubic_fast`` evaluate the cubic B-spline of COEFFICIENTS (CubicSplineProcessor output). A
  volume of the other kind is refused with Volume.require_samples / require_coefficients' message
  plus the alternative (check_volume_kind).
- Derivatives are in normalised intensity per world unit (per world unit squared for the Hessian),
  curvatures in 1/world unit with the sign convention of vgraph.numerics.curvature (interior
  brighter: a sphere of radius r has k1 = k2 = +1/r).
- Curvature is undefined where |grad f| * min(spacing) <= MIN_GRADIENT (normalised intensity per
  voxel), or below the float32 rounding of the values (ROUNDING_GRADIENT * max |value|, see
  min_gradient): no direction, so no surface; such pixels are flagged, never given made-up numbers.
- The measure shown reads |k| * min(spacing) <= ZERO_CURVATURE (|K| against its square) as 0, so
  that float noise on flat surfaces is neither stretched by the linear normalisation nor drawn
  as contour speckle (shaders/curvature/measure.glsl).
- Measures: k1, k2, gaussian (K), mean (H), curvedness sqrt((k1^2 + k2^2) / 2) and shape index
  (2/pi) atan2(k1 + k2, k1 - k2). Normalisation to [0, 1] for the colour map (Cabral 2010 sec. 5.3),
  with kmax = max(max k, 0), kmin = min(min k, 0) over the image:
    linear       k >= 0: 0.5 + 0.5 k / kmax      k < 0: 0.5 - 0.5 k / kmin
    exponential  k >= 0: 1 - exp(-k t) / 2       k < 0: exp(k t) / 2      (t: attenuation, world units)
  so zero curvature sits at 0.5. Curvedness is never negative and uses the whole map: k / kmax or
  1 - exp(-k t). The shape index is already dimensionless in [-1, 1] and maps to (S + 1) / 2.
- Colour maps are 256-entry RGBA32F LUT textures with linear filtering (textures.LookupTexture);
  entry i at normalised value i / 255.
- Linear normalisation needs kmin, kmax of the image: RangeReduction computes them on the GPU by
  passes that each reduce blocks of REDUCE_BLOCK^2 pixels into (min, max) pairs, down to one pixel
  that the colour pass reads as a texture: nothing is read back to the CPU.
"""

from __future__ import annotations

import moderngl
import numpy as np

from vgraph.errors import VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.raycasting.textures import LookupTexture
from vgraph.gl.shaders import programs
from vgraph.image import Image
from vgraph.properties import ColorProperty, FloatProperty, OptionProperty
from vgraph.volume import Volume

DERIVATIVES = ("forward", "central", "filtered", "tricubic", "tricubic_fast")
SAMPLE_DERIVATIVES = ("forward", "central", "filtered")  # need voxel samples
CURVATURES = ("k1", "k2", "gaussian", "mean", "curvedness", "shape_index")
NORMALIZATIONS = ("linear", "exponential")
MIN_GRADIENT = 1e-6  # |grad f| * min(spacing) at or below this (normalised intensity): undefined
ROUNDING_GRADIENT = 1e-5  # ... or at or below this times the largest |value| (float32 rounding)
ZERO_CURVATURE = 1e-3  # |k| * min(spacing) at or below this reads as 0 in the shown measure
REDUCE_BLOCK = 8  # pixels per side reduced by one pass of the min/max reduction
REDUCE_SHADER = "curvature/range_reduce.frag.glsl"

# Colour maps: control points in [0, 1], evenly spaced, linearly interpolated (JET is analytic).
# viridis and coolwarm are 17 samples of matplotlib's maps (van der Walt & Smith; Moreland 2009).
_CONTROL_POINTS = {
    "viridis": [(0.267, 0.0049, 0.3294), (0.2823, 0.095, 0.4173), (0.2788, 0.1755, 0.4834),
                (0.259, 0.2515, 0.5247), (0.2297, 0.3224, 0.5457), (0.1994, 0.3876, 0.5546),
                (0.1727, 0.4488, 0.5579), (0.149, 0.5081, 0.5572), (0.1276, 0.5669, 0.5506),
                (0.1206, 0.6258, 0.5335), (0.1579, 0.6838, 0.5017), (0.2461, 0.7389, 0.452),
                (0.3692, 0.7889, 0.3829), (0.516, 0.8312, 0.2943), (0.6785, 0.8637, 0.1895),
                (0.8456, 0.8873, 0.0997), (0.9932, 0.9062, 0.1439)],
    "coolwarm": [(0.2298, 0.2987, 0.7537), (0.3042, 0.4069, 0.8453), (0.3837, 0.5102, 0.9178),
                 (0.4677, 0.6056, 0.9685), (0.5543, 0.6901, 0.9955), (0.6408, 0.7608, 0.9978),
                 (0.724, 0.8149, 0.9757), (0.8006, 0.8504, 0.93), (0.8674, 0.8644, 0.8626),
                 (0.9256, 0.8255, 0.7711), (0.9595, 0.767, 0.6741), (0.9697, 0.6905, 0.5751),
                 (0.9567, 0.598, 0.4773), (0.9214, 0.4914, 0.3834), (0.8654, 0.3711, 0.2958),
                 (0.7906, 0.2314, 0.2162), (0.7057, 0.0156, 0.1502)],
    "gray": [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0)],
}
COLORMAPS = ("jet", "viridis", "coolwarm", "gray")
COLORMAP_SIZE = 256


# --- volume kinds and defines ---------------------------------------------------------------------
def check_volume_kind(volume: Volume, derivatives: str, consumer: str) -> None:
    """Refuse the volume kind that does not fit the derivative mode, saying what to change."""
    try:
        if derivatives in SAMPLE_DERIVATIVES:
            volume.require_samples(f"{consumer} with derivatives = {derivatives}")
        else:
            volume.require_coefficients(f"{consumer} with derivatives = {derivatives}")
    except VGraphError as error:
        other = ("tricubic or tricubic_fast" if derivatives in SAMPLE_DERIVATIVES
                 else "forward, central or filtered")
        raise VGraphError(f"{error}; or set derivatives to {other}") from None


def derivative_defines(derivatives: str) -> dict[str, bool]:
    """DERIVATIVES_<MODE> (tricubic_fast: DERIVATIVES_TRICUBIC + TRICUBIC_FAST)."""
    if derivatives not in DERIVATIVES:
        raise VGraphError(f"derivatives must be one of {', '.join(DERIVATIVES)}, got {derivatives!r}")
    if derivatives.startswith("tricubic"):
        return {"DERIVATIVES_TRICUBIC": True, "TRICUBIC_FAST": derivatives == "tricubic_fast"}
    return {f"DERIVATIVES_{derivatives.upper()}": True}


def measure_defines(curvature: str, normalization: str | None = None) -> dict[str, bool]:
    """CURVATURE_<MEASURE> and, if given, NORMALIZATION_<KIND>."""
    defines = {f"CURVATURE_{curvature.upper()}": True}
    if normalization is not None:
        defines[f"NORMALIZATION_{normalization.upper()}"] = True
    return defines


def field_uniforms(volume: Volume) -> dict[str, object]:
    """Uniforms of shaders/curvature/field_*.glsl besides the volume's sampling: voxel step,
    1 / spacing and the smallest gradient with a direction."""
    dims = np.array(volume.dims, dtype=np.float64)
    spacing = np.asarray(volume.spacing, dtype=np.float64)
    return {"voxel_step": tuple(1.0 / dims), "inv_spacing": tuple(1.0 / spacing),
            "min_gradient": min_gradient(volume)}


def min_gradient(volume: Volume) -> float:
    """|grad f| (normalised intensity per world unit) at or below which curvature is undefined:
    MIN_GRADIENT per voxel of the smallest spacing, or float32 rounding of the values if that is
    larger: ROUNDING_GRADIENT times the largest |value| per voxel (a constant volume of 7 has
    spline derivatives of ~1e-6 from rounding alone, which a range of 1 would not hide)."""
    lo, hi = volume.value_range
    rounding = ROUNDING_GRADIENT * max(abs(lo), abs(hi)) / (hi - lo)  # normalised, per voxel
    return max(MIN_GRADIENT, rounding) / float(min(volume.spacing))


def measure_uniforms(volume: Volume) -> dict[str, float]:
    """Uniforms of shaders/curvature/measure.glsl: the zero-curvature floor in 1/world units."""
    return {"zero_curvature": ZERO_CURVATURE / float(min(volume.spacing))}


# --- colour maps ----------------------------------------------------------------------------------
def colormap_table(name: str, size: int = COLORMAP_SIZE) -> np.ndarray:
    """(size, 4) float32 RGBA of colour map ``name`` at values i / (size - 1), alpha 1."""
    x = np.linspace(0.0, 1.0, size)
    if name == "jet":  # MATLAB's jet: blue -> cyan -> yellow -> red
        rgb = np.stack([np.clip(1.5 - np.abs(4.0 * x - c), 0.0, 1.0) for c in (3.0, 2.0, 1.0)], -1)
    elif name in _CONTROL_POINTS:
        points = np.array(_CONTROL_POINTS[name])
        knots = np.linspace(0.0, 1.0, len(points))
        rgb = np.stack([np.interp(x, knots, points[:, c]) for c in range(3)], -1)
    else:
        raise VGraphError(f"colormap must be one of {', '.join(COLORMAPS)}, got {name!r}")
    return np.concatenate([rgb, np.ones((size, 1))], axis=1).astype(np.float32)


# --- min / max of the curvature image --------------------------------------------------------------
class RangeReduction:
    """(min, max) of the selected curvature measure over the pixels where curvature is defined
    (alpha 1), on the GPU: each pass reduces blocks of REDUCE_BLOCK^2 pixels, down to 1 x 1. The
    result pixel holds (kmin, kmax, count, 1) with kmin = min(min k, 0), kmax = max(max k, 0).
    Targets are kept between evaluations."""

    def __init__(self):
        self._levels: list[RenderTargets] = []

    def run(self, ctx: moderngl.Context, source: Image, defines: dict, processor: str,
            uniforms: dict | None = None, pairs: bool = False) -> Image:
        """Reduce the curvature image ``source``, or with ``pairs`` an image that already holds
        (min, max, count, 1) per pixel (the CurvatureVolumeRaycaster's range pass). ``uniforms``:
        those of measure.glsl (measure_uniforms)."""
        sizes = reduction_sizes(source.size)
        while len(self._levels) < len(sizes):
            self._levels.append(RenderTargets(1))
        image = source
        for level, size in enumerate(sizes):
            first = level == 0 and not pairs
            program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, REDUCE_SHADER,
                                       {**defines, "REDUCE_FIRST": first}, processor=processor)
            target, = self._levels[level].ensure(ctx, size)
            fullscreen_pass(ctx, program, target, {"source": image},
                            {"source_size": tuple(int(v) for v in image.size),
                             "reduce_block": REDUCE_BLOCK, "last_pass": level == len(sizes) - 1,
                             **(uniforms or {})})
            image = target
        return image


def reduction_sizes(size) -> list[tuple[int, int]]:
    """Target sizes of the reduction passes for an image of ``size`` (ends with (1, 1))."""
    width, height = (int(v) for v in size)
    sizes = []
    while True:
        width, height = -(-width // REDUCE_BLOCK), -(-height // REDUCE_BLOCK)
        sizes.append((width, height))
        if width == height == 1:
            return sizes


# --- components -----------------------------------------------------------------------------------
class CurvatureField(Component):
    """Curvature of the level set through a point from the chosen derivatives (Kindlmann et al.
    2003): finite differences of voxel samples or the tricubic B-spline of coefficients."""

    glsl = ("curvature/field_fd.glsl", "curvature/field_tricubic.glsl", "curvature/kindlmann.glsl")

    def declare(self):
        return {"derivatives": OptionProperty("tricubic", choices=list(DERIVATIVES),
                                              doc="forward, central, filtered differences (voxel samples) "
                                                  "or tricubic, tricubic_fast (B-spline coefficients)")}

    def bind(self, frame: Frame) -> Binding:
        derivatives = self.processor.derivatives
        check_volume_kind(frame.volume, derivatives, f"{self.processor.type_name} '{self.processor.id}'")
        return Binding(defines=derivative_defines(derivatives), uniforms=field_uniforms(frame.volume))


class CurvatureColoring(Component):
    """A curvature measure, normalised to [0, 1] and looked up in a colour map (Cabral 2010 sec. 5.3)."""

    glsl = ("curvature/measure.glsl", "curvature/normalization.glsl")

    def start(self) -> None:
        self.colormap = LookupTexture(COLORMAP_SIZE)

    def declare(self):
        return {"curvature": OptionProperty("gaussian", choices=list(CURVATURES), doc="the measure shown"),
                "normalization": OptionProperty("linear", choices=list(NORMALIZATIONS),
                                                doc="linear: by the largest and smallest curvature "
                                                    "shown; exponential: with attenuation"),
                "attenuation": FloatProperty(1.0, min=1e-6, max=1e6,
                                             doc="t of the exponential normalisation, in world units"),
                "colormap": OptionProperty("jet", choices=list(COLORMAPS)),
                "undefined_color": ColorProperty((0.5, 0.5, 0.5, 1.0),
                                                 doc="colour where the curvature is undefined")}

    def bind(self, frame: Frame) -> Binding:
        processor = self.processor
        name = processor.colormap
        texture = self.colormap.update(frame.ctx, name, lambda: colormap_table(name))
        return Binding(defines=measure_defines(processor.curvature, processor.normalization),
                       textures={"colormap": texture},
                       uniforms={"attenuation": processor.attenuation,
                                 "undefined_color": tuple(processor.undefined_color),
                                 **measure_uniforms(frame.volume)})
