"""Tricubic B-spline evaluation on the GPU (shaders/tricubic/): value, gradient and Hessian at points.

Conventions (docs/explanations/tricubic.md has the math and the measured precision):
- The input is a coefficient Volume (``is_spline_coefficients``, float data, the output of the
  CubicSplineProcessor / numerics.bspline.prefilter), sampled from its R32F ``volume.texture(ctx)``.
- Points are voxel coordinates (x, y, z), shape (..., 3): voxel (i, j, k) = data[k, j, i] at (i, j, k),
  exactly as numerics.bspline.evaluate takes them; in GLSL the texture coordinate of voxel i is
  (i + 0.5) / n. Results use the reference's units too: values in the coefficients' stored units
  (normalised intensity = value * scale + offset, Volume.texture_scale_offset), gradients per world
  unit (divided by the spacing of their axis), Hessian entries divided by both axes' spacings.
- Variants: "direct" sums the 64 coefficients around the point (texelFetch, float32 weights);
  "fast" is Sigg & Hadwiger's form from trilinear fetches (8 for the value, 32 with the gradient,
  92 with the Hessian), read through a LINEAR sampler object. Both mirror the coefficients at the
  grid boundary like the reference, so they agree with it everywhere, not only inside the grid.
- GPU work is float32; the results come back as float64 arrays in a numerics.bspline.SplineSample.
  Non-finite points give NaN, as in the reference.
- The evaluation runs as a fullscreen fragment pass (GLSL 330) of ``tricubic/probe.frag.glsl``,
  one point per pixel, PROBE_WIDTH points per row, at most PROBE_MAX_ROWS rows per pass.
"""

from __future__ import annotations

import moderngl
import numpy as np

from vgraph.errors import VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, set_uniform
from vgraph.gl.shaders import programs
from vgraph.gl.raycasting.textures import linear_sampler
from vgraph.numerics.bspline import SplineSample
from vgraph.volume import Volume

VARIANTS = ("direct", "fast")
PROBE_SHADER = "tricubic/probe.frag.glsl"
PROBE_WIDTH = 1024  # points per row of the probe target
PROBE_MAX_ROWS = 1024  # rows per pass: 1 M points, 16 MB per RGBA32F target
# Texture fetches per evaluated point, by variant and derivative order (value, + gradient, + Hessian).
FETCHES = {"direct": (64, 64, 64), "fast": (8, 32, 92)}

_COEFFICIENT_UNIT, _POINTS_UNIT = 0, 1


def variant_defines(variant: str) -> dict[str, object]:
    """The defines that select ``variant`` in shaders including ``tricubic/tricubic.glsl``."""
    _check_variant(variant)
    return {"TRICUBIC_FAST": variant == "fast"}


def probe_program(ctx: moderngl.Context, variant: str, derivatives: int,
                  texture_space: bool = False) -> moderngl.Program:
    """The (cached) harness program for one variant and derivative order."""
    _check_derivatives(derivatives)
    defines = {**variant_defines(variant), "PROBE_DERIVATIVES": int(derivatives),
               "PROBE_TEXTURE_SPACE": bool(texture_space)}
    return programs.program(ctx, FULLSCREEN_VERTEX_SHADER, PROBE_SHADER, defines)


def evaluate_gl(ctx: moderngl.Context, coefficient_volume: Volume, points_voxel_xyz,
                variant: str = "direct", derivatives: int = 0, *,
                texture_space: bool = False) -> SplineSample:
    """Tricubic B-spline value (and gradient, Hessian) of a coefficient volume at voxel points,
    computed on the GPU; same shapes and units as numerics.bspline.evaluate(volume.data, points,
    volume.spacing, derivatives). ``texture_space`` calls the texture-coordinate entry points
    (p = (u + 0.5) / n, as a ray caster does) instead of the voxel-coordinate ones."""
    _check_variant(variant)
    _check_derivatives(derivatives)
    volume = _checked_volume(coefficient_volume)
    points = np.asarray(points_voxel_xyz, dtype=np.float64)
    if points.shape[-1:] != (3,):
        raise VGraphError(f"evaluate_gl: points must have shape (..., 3) in (x, y, z), "
                          f"got {points.shape}")
    flat = points.reshape(-1, 3)
    finite = np.all(np.isfinite(flat), axis=1)
    flat32 = np.where(finite[:, None], flat, 0.0).astype(np.float32)
    count = flat32.shape[0]
    columns = np.empty((count, 13), dtype=np.float64)  # value, gradient (3), hessian (9)
    if count:
        program = probe_program(ctx, variant, derivatives, texture_space)
        width = min(PROBE_WIDTH, count)
        batch = ProbeBatch(ctx, width, min(PROBE_MAX_ROWS, -(-count // width)), derivatives)
        try:
            for lo in range(0, count, batch.capacity):
                hi = min(count, lo + batch.capacity)
                batch.upload(flat32[lo:hi])
                batch.run(program, volume, variant)
                columns[lo:hi] = batch.download(hi - lo)
        finally:
            batch.release()
    columns[~finite] = np.nan
    return _as_sample(columns, points.shape[:-1], derivatives)


class ProbeBatch:
    """GPU buffers for up to width * height points: an RGBA32F points texture and one (value and
    gradient) or four (+ the Hessian's three columns) RGBA32F result targets. ``run`` renders one
    pass."""

    def __init__(self, ctx: moderngl.Context, width: int, height: int, derivatives: int):
        self.ctx = ctx
        self.size = (int(width), int(height))
        self.capacity = self.size[0] * self.size[1]
        self.points = ctx.texture(self.size, 4, dtype="f4")
        self.targets = [ctx.texture(self.size, 4, dtype="f4")
                        for _ in range(4 if derivatives >= 2 else 1)]
        self.framebuffer = ctx.framebuffer(color_attachments=self.targets)
        self._vertex_arrays: dict[moderngl.Program, moderngl.VertexArray] = {}

    def upload(self, points_xyz: np.ndarray) -> None:
        """Write (m, 3) float32 voxel points, m <= capacity; the rest of the texture is zero."""
        rgba = np.zeros((self.capacity, 4), dtype=np.float32)
        rgba[: len(points_xyz), :3] = points_xyz
        self.points.write(rgba.tobytes())  # row y = 0 first: point x + y * width at pixel (x, y)

    def run(self, program: moderngl.Program, volume: Volume, variant: str) -> None:
        """One fullscreen pass of ``program`` over all pixels (points) of the batch."""
        self.framebuffer.use()
        self.ctx.viewport = (0, 0, *self.size)
        volume.texture(self.ctx).use(location=_COEFFICIENT_UNIT)
        self.points.use(location=_POINTS_UNIT)
        set_uniform(program, "coefficients", _COEFFICIENT_UNIT)
        set_uniform(program, "points", _POINTS_UNIT)
        set_uniform(program, "inv_spacing", tuple(1.0 / float(s) for s in volume.spacing))
        sampler = linear_sampler(self.ctx) if variant == "fast" else None
        if sampler is not None:  # the fast form needs hardware trilinear filtering
            sampler.use(_COEFFICIENT_UNIT)
        try:
            vao = self._vertex_arrays.get(program)
            if vao is None:
                vao = self._vertex_arrays[program] = self.ctx.vertex_array(program, [])
            vao.render(moderngl.TRIANGLES, vertices=3)
        finally:
            if sampler is not None:
                sampler.clear(_COEFFICIENT_UNIT)

    def download(self, count: int) -> np.ndarray:
        """(count, 13) float64: value, gradient (x, y, z), Hessian (9 entries, row-major)."""
        out = np.zeros((count, 13), dtype=np.float64)
        parts = [np.frombuffer(self.framebuffer.read(components=4, attachment=i, dtype="f4"),
                               dtype=np.float32).reshape(-1, 4)[:count]
                 for i in range(len(self.targets))]
        out[:, 0:4] = parts[0]
        if len(parts) == 4:  # attachments 1..3 hold the Hessian's columns x, y, z
            out[:, 4:13] = np.stack([part[:, :3] for part in parts[1:]], axis=-1).reshape(count, 9)
        return out

    def release(self) -> None:
        for vao in self._vertex_arrays.values():
            vao.release()
        self.framebuffer.release()
        for texture in [self.points, *self.targets]:
            texture.release()


def _as_sample(columns: np.ndarray, shape: tuple, derivatives: int) -> SplineSample:
    value = columns[:, 0].reshape(shape)
    gradient = columns[:, 1:4].reshape(shape + (3,)) if derivatives >= 1 else None
    hessian = columns[:, 4:13].reshape(shape + (3, 3)) if derivatives >= 2 else None
    return SplineSample(value, gradient, hessian)


def _checked_volume(volume) -> Volume:
    if not isinstance(volume, Volume):
        raise VGraphError(f"evaluate_gl: expected a Volume of B-spline coefficients, "
                          f"got {type(volume).__name__}")
    volume.require_coefficients("tricubic evaluation (evaluate_gl)")
    if volume.data.dtype.kind != "f":
        where = f" from {volume.source}" if volume.source else ""
        raise VGraphError(f"evaluate_gl: coefficient volume{where} must hold float data (it is "
                          f"uploaded as R32F), got {volume.data.dtype}")
    return volume


def _check_variant(variant: str) -> None:
    if variant not in VARIANTS:
        raise VGraphError(f"tricubic variant must be one of {', '.join(VARIANTS)}, got {variant!r}")


def _check_derivatives(derivatives: int) -> None:
    if derivatives not in (0, 1, 2) or isinstance(derivatives, bool):
        raise VGraphError(f"tricubic derivatives must be 0, 1 or 2, got {derivatives!r}")
