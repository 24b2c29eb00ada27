"""Where a brick pyramid's bricks are: their level-0 voxel bounds, the samples each owns, the
levels' grids and strides (BrickGeometry, one per source). The selection of a frame's bricks
(vgraph.bricks.selection) and everything that draws or places them read it.

Conventions (docs/explanations/bricked-ray-casting.md):
- The pyramid is an octree of cells (vgraph.bricks.cells): cell b of level L covers level-0 voxels
  [b * B * f_L, (b + 1) * B * f_L) per axis (B the brick size, f_L the level's factor: 2^L where
  every level halves every axis, 1 along an axis the pyramid keeps), exactly its children at level
  L - 1, and reads the level-L voxels that cover that region. The selection walks it from the
  coarsest level down, so the chosen cells ("bricks") tile the volume whatever their levels.
- A brick *owns* the samples whose level-0 texture coordinate t lies in [j_lo / n, j_hi / n) per
  axis (j the level-0 voxel bounds above, n the level-0 voxels): half-open, so each sample of the
  global lattice lies in exactly one brick; the volume's outer faces are pushed to +-OUTSIDE so
  samples on (or a rounding beyond) the box still have an owner.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from vgraph import derived
from vgraph.bricks.cells import cell_factors, cell_grid, cells_are_bricks, coarseness
from vgraph.bricks.pyramid import BrickSource

OUTSIDE = 1e6  # texture coordinate of the volume's outer faces in the ownership test


class BrickGeometry:
    """Where a source's bricks are: level-0 voxel bounds, world boxes and ownership bounds.
    ``BrickGeometry.of(source)``: the one kept per source (vgraph.derived), which holds the source
    weakly (a kept value must not keep its source alive)."""

    def __init__(self, source: BrickSource, weak: bool = False):
        base = source.levels[0]
        self._source = weakref.ref(source) if weak else (lambda: source)
        self.dims0 = np.asarray(base.shape[::-1], dtype=np.float64)      # (x, y, z)
        self.spacing0 = np.asarray(base.spacing, dtype=np.float64)
        self.origin0 = np.asarray(base.origin, dtype=np.float64)
        self.brick = np.asarray(source.brick, dtype=np.float64)          # (x, y, z)
        factors = [np.asarray(f, dtype=np.int64) for f in cell_factors(source)]
        self.spans = [self.brick * f for f in factors]                   # level-0 voxels per cell
        self.ratios = [None] + [b // a for a, b in zip(factors, factors[1:])]  # children per axis
        self.grids = [np.asarray(cell_grid(source, k)[::-1]) for k in range(len(source.levels))]
        self.coarseness = coarseness(source)
        # Level-0 samples per sample of each level (brick_span.glsl): the level's smallest cell
        # edge over level 0's smallest voxel edge, whole (2^L where every axis halves).
        finest = float(self.spacing0.min())
        self.strides = [max(1, int(math.floor(float((f * self.spacing0).min()) / finest + 1e-9))) for f in factors]
        # per level: whether its cells are its bricks (cells_of_bricks changes nothing there), not asked
        # per frame
        self.cells_are_bricks = [cells_are_bricks(source, k) for k in range(len(source.levels))]
        self.per_brick: dict = {}  # key -> the brick's uniforms (targets.brick_uniforms), made once
        self.per_level: dict = {}  # (what, level) -> a level's boxes and corners (kept_per_level)

    @staticmethod
    def of(source: BrickSource) -> BrickGeometry:
        """The geometry of ``source``, made once per source (vgraph.derived)."""
        return derived.value(source, "brick geometry", lambda: BrickGeometry(source, weak=True))

    @property
    def source(self) -> BrickSource:
        return self._source()

    def voxel_bounds(self, key) -> tuple[np.ndarray, np.ndarray]:
        """Level-0 voxel bounds [lo, hi) (x, y, z) of a brick, hi clipped to the volume."""
        level, index = key[0], np.asarray(key[1:][::-1], dtype=np.float64)
        span = self.spans[level]
        return index * span, np.minimum((index + 1) * span, self.dims0)

    def owner_bounds(self, key) -> tuple[np.ndarray, np.ndarray]:
        """Texture-space bounds [lo, hi) of the samples the brick owns (see the module docstring)."""
        lo, hi = self.voxel_bounds(key)
        index = np.asarray(key[1:][::-1])
        t_lo = np.where(index == 0, -OUTSIDE, lo / self.dims0)
        t_hi = np.where(index == self.grids[key[0]] - 1, OUTSIDE, hi / self.dims0)
        return t_lo, t_hi

    def eye_in_bricks(self, eye, level: int) -> np.ndarray:
        """The eye's position in brick units of ``level`` (x, y, z)."""
        return ((np.asarray(eye) - self.origin0) / self.spacing0 + 0.5) / self.spans[level]
