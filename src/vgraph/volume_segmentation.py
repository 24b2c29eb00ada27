"""What the segmentation processors (VolumeMorphology, ConnectedComponents, GradientMagnitude,
VolumeMath, VolumeMask) share: a ball in world units on the voxel grid, grids compared and one
volume sampled onto another's grid, the label volume of connected components with its sizes,
and the LabelRayCaster's label limit.

- A ball of radius r world units is, on a grid of spacing (sx, sy, sz), the ellipsoid of voxel
  offsets (di, dj, dk) with (di sx / r)^2 + (dj sy / r)^2 + (dk sz / r)^2 <= 1 (the direction
  turns it, a ball stays a ball). Its half-widths are floor(r / s) voxels per axis.
- Two grids are the same when their dims are equal and their spacing, origin and direction agree
  within GRID_TOLERANCE of the voxel size (files round what they store).
- Sampling one volume on another's grid: each voxel centre of the target grid, taken to world
  space and into the source's voxel indices (source affine^-1 @ target affine), sampled by
  scipy.ndimage (nearest or linear); within half a voxel outside the source's voxel centres the
  edge voxel holds (as the renderers' clamped textures), beyond its voxel cells 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from vgraph.errors import PropertyError, VGraphError
from vgraph.volume import Volume

GRID_TOLERANCE = 1e-5  # of the voxel size (spacing, origin) or of 1 (direction cosines)
# The LabelRayCaster resolves its label table from a texture of 256 codes a row
# (processors/label_raycaster.py, LABEL_ROW) and at most GL_MAX_TEXTURE_SIZE rows, which OpenGL 4.5
# guarantees to be at least 16384: so many distinct labels any GL 4.5 can show.
MAX_SHOWN_LABELS = 256 * 16384


class GridMismatchError(PropertyError):
    """Two volumes that must lie on one grid do not: names the processor's property that decides
    what happens then, and how the grids differ."""


def ball_offsets(radius: float, spacing) -> np.ndarray:
    """The ball of ``radius`` world units as a boolean footprint [z, y, x] on a grid of ``spacing``
    (x, y, z): an ellipsoid in voxels on an anisotropic grid (module docstring)."""
    spacing = np.asarray(spacing, dtype=np.float64)
    half = ball_half_widths(radius, spacing)
    axes = [np.arange(-h, h + 1) * s / radius for h, s in zip(half[::-1], spacing[::-1])]
    z, y, x = np.meshgrid(*axes, indexing="ij")
    return x * x + y * y + z * z <= 1.0 + 1e-9


def ball_half_widths(radius: float, spacing) -> np.ndarray:
    """Voxels (x, y, z) the ball of ``radius`` world units reaches from its centre along each axis."""
    return np.floor(radius / np.asarray(spacing, dtype=np.float64) + 1e-9).astype(int)


def check_reach(where: str, what: str, reach, volume: Volume) -> None:
    """Refuse a kernel reaching ``reach`` voxels (x, y, z) beyond the volume's voxel count along an
    axis: it would mostly see the mirrored copies beyond the faces."""
    for axis, (r, n) in enumerate(zip(reach, volume.dims)):
        if r > n:
            raise PropertyError(where, f"the {what} reaches {int(r)} voxels along {'xyz'[axis]}, more than "
                                f"the volume's {n} voxels there (spacing {volume.spacing[axis]:g}): use a "
                                f"smaller value")


def grid_difference(a: Volume, b: Volume) -> str | None:
    """How the grids of ``a`` and ``b`` differ, in words, or None when they are the same."""
    if a.dims != b.dims:
        return f"dims {_xyz(a.dims)} and {_xyz(b.dims)}"
    size = min(min(a.spacing), min(b.spacing))
    if not np.allclose(a.spacing, b.spacing, rtol=0, atol=GRID_TOLERANCE * size):
        return f"spacing {_xyz(a.spacing)} and {_xyz(b.spacing)}"
    if not np.allclose(a.origin, b.origin, rtol=0, atol=GRID_TOLERANCE * size):
        return f"origin {_xyz(a.origin)} and {_xyz(b.origin)}"
    if not np.allclose(a.direction, b.direction, rtol=0, atol=GRID_TOLERANCE):
        return f"direction {np.round(a.direction, 6).tolist()} and {np.round(b.direction, 6).tolist()}"
    return None


def _xyz(values) -> str:
    return " x ".join(f"{v:g}" for v in values)


def require_same_grid(where: str, names: tuple[str, str], a: Volume, b: Volume, remedy: str) -> None:
    """Raise GridMismatchError at ``where`` (processor.property) when ``a`` and ``b`` lie on
    different grids; ``names`` name their inports, ``remedy`` says what to do."""
    difference = grid_difference(a, b)
    if difference is not None:
        described = [f"{name}" + (f" ({v.source})" if v.source else "") for name, v in zip(names, (a, b))]
        raise GridMismatchError(where, f"{described[0]} and {described[1]} lie on different grids "
                                f"({difference}): {remedy}")


def sampled_on_grid(volume: Volume, grid: Volume, order: int) -> np.ndarray:
    """``volume``'s voxels sampled at every voxel centre of ``grid`` ([z, y, x] of grid's shape),
    by nearest (order 0) or linear (order 1) interpolation; 0 beyond its voxel cells (module
    docstring). Linear gives float32 (float64 stays)."""
    return sampled_at(volume, grid.affine, tuple(grid.dims[::-1]), order)


def sampled_at(volume: Volume, affine: np.ndarray, shape, order: int) -> np.ndarray:
    """sampled_on_grid on the grid of ``affine`` (index -> world) and ``shape`` ([z, y, x]): a
    whole grid, or a slab of one (vgraph.chunked_segmentation)."""
    to_index = np.linalg.inv(volume.affine) @ affine  # grid index (i, j, k) -> volume index
    matrix, offset = to_index[:3, :3][::-1, ::-1], to_index[:3, 3][::-1]  # in [z, y, x] order
    data = volume.data if order == 0 else volume.data.astype(np.float64 if volume.data.dtype == np.float64
                                                                    else np.float32)
    out = ndimage.affine_transform(data, matrix, offset, output_shape=tuple(shape), order=order, mode="nearest")
    index = np.indices(tuple(shape), dtype=np.float64).reshape(3, -1)
    reached = matrix @ index + offset[:, None]
    upper = np.array(volume.data.shape)[:, None] - 0.5
    outside = np.any((reached < -0.5 - 1e-9) | (reached > upper + 1e-9), axis=0).reshape(tuple(shape))
    out[outside] = 0
    return out


def checked_fill(value: float, dtype: np.dtype, where: str):
    """``value`` in ``dtype``, refused (naming ``where``) when the type cannot hold it exactly."""
    kind = np.dtype(dtype)
    if kind.kind in "iu":
        info = np.iinfo(kind)
        if value != round(value) or not info.min <= value <= info.max:
            raise PropertyError(where, f"{value:g} does not fit the volume's type {kind} "
                                f"(whole numbers {info.min} .. {info.max})")
    return kind.type(value)


def label_values(volume: Volume, who: str, data: np.ndarray | None = None) -> np.ndarray:
    """The voxels of a label volume or mask (or ``data``, a part of them): integers, or floats that
    are whole numbers; anything else is refused naming ``who``."""
    data = volume.data if data is None else data
    if data.dtype.kind in "iu":
        return data
    if not volume.holds_labels and not np.all(np.isfinite(data) & (data == np.round(data))):
        raise VGraphError(f"{who}: {volume.source or 'the volume'} holds intensities, not labels or a "
                          f"mask: make a mask or labels first (VolumeThreshold)")
    return np.nan_to_num(data, nan=0.0).astype(np.int64)


@dataclass(eq=False)
class ComponentLabels(Volume):
    """A label volume of connected components: 0 the background, 1 .. n the components from the
    largest down. ``voxel_counts[l - 1]`` is the size of label l in voxels; ``world_volumes`` the
    same in cubic world units (voxel count x the voxel's volume)."""

    voxel_counts: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def world_volumes(self) -> np.ndarray:
        return self.voxel_counts * float(np.prod(self.spacing))

    @property
    def component_count(self) -> int:
        return int(self.voxel_counts.size)


def components_by_size(labels: np.ndarray, count: int, min_voxels: float) -> tuple[np.ndarray, np.ndarray]:
    """scipy.ndimage.label's ``labels`` (1 .. count) relabelled from the largest component down
    (a tie: the one scipy numbered first), those of fewer than ``min_voxels`` voxels dropped (0):
    (the new labels in the smallest unsigned type that holds them, their voxel counts)."""
    sizes = np.bincount(labels.ravel(), minlength=count + 1)[1:]
    order = np.argsort(-sizes, kind="stable")
    kept = order[sizes[order] >= min_voxels]
    new = np.zeros(count + 1, dtype=smallest_label_type(kept.size))
    new[kept + 1] = np.arange(1, kept.size + 1)
    return new[labels], sizes[kept]


def smallest_label_type(count: int) -> np.dtype:
    for dtype in (np.uint8, np.uint16, np.uint32):
        if count <= np.iinfo(dtype).max:
            return np.dtype(dtype)
    return np.dtype(np.uint64)
