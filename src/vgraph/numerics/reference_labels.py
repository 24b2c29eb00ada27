"""CPU reference of the LabelRayCaster (processors/label_raycaster.py), in numpy, float64.

It takes the rays from the EntryExitPoints images (rgb = texture coordinates, alpha = hit), as the
shader does, and follows the same rules: sample i at entry + i * step, step = min(spacing) /
sampling_rate world units, samples = floor(length / step + 1e-3) + 1 (raycasting/ray.glsl); the
label of each sample by the majority of interpolation weights (vgraph.labels.majority); composite
(front to back, opacity corrected to 1 - (1 - a)^(1 / sampling_rate), early termination; in log
space as numerics.reference_raycast's rule 7) or
first_hit (the first shown label, opaque, its hit refined by halvings of the step); optional
Blinn-Phong with a headlight (numerics.reference_raycast's model) and the majority rule's normal;
the result over the background. Rays are marched CHUNK_RAYS at a time (bounded memory).

It works in the texture coordinates of ``volume`` along its own index axes, so ``volume`` must be
the one the entry points are of: for an oriented volume (Volume.direction) the copy the ray
casters draw, on its axes reordered and mirrored (vgraph.gl.raycasting.framed_view.volume_in_frame).
Lengths, steps and the headlight's angles are the same along those axes as in the world (they are
turned and mirrored alike), so nothing else changes.
"""

from __future__ import annotations

import numpy as np

from vgraph.labels import BACKGROUND, LabelTable, label_codes, majority
from vgraph.numerics.reference_raycast import GRADIENT_EPSILON, corrected_opacity
from vgraph.volume import Volume

CHUNK_RAYS = 65536  # rays marched together, at most (bounded memory)
HIT_REFINEMENT = 6  # halvings of the first hit's step (shaders/labels/compositing_first_hit.glsl)


def render_labels(volume: Volume, table: LabelTable, entry: np.ndarray, exit: np.ndarray, *,
                  mode: str = "composite", sampling_rate: float = 1.0, early_termination: float = 0.99,
                  background=(0.0, 0.0, 0.0, 1.0), shading: dict | None = None,
                  sample_weights=None) -> np.ndarray:
    """The picture (H, W, 4) from entry and exit images (H, W, 4) as Image.to_numpy() gives them.
    ``shading``: None, or {"ambient", "diffuse", "specular", "shininess"} of a headlight.
    ``sample_weights``: None, or weights (a mask, a cut-away: vgraph.masking) at (M, 3) points in
    the volume's texture coordinates: composite multiplies the label's opacity by them, first_hit
    takes no hit below 1/2 and does not refine a hit after such a sample."""
    codes = label_codes(volume.data, "reference")
    classes = codes.classes(table)[codes.codes.astype(np.int64)]
    colors = table.colors(codes.values).astype(np.float64)
    spacing = np.asarray(volume.spacing, dtype=np.float64)
    dims = np.array(volume.dims, dtype=np.float64)
    hit = (entry[..., 3] != 0.0) & (exit[..., 3] != 0.0)
    start, end = entry[hit][:, :3].astype(np.float64), exit[hit][:, :3].astype(np.float64)
    along = end - start
    length = np.linalg.norm(along * dims * spacing, axis=1)
    step_length = spacing.min() / sampling_rate
    samples = np.floor(length / step_length + 1e-3).astype(np.int64) + 1
    step = np.where(length[:, None] > 0.0, along * (step_length / np.maximum(length, 1e-300))[:, None], 0.0)
    direction = along * dims * spacing / np.maximum(length, 1e-300)[:, None]
    total = np.zeros((len(start), 4))
    march = dict(classes=classes, colors=colors, spacing=spacing, mode=mode, exponent=1.0 / sampling_rate,
                 early_termination=early_termination, shading=shading, weights=sample_weights)
    for first in range(0, len(start), CHUNK_RAYS):  # bounded memory, whatever the image size
        rays = slice(first, first + CHUNK_RAYS)
        total[rays] = _march(start[rays], step[rays], direction[rays], samples[rays], **march)
    picture = np.zeros(entry.shape[:2] + (4,))
    picture[hit] = total
    bg = np.asarray(background, dtype=np.float64)
    return np.concatenate([picture[..., :3] + (1.0 - picture[..., 3:]) * bg[:3],
                           picture[..., 3:] + (1.0 - picture[..., 3:]) * bg[3]], axis=-1)


def _march(start, step, direction, samples, *, classes, colors, spacing, mode, exponent,
           early_termination, shading, weights=None):
    """Premultiplied RGBA of rays from ``start`` by ``step`` (texture coordinates) for ``samples``
    samples each, composited in log space or to the first hit."""
    total = np.zeros((len(start), 4))
    active = np.ones(len(start), dtype=bool)
    log_transparency = np.zeros(len(start))  # ln(1 - A), composite in log space
    for i in range(int(samples.max(initial=0))):
        rays = np.flatnonzero(active & (i < samples))
        if rays.size == 0:
            break
        winner, _, normal = majority(classes, start[rays] + i * step[rays])
        kept = np.ones(len(rays)) if weights is None else weights(start[rays] + i * step[rays])
        shown = (winner != BACKGROUND) & (kept >= 0.5 if mode == "first_hit" else kept > 0.0)
        rays, winner, normal, kept = rays[shown], winner[shown], normal[shown], kept[shown]
        if mode == "first_hit" and i > 0:
            refine = np.ones(len(rays), dtype=bool) if weights is None \
                else weights(start[rays] + (i - 1) * step[rays]) >= 0.5
            refined = _refined_hit(classes, start[rays[refine]], step[rays[refine]], i, winner[refine],
                                   normal[refine])
            winner[refine], normal[refine] = refined
        rgb = colors[winner, :3]
        if shading is not None:
            rgb = _headlight(rgb, normal / spacing, direction[rays], shading, spacing.min())
        if mode == "first_hit":
            total[rays] = np.concatenate([rgb, np.ones((len(rays), 1))], axis=1)
            active[rays] = False
            continue
        alpha = corrected_opacity(colors[winner, 3] * kept, exponent)
        total[rays, :3] += (np.exp(log_transparency[rays]) * alpha)[:, None] * rgb
        with np.errstate(divide="ignore"):  # an opaque label: ln 0 = -inf
            log_transparency[rays] += np.log1p(-alpha)
        total[rays, 3] = -np.expm1(log_transparency[rays])
        active[rays[total[rays, 3] >= early_termination]] = False
    return total


def _refined_hit(classes, start, step, i, winner, normal):
    """compositing_first_hit.glsl: HIT_REFINEMENT halvings of [i - 1, i] towards where the majority
    turns to a shown label; the label and normal at the last shown point."""
    outside, inside = np.full(len(start), i - 1.0), np.full(len(start), float(i))
    for _ in range(HIT_REFINEMENT):
        middle = 0.5 * (outside + inside)
        here, _, here_normal = majority(classes, start + middle[:, None] * step)
        shown = here != BACKGROUND
        inside = np.where(shown, middle, inside)
        outside = np.where(shown, outside, middle)
        winner = np.where(shown, here, winner)
        normal = np.where(shown[:, None], here_normal, normal)
    return winner, normal


def _headlight(rgb, gradient, direction, shading, min_spacing):
    """raycasting/shading.glsl with LIGHT_HEADLIGHT: L = V = H = the viewer, two-sided."""
    norm = np.linalg.norm(gradient, axis=1)
    lit = norm > GRADIENT_EPSILON / min_spacing
    lambert = np.abs((gradient * direction).sum(axis=1)) / np.where(lit, norm, 1.0)
    gloss = np.where(lambert > 0.0, lambert ** shading["shininess"], 0.0)
    shaded = np.clip((shading["ambient"] + shading["diffuse"] * lambert)[:, None] * rgb
                     + shading["specular"] * gloss[:, None], 0.0, 1.0)
    return np.where(lit[:, None], shaded, rgb)
