"""CPU reference ray caster (numpy, vectorised over rays). The GL ray caster copies this model;
tests compare the two images pixel by pixel.

Optical model (Inácio 2009 ch. 2.4 and 4.1-4.3), in this order:

1. Rays: ``Camera.rays(W, H)`` - one per pixel centre, row 0 at the top, origin on the near plane
   (ray parameter t = 0), unit direction, t in world units. The far plane is at
   ``t_far = (far - near) / dot(direction, forward)``.
2. Box: the volume's voxel centres span ``[origin, origin + (dims - 1) * spacing]`` (x, y, z)
   along its index axes: for an oriented volume (Volume.direction) a box turned as they are, which
   is tested in the turned coordinates where it is axis-aligned (vgraph.numerics.reference_boxes:
   the turn keeps t). Slab test against this box grown by ``eps = 1e-9 * (max |corner
   coordinate| + min spacing)`` on every side (so rays running exactly along a face count as hits;
   a float32 GL version uses ~1e-5 instead; only such grazing rays may differ). ``t_entry =
   max(t_box_in, 0)`` (clipped to the near plane, so a camera inside the box works), ``t_exit =
   min(t_box_out, t_far)``. The ray misses if ``t_exit < t_entry``: its pixel is the background,
   exactly. The camera is resolved on ``volume_box`` (the box itself, or for a tilted volume the
   box with its bounding sphere, which is what framing uses).
3. Samples: ``step = min(spacing) / sampling_rate`` (world units). Sample i is at
   ``t_entry + i * step`` for ``i = 0 .. n - 1`` with ``n = floor((t_exit - t_entry) / step + 1e-3) + 1``:
   the first sample lies on the entry face and, when the length is a whole number of steps (up to
   rounding), the last one on the exit face. (So an orthographic view along an axis with pixels on
   voxel centres samples exactly the voxel centres of each column.)
4. Reconstruction (vgraph.numerics.reference_sampling, as the gradients of rule 6): voxel coordinate ``u = (p - origin) / spacing`` (``direction^T (p - origin) /
   spacing`` for an oriented volume: the inverse of its affine), clamped to [0, dims - 1] per
   axis (= GL clamp-to-edge with texture coordinate ``(u + 0.5) / dims``), trilinear interpolation
   with voxel centres at integer u. Values are normalised intensities ``volume.normalized``;
   non-finite voxels count as the value range's end (NaN and -inf -> low, +inf -> high), as the
   volume's texture upload does.
5. Classification (``classification``: by value and gradient magnitude as
   vgraph.numerics.reference_classification states): the TF's 4096-entry LUT (``TransferFunction.lut()``) with LINEAR interpolation
   between entries, intensity clamped to [0, 1]: ``x = v * 4095``, entries floor(x) and floor(x)+1
   (= a GL 1D texture, linear filter, clamp-to-edge, coordinate ``0.5/4096 + v * 4095/4096``).
6. Optional shading (``shading=Shading(...)``, Inácio 2009 ch. 4.3, Blinn-Phong with a headlight):
   gradient by central differences of the reconstructed field one voxel away along each axis,
   ``g_k = (f(p + h_k e_k) - f(p - h_k e_k)) / (2 h_k)``, ``h = spacing`` (normalised intensity per
   world unit); for an oriented volume along its index axes (``e_k`` = column k of the direction),
   the components then turned into the world (``g = direction @ g_index``), as are the
   precomputed gradients below. With ``Shading(gradients="precomputed")`` (the RayCaster's ``derivatives =
   precomputed``) the gradient is instead computed once at the voxels,
   ``G[i] = (F[i + e_k] - F[i - e_k]) / (2 h_k)`` on the normalised voxel values F padded by one
   voxel of their edge values (= the clamp-to-edge of rule 4), and reconstructed trilinearly like
   the intensities (rule 4's clamping and weights). With ``quantized=True`` (the default, as the GL
   texture stores them) each component is first rounded to ``round(G_k * (32767 / s_k)) * s_k /
   32767`` with ``s_k = max |G_k|`` over the volume (1 where that is 0): 16-bit steps on each side
   of 0 (the texture stores 32767 plus these). Trilinear interpolation commutes with whole-voxel
   shifts and edge padding equals clamping, so unquantised this equals the on-the-fly central
   difference at every point of the box (it differs only beyond the box, by the clamping);
   quantised it differs by at most ``s_k / 65534`` per component. ``L = V = H = -direction``;
   two-sided: ``c = |dot(g / |g|, L)|``;
   ``rgb' = clamp(ambient * rgb + diffuse * c * rgb + specular * c ** shininess, 0, 1)``; where
   ``|g| * min(spacing) <= 1e-6`` the colour stays unshaded. Alpha is not changed. (Only samples
   with opacity > 0 are shaded; the others do not contribute anyway.)
7. DVR: opacity correction ``a' = 1 - (1 - a) ** (step / min(spacing))`` (the TF alpha is per sample
   at sampling rate 1); front-to-back ``C += (1 - A) * a' * rgb``, ``A += (1 - A) * a'``, starting
   from C = 0, A = 0. Early termination: before each sample the ray stops if ``A >= early_termination``
   (so an opaque TF takes exactly one sample). Final pixel over the background:
   ``rgb = C + (1 - A) * bg.rgb``, ``alpha = A + (1 - A) * bg.a``. Computed in log space, which is
   the same arithmetic to rounding for ordinary inputs and stays exact at the extremes (opacities
   1e-9 and 1 - 1e-9, optical depths 1e-8 to 1e8): ``a' = -expm1(exponent * log1p(-a))`` (a
   itself at sampling rate 1), the ray keeps ``ln(1 - A) = sum log1p(-a')``, a sample's weight is
   ``exp(ln(1 - A)) * a'`` and ``A = -expm1(ln(1 - A))``.
8. MIP: ``m`` = max over all n samples of the normalised intensity clamped to [0, 1] (no early
   termination, no opacity correction, no shading); ``(rgb, a) = TF(m)`` via the LUT as in 5;
   pixel = ``a * rgb + (1 - a) * bg.rgb``, alpha ``a + (1 - a) * bg.a`` - a single DVR sample.
9. Optional shadows (``shadow``, a callable from (M, 3) world points to the light's
   transmittance T: vgraph.numerics.reference_shadows): in DVR each visible sample's colour,
   shaded or not, is multiplied by ``1 - shadow_strength * (1 - T)`` at its point (the GL ray
   caster's light_volume inport).
10. Memory: rays are marched ``chunk_rays`` at a time in lockstep, so the working memory is bounded
   by the chunk (whatever the sampling rate or optical depth) plus a few float64 numbers per pixel
   (its ray, interval and result).

The image is float32 (H, W, 4), row 0 at the top. Arithmetic is float64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vgraph.camera import Camera
from vgraph.clipping import clip_intervals
from vgraph.errors import VGraphError, positive_pair
from vgraph.numerics.reference_boxes import RayBox, volume_box
from vgraph.numerics.reference_sampling import VolumeSampler
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

MODES = ("dvr", "mip")
SAMPLE_COUNT_SLACK = 1e-3  # fraction of a step; see rule 3 of the module docstring
GRADIENT_EPSILON = 1e-6  # |g| * min(spacing) below this: no shading; see rule 6
GRADIENT_MODES = ("central", "precomputed")


@dataclass(frozen=True)
class Shading:
    """Blinn-Phong coefficients (headlight, white light and specular colour) and where the
    gradient comes from: ``central`` differences of the reconstructed field, or ``precomputed``
    central differences at the voxels, interpolated (``quantized`` to 16-bit steps as the GL
    texture holds them); rule 6."""

    ambient: float = 0.3
    diffuse: float = 0.7
    specular: float = 0.2
    shininess: float = 32.0
    gradients: str = "central"
    quantized: bool = True


def render(volume: Volume, camera: Camera, transfer_function: TransferFunction, size,
           *, mode: str = "dvr", sampling_rate: float = 1.0, early_termination: float = 0.99,
           background=(0.0, 0.0, 0.0, 1.0), shading: Shading | None = None,
           return_samples: bool = False, chunk_rays: int = 65536, clip_planes=(), crop_box=None,
           shadow=None, shadow_strength: float = 1.0, classification=None, sample_weights=None):
    """Render ``volume`` as the GL ray caster does (model in the module docstring).

    ``classification`` (dvr only): a reference_classification.GradientClassification, gradient
    opacity and 2D transfer functions by its model.

    ``clip_planes`` and ``crop_box`` cut each ray's interval before sampling (vgraph.clipping).
    ``sample_weights`` (vgraph.masking.MaskWeights: a mask, a cut-away) weighs each sample at its
    world point: dvr multiplies the TF opacity by it before the correction, mip the intensity.
    ``size`` is (width, height). Returns the float32 (H, W, 4) image, row 0 at the top, and with
    ``return_samples=True`` also the int32 (H, W) number of samples each ray took."""
    width, height, background = _check_arguments(volume, size, mode, sampling_rate,
                                                 early_termination, background)
    _check_shading(shading)
    camera = camera.resolved(*volume_box(volume), width / height)  # as the GL renderers do
    origins, directions = camera.rays(width, height)
    origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    t_entry, t_exit = RayBox.of([volume]).clip(origins, directions, camera.far_distance(directions),
                                               min(volume.spacing), crop_box)  # rule 2
    t_entry, t_exit = clip_intervals(origins, directions, t_entry, t_exit, clip_planes)
    step = min(volume.spacing) / sampling_rate
    counts = sample_counts(t_entry, t_exit, step)
    sampler = VolumeSampler(volume)
    lut = transfer_function.for_volume(volume).lut().astype(np.float64)
    classify = _classifier(sampler, lut, classification, mode)

    rgba = np.empty((len(origins), 4))
    taken = np.zeros(len(origins), dtype=np.int32)
    for start in range(0, len(origins), chunk_rays):
        rays = slice(start, start + chunk_rays)
        march, table = (_march_dvr, classify) if mode == "dvr" else (_march_mip, lut)
        rgba[rays], taken[rays] = march(sampler, table, origins[rays], directions[rays],
                                        t_entry[rays], counts[rays], step, sampling_rate,
                                        early_termination, shading, (shadow, shadow_strength), sample_weights)
    # Over the background; a missed ray (A = 0, no samples) becomes the background exactly.
    coverage = rgba[:, 3:4]
    image = np.concatenate([rgba[:, :3] + (1.0 - coverage) * background[:3],
                            coverage + (1.0 - coverage) * background[3]], axis=1)
    image = image.reshape(height, width, 4).astype(np.float32)
    if return_samples:
        return image, taken.reshape(height, width)
    return image


def sample_counts(t_entry: np.ndarray, t_exit: np.ndarray, step: float) -> np.ndarray:
    """n = floor((t_exit - t_entry) / step + slack) + 1 for hits, 0 for misses (t_exit < t_entry)."""
    length = t_exit - t_entry
    hit = length >= 0.0
    counts = np.zeros(len(length), dtype=np.int64)
    counts[hit] = np.floor(length[hit] / step + SAMPLE_COUNT_SLACK).astype(np.int64) + 1
    return counts


def lookup(lut: np.ndarray, intensity: np.ndarray) -> np.ndarray:
    """RGBA from an (N, 4) LUT at normalised intensities, linear between entries, clamped."""
    x = np.clip(intensity, 0.0, 1.0) * (len(lut) - 1)
    base = np.minimum(np.floor(x).astype(np.int64), len(lut) - 2)
    frac = (x - base)[:, None]
    return lut[base] * (1.0 - frac) + lut[base + 1] * frac


# --- marching -----------------------------------------------------------------------------------
def _classifier(sampler, lut, classification, mode):
    """classify(points, values) -> RGBA: the LUT (rule 5), or ``classification``'s model."""
    if classification is None or classification.is_off:
        return lambda points, values: lookup(lut, values)
    if mode != "dvr":
        raise VGraphError(f"reference ray caster: gradient opacity and 2D transfer functions "
                          f"classify dvr samples, not {mode}")
    return classification.classifier(sampler, lut)


def _march_dvr(sampler, classify, origins, directions, t_entry, counts, step, sampling_rate,
               early_termination, shading, shadow=(None, 1.0), sample_weights=None):
    """Front-to-back compositing of a chunk of rays in lockstep, in log space (rule 7); returns
    premultiplied RGBA and the samples taken per ray."""
    colour = np.zeros((len(origins), 3))
    log_transparency = np.zeros(len(origins))  # ln(1 - A)
    taken = np.zeros(len(origins), dtype=np.int32)
    exponent = 1.0 / sampling_rate  # step / step_ref with step_ref = min(spacing)
    active = np.flatnonzero(counts > 0)
    i = 0
    while active.size:
        points = origins[active] + (t_entry[active] + i * step)[:, None] * directions[active]
        sample = classify(points, sampler(points))
        if sample_weights is not None:  # a mask or cut-away (vgraph.masking)
            sample = np.column_stack([sample[:, :3], sample[:, 3] * sample_weights(points)])
        opacity = corrected_opacity(sample[:, 3], exponent)
        rgb = sample[:, :3]
        if shading is not None:
            rgb = shade_samples(sampler, shading, points, directions[active], rgb, opacity > 0.0)
        if shadow[0] is not None:  # rule 9; only where it adds (a shadow ray costs many samples)
            lit = opacity > 0.0
            rgb = rgb.copy()
            rgb[lit] *= (1.0 - shadow[1] * (1.0 - shadow[0](points[lit])))[:, None]
        colour[active] += (np.exp(log_transparency[active]) * opacity)[:, None] * rgb
        with np.errstate(divide="ignore"):  # an opaque sample: ln 0 = -inf, the ray stops
            log_transparency[active] += np.log1p(-opacity)
        taken[active] += 1
        i += 1
        going = -np.expm1(log_transparency[active]) < early_termination  # A < early_termination
        active = active[(i < counts[active]) & going]
    alpha = -np.expm1(log_transparency)
    return np.concatenate([colour, alpha[:, None]], axis=1), taken


def corrected_opacity(alpha: np.ndarray, exponent: float) -> np.ndarray:
    """Opacity correction ``1 - (1 - a) ** exponent`` in the stable form
    ``-expm1(exponent * log1p(-a))``: full float64 precision for opacities down to 1e-300 and up
    to 1 - 1e-16, where the plain form loses the small ones (a = 1e-9: 8e-8 relative). An exponent
    of 1 leaves alpha as it is; a = 1 stays 1."""
    if exponent == 1.0:
        return alpha
    with np.errstate(divide="ignore"):
        return -np.expm1(exponent * np.log1p(-alpha))


def _march_mip(sampler, lut, origins, directions, t_entry, counts, step, sampling_rate,
               early_termination, shading, shadow=None, sample_weights=None):
    """Maximum intensity along each ray, classified once; premultiplied RGBA (0 for misses)."""
    maximum = np.zeros(len(origins))  # intensities are clamped to [0, 1], so 0 is neutral
    active = np.flatnonzero(counts > 0)
    i = 0
    while active.size:
        points = origins[active] + (t_entry[active] + i * step)[:, None] * directions[active]
        value = np.clip(sampler(points), 0.0, 1.0)
        if sample_weights is not None:  # a mask or cut-away (vgraph.masking)
            value = value * sample_weights(points)
        maximum[active] = np.maximum(maximum[active], value)
        i += 1
        active = active[i < counts[active]]
    sample = lookup(lut, maximum)
    rgba = np.concatenate([sample[:, :3] * sample[:, 3:4], sample[:, 3:4]], axis=1)
    rgba[counts == 0] = 0.0
    return rgba, counts.astype(np.int32)


def shade_samples(sampler, shading, points, directions, rgb, visible):
    """Blinn-Phong with a two-sided headlight for the visible samples (rule 6)."""
    shaded = rgb.copy()
    if shading.gradients == "precomputed":
        grad = sampler.voxel_gradient(points[visible], shading.quantized)
    else:
        grad = sampler.gradient(points[visible])
    norm = np.linalg.norm(grad, axis=1)
    lit = norm * sampler.spacing.min() > GRADIENT_EPSILON
    cosine = np.abs(np.einsum("ij,ij->i", grad[lit], -directions[visible][lit])) / norm[lit]
    base = rgb[visible][lit]
    light = ((shading.ambient + shading.diffuse * cosine)[:, None] * base
             + (shading.specular * cosine ** shading.shininess)[:, None])
    rows = np.flatnonzero(visible)[lit]
    shaded[rows] = np.clip(light, 0.0, 1.0)
    return shaded


def shade_points(volume: Volume, shading: Shading, points, directions, rgb) -> np.ndarray:
    """(M, 3) colours ``rgb`` shaded at world ``points`` seen along ``directions`` (rule 6);
    for surfaces found elsewhere (the GL iso hits)."""
    _check_shading(shading)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    rgb = np.asarray(rgb, dtype=np.float64).reshape(-1, 3)
    return shade_samples(VolumeSampler(volume), shading, points,
                         np.asarray(directions, dtype=np.float64).reshape(-1, 3), rgb,
                         np.ones(len(points), dtype=bool))


def _check_shading(shading: Shading | None) -> None:
    if shading is not None and shading.gradients not in GRADIENT_MODES:
        raise VGraphError(f"reference ray caster: shading gradients must be one of {GRADIENT_MODES}, "
                          f"got {shading.gradients!r}")


def _check_arguments(volume, size, mode, sampling_rate, early_termination, background):
    if volume.is_spline_coefficients:
        raise VGraphError(f"reference ray caster: volume{_where(volume)} holds B-spline "
                          "coefficients, not samples")
    width, height = positive_pair(size, "reference ray caster: size", "(width, height)")
    if mode not in MODES:
        raise VGraphError(f"reference ray caster: mode must be one of {MODES}, got {mode!r}")
    if not (math.isfinite(sampling_rate) and sampling_rate > 0.0):
        raise VGraphError(f"reference ray caster: sampling_rate must be positive, got {sampling_rate}")
    if not (0.0 < early_termination <= 1.0):
        raise VGraphError("reference ray caster: early_termination must be in (0, 1], "
                          f"got {early_termination}")
    bg = np.asarray(background, dtype=np.float64)
    if bg.shape != (4,) or not np.all(np.isfinite(bg)):
        raise VGraphError(f"reference ray caster: background must be 4 finite numbers (r, g, b, a), "
                          f"got {background!r}")
    return width, height, bg


def _where(volume) -> str:
    return f" from {volume.source}" if volume.source else ""
