"""Masks and cut-aways: which samples a ray caster keeps besides its clip planes (issue 37; after
Voreen's and Inviwo's volume masking and 3D Slicer's "hide a region by a segmentation").

The model (the GL Mask and CutAway components, vgraph.gl.raycasting.mask, and the CPU reference
vgraph.numerics.reference_raycast both follow it): every sample gets a weight w in [0, 1], the
product of the mask's and the cut-away's; dvr multiplies the sample's TF opacity by w (before the
opacity correction), mip and xray its normalised intensity, first_hit needs opacity * w > 0. So a
sample of weight 0 adds nothing: it is skipped.

- A mask is a volume on its own grid in the patient frame (its own origin, spacing and direction).
  A voxel is IN when its value is one of ``labels`` (integer labels; a mask whose voxels are not
  whole numbers is refused by name), or, with no labels listed, when it is not 0 (a binary mask).
  ``mode`` keep: the voxels IN are kept; hide: they are hidden (a cut-away by a segmentation).
  Outside the mask's grid the value is 0. The kept indicator K (1 kept, 0 hidden) per voxel is
  what the GL texture holds (R8: 0 or 1 exactly; smoothed, steps of 1/255).
- ``boundary`` hard: w = K of the mask voxel nearest to the sample (the voxel whose cell holds it;
  outside the cells: the value 0's K). smooth: K blurred by a Gaussian of ``smoothing`` mask voxels
  (scipy.ndimage, the outside value beyond the grid) and reconstructed trilinearly (clamped to the
  outer voxel centres inside the grid): a soft edge about 1 + 2 * smoothing voxels wide.
- A cut-away region is a box (``size`` its edge lengths) or a sphere (``size`` its diameters: an
  ellipsoid where they differ) around ``center``, in world units on the world axes; samples
  inside it (boundary included) get weight 0. Subtracted from the volume, it leaves a concave
  region, which the convex clip planes of vgraph.clipping cannot.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Annotated

import numpy as np
from pydantic import AfterValidator, BeforeValidator

from vgraph.errors import PropertyError, VGraphError
from vgraph.labels import label_codes
from vgraph.properties import StringProperty
from vgraph.volume import Volume

MODES = ("keep", "hide")
BOUNDARIES = ("hard", "smooth")
SHAPES = ("none", "box", "sphere")
LEVELS = 255  # the R8 texture's steps (smoothed indicators are rounded to them, GL and CPU alike)


def parse_labels(text: str, address: str) -> tuple[int, ...]:
    """'1, 3 7' -> (1, 3, 7); '' -> () (a binary mask). PropertyError naming ``address`` otherwise."""
    try:
        return _labels_of(text)
    except ValueError as error:
        raise PropertyError(address, str(error)) from None


def _labels_of(text: str) -> tuple[int, ...]:
    words = [word for word in re.split(r"[,\s]+", text.strip()) if word]
    try:
        return tuple(sorted({int(word) for word in words}))
    except ValueError:
        raise ValueError(f"{text!r} is not a list of integer labels (e.g. '2' or '1, 3'); "
                         f"leave it empty to keep every nonzero voxel") from None


def _label_text(value):
    """A label, or a list of them, as ``--set ID.mask_labels=2`` or ``[1, 3]`` parse, as text."""
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    if isinstance(value, (list, tuple)) and all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        return ", ".join(map(str, value))
    return value


def _checked_label_text(text: str) -> str:
    _labels_of(text)
    return text


class LabelListProperty(StringProperty):
    """Integer labels as text ('2', '1, 3'; '' for none), checked when set; a number or a list of
    numbers is taken as that text. Edited as a string."""

    def _value_type(self):
        return Annotated[str, BeforeValidator(_label_text), AfterValidator(_checked_label_text)]


@dataclass(frozen=True)
class MaskSelection:
    """Which mask voxels are kept and how the boundary is drawn (module docstring)."""

    labels: tuple[int, ...] = ()
    mode: str = "keep"
    boundary: str = "hard"
    smoothing: float = 0.0

    def outside(self) -> float:
        """K beyond the mask's grid, where the value is 0."""
        inside = bool(self.labels) and 0 in self.labels
        return float(inside if self.mode == "keep" else not inside)


def kept_indicator(mask: Volume, selection: MaskSelection, consumer: str) -> np.ndarray:
    """The kept indicator K per mask voxel as uint8 [z, y, x]: 0 or 255 (hard), the blurred
    indicator in steps of 1/255 (smooth). VGraphError naming ``consumer`` for labels asked of a
    mask without whole-number values, or for listed labels the mask does not hold."""
    mask.require_samples(consumer)
    data = np.asarray(mask.data)
    if selection.labels:
        codes = label_codes(data, consumer)
        wanted = np.asarray(selection.labels, dtype=np.int64)
        held = codes.values[np.bincount(codes.codes.ravel(), minlength=codes.values.size) > 0].tolist()
        missing = sorted(set(selection.labels) - set(held))
        if missing:
            shown = ", ".join(map(str, held[:12])) + (" ..." if len(held) > 12 else "")
            raise VGraphError(f"{consumer}: the mask holds no voxel of label {', '.join(map(str, missing))} "
                              f"(it holds {shown})")
        inside = np.isin(codes.values, wanted)[codes.codes]
    else:
        inside = data != 0
    kept = inside if selection.mode == "keep" else ~inside
    if selection.boundary == "hard" or selection.smoothing <= 0.0:
        return kept.astype(np.uint8) * np.uint8(LEVELS)
    from scipy import ndimage  # only for smoothed masks
    blurred = ndimage.gaussian_filter(kept.astype(np.float32), selection.smoothing, mode="constant",
                                      cval=selection.outside())
    return np.rint(np.clip(blurred, 0.0, 1.0) * LEVELS).astype(np.uint8)


def world_to_mask_texture(mask: Volume) -> np.ndarray:
    """4x4 float64: world points -> the mask's texture coordinates ((index + 0.5) / dims)."""
    dims = np.asarray(mask.dims, dtype=np.float64)
    to_texture = np.diag([*(1.0 / dims), 1.0])
    to_texture[:3, 3] = 0.5 / dims
    return to_texture @ np.linalg.inv(mask.affine)


def check_overlap(mask: Volume, volume: Volume, consumer: str) -> None:
    """VGraphError naming ``consumer`` when the mask's box and the volume's do not meet: the mask
    would hide (keep) everything, a blank or unchanged image that says nothing."""
    low, high = mask.world_box()
    vlow, vhigh = volume.world_box()
    slack = 0.5 * (np.asarray(mask.spacing).max() + np.asarray(volume.spacing).max())
    if np.any(low > vhigh + slack) or np.any(high < vlow - slack):
        raise VGraphError(f"{consumer}: the mask ({mask.source or 'its grid'}, world box "
                          f"{np.round(low, 4).tolist()} .. {np.round(high, 4).tolist()}) does not overlap "
                          f"the volume ({np.round(vlow, 4).tolist()} .. {np.round(vhigh, 4).tolist()}); "
                          f"masks are placed by their own origin, spacing and direction in the patient frame")


@dataclass(frozen=True)
class CutAwayRegion:
    """A box or sphere subtracted from the rendering (module docstring); shape 'none': nothing."""

    shape: str = "none"
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def checked(self, address: str) -> "CutAwayRegion":
        if self.shape != "none" and min(self.size) <= 0.0:
            raise PropertyError(address, f"the cut-away {self.shape} needs sizes > 0, got {list(self.size)}")
        return self

    def world_to_region(self) -> np.ndarray:
        """4x4: world points -> region coordinates q, inside where max |q| <= 1 (box) or |q| <= 1
        (sphere)."""
        half = np.asarray(self.size, dtype=np.float64) / 2.0
        matrix = np.diag([*(1.0 / half), 1.0])
        matrix[:3, 3] = -np.asarray(self.center, dtype=np.float64) / half
        return matrix

    def weights(self, points: np.ndarray) -> np.ndarray:
        """(M,) 0 inside the region, 1 outside, at (M, 3) world points."""
        if self.shape == "none":
            return np.ones(len(points))
        q = (points - np.asarray(self.center)) / (np.asarray(self.size, dtype=np.float64) / 2.0)
        inside = np.abs(q).max(axis=1) <= 1.0 if self.shape == "box" else (q * q).sum(axis=1) <= 1.0
        return np.where(inside, 0.0, 1.0)


class MaskWeights:
    """The CPU reference's sample weights (module docstring): ``weights(points)`` at (M, 3) world
    points, the mask's times the cut-away's."""

    def __init__(self, mask: Volume | None = None, selection: MaskSelection = MaskSelection(),
                 cutaway: CutAwayRegion = CutAwayRegion(), consumer: str = "mask"):
        self.mask, self.selection, self.cutaway = mask, selection, cutaway
        if mask is not None:
            self.table = kept_indicator(mask, selection, consumer).ravel().astype(np.float64) / LEVELS
            self.dims = np.asarray(mask.dims)
            self.outside = selection.outside()

    def __call__(self, points: np.ndarray) -> np.ndarray:
        weights = self.cutaway.weights(points)
        if self.mask is not None:
            weights = weights * self._mask_weights(points)
        return weights

    def _mask_weights(self, points: np.ndarray) -> np.ndarray:
        u = self.mask.world_to_voxel(points)
        inside = np.all((u >= -0.5) & (u < self.dims - 0.5), axis=1)
        nx, ny = self.dims[0], self.dims[1]
        if self.selection.boundary == "hard":
            index = np.clip(np.floor(u + 0.5).astype(np.int64), 0, self.dims - 1)
            values = self.table[(index[:, 2] * ny + index[:, 1]) * nx + index[:, 0]]
        else:
            values = _trilinear(self.table, self.dims, u)
        return np.where(inside, values, self.outside)


def _trilinear(table: np.ndarray, dims: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Per-voxel ``table`` ([z, y, x] order, x fastest) at voxel coordinates u, clamped to the voxel
    centres (GL's clamp-to-edge)."""
    u = np.clip(u, 0.0, dims - 1)
    base = np.minimum(np.floor(u).astype(np.int64), np.maximum(dims - 2, 0))
    frac = u - base
    top = np.minimum(base + 1, dims - 1)
    nx, ny = dims[0], dims[1]
    result = np.zeros(len(u))
    for corner in range(8):
        pick = [(corner >> axis) & 1 for axis in range(3)]
        index = np.where(pick, top, base)
        weight = np.prod(np.where(pick, frac, 1.0 - frac), axis=1)
        result += weight * table[(index[:, 2] * ny + index[:, 1]) * nx + index[:, 0]]
    return result
