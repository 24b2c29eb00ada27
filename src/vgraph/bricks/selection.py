"""Which bricks a frame of the bricked ray caster draws, at which level, in which order.

Conventions (docs/bricked_raycaster.md):
- The pyramid is an octree: brick b of level L covers level-0 voxels [b * B * 2^L, (b + 1) * B *
  2^L) per axis (B the brick size), exactly its children at level L - 1. The selection walks it
  from the coarsest level down, so the chosen bricks tile the volume whatever their levels.
- A brick *owns* the samples whose level-0 texture coordinate t lies in [j_lo / n, j_hi / n) per
  axis (j the level-0 voxel bounds above, n the level-0 voxels): half-open, so each sample of the
  global lattice lies in exactly one brick; the volume's outer faces are pushed to +-OUTSIDE so
  samples on (or a rounding beyond) the box still have an owner.
- Level per brick: a level-0 voxel (the smallest spacing) projects to p pixels at the brick's
  nearest point; the brick wants level floor(-log2(p) + lod_bias) (voxels of about a pixel at
  lod_bias 0), clamped to the pyramid and to at least ``floor_level``; ``plan_frame`` raises
  floor_level until the frame fits the budget.
- Empty bricks: the per-brick ranges of the brick's level (``brick_ranges``), widened to the 3^3
  neighbouring bricks (a sample inside a brick filters voxels up to one voxel outside it),
  normalised by the value range: dvr drops bricks whose whole range has no LUT opacity
  (empty_space.occupied_blocks, the RayCaster's skipping rule), iso those whose maximum is below the
  level, mip those whose maximum is <= 0.
- Order: front to back, the grid's sweep order (tetrahedra.cells.axis_order, reversed) at the top
  and for each brick's children, valid for orthographic and perspective cameras.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from vgraph.bricks.cache import brick_bytes, usable_range
from vgraph.bricks.pyramid import BrickSource, brick_grid
from vgraph.gl.raycasting.empty_space import occupied_blocks
from vgraph.gl.tetrahedra.cells import axis_order

OUTSIDE = 1e6  # texture coordinate of the volume's outer faces in the ownership test


@dataclass
class FramePlan:
    bricks: list = field(default_factory=list)  # (key, (x, y, w, h) scissor rect), front to back
    floor_level: int = 0                        # the finest level the budget allowed
    bytes: int = 0                              # the frame's bricks with halo


class BrickGeometry:
    """Where a source's bricks are: level-0 voxel bounds, world boxes and ownership bounds."""

    def __init__(self, source: BrickSource):
        base = source.levels[0]
        self.source = source
        self.dims0 = np.asarray(base.shape[::-1], dtype=np.float64)      # (x, y, z)
        self.spacing0 = np.asarray(base.spacing, dtype=np.float64)
        self.origin0 = np.asarray(base.origin, dtype=np.float64)
        self.brick = np.asarray(source.brick, dtype=np.float64)          # (x, y, z)
        self.grids = [np.asarray(brick_grid(level.shape, source.brick)[::-1]) for level in source.levels]

    def voxel_bounds(self, key) -> tuple[np.ndarray, np.ndarray]:
        """Level-0 voxel bounds [lo, hi) (x, y, z) of a brick, hi clipped to the volume."""
        level, index = key[0], np.asarray(key[1:][::-1], dtype=np.float64)
        span = self.brick * 2.0 ** level
        return index * span, np.minimum((index + 1) * span, self.dims0)

    def owner_bounds(self, key) -> tuple[np.ndarray, np.ndarray]:
        """Texture-space bounds [lo, hi) of the samples the brick owns (see the module docstring)."""
        lo, hi = self.voxel_bounds(key)
        index = np.asarray(key[1:][::-1])
        t_lo = np.where(index == 0, -OUTSIDE, lo / self.dims0)
        t_hi = np.where(index == self.grids[key[0]] - 1, OUTSIDE, hi / self.dims0)
        return t_lo, t_hi

    def world_box(self, key) -> tuple[np.ndarray, np.ndarray]:
        """World box of the brick's owned region inside the volume box (voxel centres')."""
        lo, hi = self.voxel_bounds(key)
        top = self.dims0 - 1.0
        lo, hi = np.clip(lo - 0.5, 0.0, top), np.clip(hi - 0.5, 0.0, top)
        return self.origin0 + lo * self.spacing0, self.origin0 + hi * self.spacing0

    def eye_in_bricks(self, eye, level: int) -> np.ndarray:
        """The eye's position in brick units of ``level`` (x, y, z)."""
        return ((np.asarray(eye) - self.origin0) / self.spacing0 + 0.5) / (self.brick * 2.0 ** level)


# --- emptiness ------------------------------------------------------------------------------------
def normalised_ranges(source: BrickSource, level: int, value_range=None) -> tuple[np.ndarray, np.ndarray]:
    """Per-brick [z, y, x] min and max of normalised intensity over each brick and its neighbours;
    a brick without finite voxels counts as 0 (non-finite voxels are uploaded clamped)."""
    low, high = source.brick_ranges(level)
    lo, hi = usable_range(value_range if value_range is not None else source.value_range)
    low = np.where(np.isfinite(low), (low - lo) / (hi - lo), 0.0)
    high = np.where(np.isfinite(high), (high - lo) / (hi - lo), 0.0)
    return (ndimage.minimum_filter(low, size=3, mode="nearest"),
            ndimage.maximum_filter(high, size=3, mode="nearest"))


def visible_bricks(source: BrickSource, level: int, mode: str, alpha=None, iso_level: float = 0.5,
                   value_range=None) -> np.ndarray:
    """Bool per brick [z, y, x] of ``level``: whether it can contribute in ``mode``."""
    low, high = normalised_ranges(source, level, value_range)
    if mode == "dvr":
        return occupied_blocks(low, high, alpha)
    if mode == "iso":
        return high >= iso_level
    return high > 0.0  # mip: intensities are clamped to [0, 1]; 0 adds nothing to the maximum


# --- level of detail --------------------------------------------------------------------------------
def pixels_per_world(camera, size, distance: float) -> float:
    """Pixels per world unit at ``distance`` from the eye (along the view)."""
    if camera.projection == "orthographic":
        return size[1] / (2.0 * camera.parallel_scale)
    return size[1] / (2.0 * max(distance, 1e-12) * math.tan(math.radians(camera.fov) / 2.0))


def desired_level(geometry: BrickGeometry, camera, size, key, lod_bias: float) -> int:
    lo, hi = geometry.world_box(key)
    eye = np.asarray(camera.position, dtype=np.float64)
    distance = float(np.linalg.norm(np.maximum(np.maximum(lo - eye, eye - hi), 0.0)))
    pixels = float(geometry.spacing0.min()) * pixels_per_world(camera, size, distance)
    return int(math.floor(-math.log2(max(pixels, 1e-30)) + lod_bias))


# --- culling ---------------------------------------------------------------------------------------
def screen_rect(geometry: BrickGeometry, view_projection: np.ndarray, size, key):
    """Pixel rectangle (x, y, w, h) covering the brick (one pixel of margin), None if off screen;
    the whole viewport when a corner lies behind the eye."""
    lo, hi = geometry.world_box(key)
    corners = np.array([[(lo, hi)[i >> a & 1][a] for a in range(3)] + [1.0] for i in range(8)])
    clip = corners @ np.asarray(view_projection, dtype=np.float64).T
    if (clip[:, 3] <= 1e-9).any():
        return (0, 0, int(size[0]), int(size[1]))
    ndc = clip[:, :2] / clip[:, 3:4]
    pixel = (ndc * 0.5 + 0.5) * np.asarray(size, dtype=np.float64)
    x0, y0 = np.maximum(np.floor(pixel.min(axis=0)) - 1, 0).astype(int)
    x1, y1 = np.minimum(np.ceil(pixel.max(axis=0)) + 1, size).astype(int)
    return (int(x0), int(y0), int(x1 - x0), int(y1 - y0)) if x1 > x0 and y1 > y0 else None


# --- the walk ----------------------------------------------------------------------------------------
def front_to_back(counts, eye, forward, perspective: bool, offset=(0, 0, 0)):
    """Cells of a [x, y, z] block of ``counts`` starting at ``offset``, front to back, as (x, y, z)
    indices; ``eye`` in cell units."""
    axes = [axis_order(int(n), float(eye[a] - offset[a]) if perspective else None, float(forward[a]))[::-1] + offset[a]
            for a, n in enumerate(counts)]
    return [(int(x), int(y), int(z)) for z in axes[2] for y in axes[1] for x in axes[0]]


def select_bricks(source: BrickSource, camera, size, view_projection, visible, lod_bias: float,
                  floor_level: int = 0, geometry: BrickGeometry | None = None) -> list:
    """(key, rect) of the bricks to draw, front to back (see the module docstring). ``visible(level)``
    is the bool [z, y, x] array of bricks that can contribute at that level."""
    geometry = geometry or BrickGeometry(source)
    top = len(source.levels) - 1
    perspective = camera.projection == "perspective"
    forward = camera.basis()[2]
    masks: dict[int, np.ndarray] = {}
    chosen: list = []

    def walk(level: int, cells):
        eye = geometry.eye_in_bricks(camera.position, level)
        for x, y, z in cells:
            key = (level, z, y, x)
            rect = screen_rect(geometry, view_projection, size, key)
            if rect is None:
                continue
            want = min(max(desired_level(geometry, camera, size, key, lod_bias), floor_level, 0), top)
            if level > want:
                grid = geometry.grids[level - 1]
                first = np.array([x, y, z]) * 2
                counts = np.minimum(first + 2, grid) - first
                walk(level - 1, front_to_back(counts, eye * 2, forward, perspective, first))
                continue
            if level not in masks:
                masks[level] = visible(level)
            if masks[level][z, y, x]:
                chosen.append((key, rect))

    eye_top = geometry.eye_in_bricks(camera.position, top)
    walk(top, front_to_back(geometry.grids[top], eye_top, forward, perspective))
    return chosen


def plan_frame(source: BrickSource, camera, size, view_projection, visible, lod_bias: float,
               budget_bytes: int) -> FramePlan:
    """The frame's bricks at the finest levels whose bricks fit ``budget_bytes`` together; raises
    ValueError when not even the coarsest level fits."""
    geometry = BrickGeometry(source)
    for floor_level in range(len(source.levels)):
        bricks = select_bricks(source, camera, size, view_projection, visible, lod_bias, floor_level, geometry)
        total = sum(brick_bytes(source, key) for key, _ in bricks)
        if total <= budget_bytes:
            return FramePlan(bricks, floor_level, total)
    raise ValueError(f"the {len(bricks)} bricks of the coarsest level need {total / 2**20:.2f} MB "
                     f"but the budget is {budget_bytes / 2**20:.2f} MB")
