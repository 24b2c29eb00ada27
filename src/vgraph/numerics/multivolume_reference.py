"""CPU reference of the MultiVolumeRayCaster (numpy, vectorised over rays): several volumes
(channels), each with its own transfer function, sampled at the same world points of each ray and
blended. Tests compare the GL images with it pixel by pixel.

Model (rules of vgraph.numerics.reference_raycast unless said otherwise; arithmetic in float64):

1. Rays: ``Camera.rays`` of the camera resolved on the UNION of the channels' boxes of voxel
   centres (EntryExitPoints fed with all channels; channels turned against the world alike, up to
   the order and sign of their axes, are united in the first one's turned coordinates:
   vgraph.numerics.reference_boxes), clipped to that box (slab test, grown by
   ``1e-5 * (max |corner| + min spacing of all channels)``; narrowed by ``crop_box``), to
   [near, far] and to the kept side of ``clip_planes`` (vgraph.clipping, as EntryExitPoints cuts
   them). A ray with nothing left is the background. One channel: its own box, as before.
2. Samples: ``step = min over channels of min(spacing) / sampling_rate``; sample i at
   ``t_entry + i * step``, ``n = floor(length / step + 1e-3) + 1`` (the RayCaster's rule).
3. Channel k at a world point p: inside its box of voxel centres (along its own index axes)
   grown by ``1e-5 * (max |corner| + min spacing)`` (the GL rays' box rule), its trilinear
   normalised intensity (clamp-to-edge) is classified by its TF's 4096-entry LUT, linear between
   entries: ``(rgb_k, a_k)``. Outside its box the channel is absent (contributes nothing). Every
   channel is tested, the first too (the union rays leave its box), except a lone channel: its
   rays are its own box.
4. ``accumulate``: ``a'_k = 1 - (1 - a_k) ** (step / min(spacing_k))``; per sample
   ``alpha = 1 - prod(1 - a'_k)``, ``rgb = sum(a'_k rgb_k) / sum(a'_k)`` (over channels present
   with a'_k > 0; none: alpha 0); front to back ``C += (1 - A) alpha rgb``, ``A += (1 - A) alpha``,
   the ray stopping before a sample once ``A >= early_termination``. In log space as
   reference_raycast's rule 7: ``a'_k = -expm1(e_k log1p(-a_k))`` (a_k itself where e_k = 1),
   ``ln(1 - alpha) = sum log1p(-a'_k)``, the ray keeps ``ln(1 - A)``.
5. ``nearest_opaque``: the first sample where some present channel has ``a_k >= threshold`` (and
   a_k > 0); among those the largest a_k, ties to the lower channel; ``C = rgb_k``, ``A = 1``.
6. ``maximum``: ``m_k`` = max of ``clip(v_k, 0, 1)`` over the samples where channel k is present
   (starting from 0); ``(rgb_k, a_k) = TF_k(m_k)`` for the channels present at some sample;
   ``C = min(sum a_k rgb_k, 1)``, ``A = 1 - prod(1 - a_k)``.
7. Shading (``shading=Shading()``, accumulate and nearest_opaque): reference_raycast's rule 6
   (Blinn-Phong, headlight, central differences one voxel of the channel away, per world unit;
   unshaded where ``|g| * min(spacing_k) <= 1e-6``) applied to each channel's colour with its own
   gradient, before the mix (accumulate: channels with a'_k > 0) or at the hit (nearest_opaque).
8. Pixel: ``rgb = C + (1 - A) bg.rgb``, ``alpha = A + (1 - A) bg.a``; float32 (H, W, 4), row 0 at
   the top.
9. Memory: the rays are marched ``chunk_rays`` at a time (reference_raycast's rule 9).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.camera import Camera
from vgraph.clipping import clip_intervals
from vgraph.errors import VGraphError
from vgraph.numerics.reference_boxes import RayBox, inside_grown_box, turned_alike
from vgraph.numerics.reference_raycast import (Shading, VolumeSampler, corrected_opacity, lookup,
                                              sample_counts, shade_samples)
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

BLENDS = ("accumulate", "nearest_opaque", "maximum")
MAX_CHANNELS = 4
CHANNEL_BOX_EPSILON = 1e-5  # relative growth of a channel's box (rule 3; the GL rays' box rule)


@dataclass
class _Channel:
    """A channel made ready for sampling: volume, sampler, LUT, reference step."""

    volume: Volume
    sampler: VolumeSampler
    lut: np.ndarray
    min_spacing: float

    @classmethod
    def of(cls, volume: Volume, transfer_function: TransferFunction) -> "_Channel":
        lut = transfer_function.for_volume(volume).lut().astype(np.float64)
        return cls(volume, VolumeSampler(volume), lut, float(min(volume.spacing)))

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Rule 3's grown box of voxel centres, along the volume's own axes."""
        return inside_grown_box(self.volume, points, CHANNEL_BOX_EPSILON)


def render_channels(channels, camera: Camera, size, *, blend: str = "accumulate",
                    sampling_rate: float = 1.0, early_termination: float = 0.99,
                    opacity_threshold: float = 0.5, background=(0.0, 0.0, 0.0, 1.0),
                    shading: Shading | None = None, clip_planes=(), crop_box=None,
                    chunk_rays: int = 65536, sample_weights=None) -> np.ndarray:
    """Render ``channels``, a list of (Volume, TransferFunction), the rays spanning the union of
    their boxes, as the MultiVolumeRayCaster does (model in the module docstring). ``size`` is (width, height);
    ``clip_planes`` and ``crop_box`` are those of the EntryExitPoints. ``sample_weights``
    (vgraph.masking.MaskWeights) weighs each channel's TF opacity (accumulate, nearest_opaque) or
    intensity (maximum) at the sample's world point."""
    if not 1 <= len(channels) <= MAX_CHANNELS:
        raise VGraphError(f"multivolume reference: 1 to {MAX_CHANNELS} channels, got {len(channels)}")
    if blend not in BLENDS:
        raise VGraphError(f"multivolume reference: blend must be one of {BLENDS}, got {blend!r}")
    _check_turned_alike([volume for volume, _ in channels])
    width, height = (int(v) for v in size)
    union = RayBox.of([volume for volume, _ in channels])
    camera = camera.resolved(*union.framing(), width / height)
    origins, directions = (a.reshape(-1, 3) for a in camera.rays(width, height))
    t_entry, t_exit = union.clip(origins, directions, camera.far_distance(directions),
                                 min(min(volume.spacing) for volume, _ in channels), crop_box)
    t_entry, t_exit = clip_intervals(origins, directions, t_entry, t_exit, clip_planes)
    ready = [_Channel.of(volume, tf) for volume, tf in channels]
    step = min(c.min_spacing for c in ready) / sampling_rate
    counts = sample_counts(t_entry, t_exit, step)
    march = {"accumulate": _accumulate, "nearest_opaque": _nearest_opaque, "maximum": _maximum}[blend]
    rgba = np.empty((len(origins), 4))
    for start in range(0, len(origins), chunk_rays):  # rule 9: bounded memory
        rays = slice(start, start + chunk_rays)
        rgba[rays] = march(ready, origins[rays], directions[rays], t_entry[rays], counts[rays], step,
                           early_termination=early_termination, threshold=opacity_threshold,
                           shading=shading, weights=sample_weights)
    bg = np.asarray(background, dtype=np.float64)
    coverage = rgba[:, 3:4]
    image = np.concatenate([rgba[:, :3] + (1.0 - coverage) * bg[:3], coverage + (1.0 - coverage) * bg[3]],
                           axis=1)
    return image.reshape(height, width, 4).astype(np.float32)


def _check_turned_alike(volumes) -> None:
    """Refuse channels whose axes are turned against the first one's by more than their order and
    sign (rule 1): no box holds both."""
    first = np.asarray(volumes[0].direction)
    for number, volume in enumerate(volumes[1:], start=2):
        if not turned_alike(volume.direction, first):
            raise VGraphError(f"multivolume reference: channel {number}'s axes are turned against "
                              f"channel 1's (directions {np.round(volume.direction, 6).tolist()} and "
                              f"{np.round(first, 6).tolist()}); resample one onto the other's grid")


def _classified(channel: _Channel, points: np.ndarray, alone: bool, weights=None):
    """(RGBA per point, present per point) of one channel (rule 3); opacities times ``weights``
    (a mask or cut-away: vgraph.masking) where given."""
    present = np.ones(len(points), dtype=bool) if alone else channel.inside(points)
    rgba = np.zeros((len(points), 4))
    rgba[present] = lookup(channel.lut, channel.sampler(points[present]))
    if weights is not None:
        rgba[:, 3] *= weights
    return rgba, present


def _weights_at(weights, points):
    return None if weights is None else weights(points)


def _points(origins, directions, t_entry, rays, i, step):
    return origins[rays] + (t_entry[rays] + i * step)[:, None] * directions[rays]


def _accumulate(channels, origins, directions, t_entry, counts, step, *, early_termination, shading, weights,
                **_):
    """Rule 4 in log space (reference_raycast's rule 7): ln(1 - alpha) of a sample is the sum of
    its channels' log1p(-a'_k), the ray keeps ln(1 - A)."""
    colour = np.zeros((len(origins), 3))
    log_transparency = np.zeros(len(origins))  # ln(1 - A)
    active = np.flatnonzero(counts > 0)
    i = 0
    while active.size:
        points = _points(origins, directions, t_entry, active, i, step)
        log_sample = np.zeros(len(active))  # ln(1 - alpha) of the sample
        weight = np.zeros(len(active))
        weighted = np.zeros((len(active), 3))
        kept = _weights_at(weights, points)
        for k, channel in enumerate(channels):
            rgba, _ = _classified(channel, points, len(channels) == 1, kept)
            corrected = corrected_opacity(rgba[:, 3], step / channel.min_spacing)  # 0 stays 0
            if shading is not None:
                rgba[:, :3] = shade_samples(channel.sampler, shading, points, directions[active],
                                            rgba[:, :3], corrected > 0.0)
            with np.errstate(divide="ignore"):  # an opaque channel: ln 0 = -inf
                log_sample += np.log1p(-corrected)
            weight += corrected
            weighted += corrected[:, None] * rgba[:, :3]
        sample_alpha = np.where(weight > 0.0, -np.expm1(log_sample), 0.0)
        sample_rgb = weighted / np.where(weight > 0.0, weight, 1.0)[:, None]
        colour[active] += (np.exp(log_transparency[active]) * sample_alpha)[:, None] * sample_rgb
        log_transparency[active] += log_sample
        i += 1
        going = -np.expm1(log_transparency[active]) < early_termination  # A < early_termination
        active = active[(i < counts[active]) & going]
    return np.concatenate([colour, -np.expm1(log_transparency)[:, None]], axis=1)


def _nearest_opaque(channels, origins, directions, t_entry, counts, step, *, threshold, shading, weights, **_):
    rgba = np.zeros((len(origins), 4))
    active = np.flatnonzero(counts > 0)
    i = 0
    while active.size:
        points = _points(origins, directions, t_entry, active, i, step)
        hit = np.zeros((len(active), 4))
        kept = _weights_at(weights, points)
        for k, channel in enumerate(channels):
            sample, present = _classified(channel, points, len(channels) == 1, kept)
            better = present & (sample[:, 3] >= threshold) & (sample[:, 3] > hit[:, 3])
            if shading is not None:
                sample[:, :3] = shade_samples(channel.sampler, shading, points, directions[active],
                                              sample[:, :3], better)
            hit[better] = sample[better]
        found = hit[:, 3] > 0.0
        rgba[active[found], :3] = hit[found, :3]
        rgba[active[found], 3] = 1.0
        i += 1
        active = active[~found]
        active = active[i < counts[active]]
    return rgba


def _maximum(channels, origins, directions, t_entry, counts, step, *, weights, **_):
    maxima = np.zeros((len(channels), len(origins)))
    met = np.zeros((len(channels), len(origins)), dtype=bool)
    active = np.flatnonzero(counts > 0)
    i = 0
    while active.size:
        points = _points(origins, directions, t_entry, active, i, step)
        kept = _weights_at(weights, points)
        for k, channel in enumerate(channels):
            present = np.ones(len(points), dtype=bool) if len(channels) == 1 else channel.inside(points)
            rows = active[present]
            values = np.clip(channel.sampler(points[present]), 0.0, 1.0)
            if kept is not None:
                values = values * kept[present]
            maxima[k, rows] = np.maximum(maxima[k, rows], values)
            met[k, rows] = True
        i += 1
        active = active[i < counts[active]]
    colour = np.zeros((len(origins), 3))
    transparency = np.ones(len(origins))
    for k, channel in enumerate(channels):
        sample = lookup(channel.lut, maxima[k])
        sample[~met[k]] = 0.0
        colour += sample[:, 3:4] * sample[:, :3]
        transparency *= 1.0 - sample[:, 3]
    return np.concatenate([np.minimum(colour, 1.0), (1.0 - transparency)[:, None]], axis=1)
