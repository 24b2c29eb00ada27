"""How far drawing a brick at a coarse level can move a pixel away from the level-0 frame, under
the frame's transfer function: a bound per brick and level, and the frame's bound
(docs/explanations/bricked-ray-casting.md, "Levels chosen by error", says why it bounds).

For a dvr brick b of level L > 0 (level 0 moves nothing: it is the reference):
- Values: every sample the brick takes, at level 0 or at L, lies in R_b, the normalised range of
  the level-0 voxels of the cell and of the cells around it (``value_ranges``).
- Per sample, over the LUT entries R_b can reach (one more on each side: the LUT's filter): the
  opacity a in [a_min, a_max]; the colour, where a > 0, in [c_min, c_max] per channel (entries
  with opacity or beside one: the filter blends a neighbour's colour in); lit, in
  [ambient c_min, min(1, max(c_max, (ambient + diffuse) c_max + specular))].
- Along a ray, the brick's samples at level 0 and at L stand for the same n <= N level-0 steps
  (brick_span.glsl), each of optical depth t in [t_min, t_max] (t = -e ln(1 - a), e FrontToBack's
  opacity exponent): both transmittances lie in [exp(-t_max n), exp(-t_min n)], so the brick's
  opacity moves by dA <= max over n in [1, N] of exp(-t_min n) - exp(-t_max n); its colour
  C = sum T_i a_i c_i, with sum T_i a_i = A, lies in [c_min A, c_max A]: dC <= c_max dA +
  (c_max - c_min) A_max, A_max = 1 - exp(-t_max N), and dC <= c_max A_max.
- Compositing front to back (the background under all, each value in [0, 1]): a brick moves each
  channel of a pixel by at most e_b = max(dC) + dA, and the bricks' moves add up: a pixel moves by
  at most the sum of e_b over the bricks whose screen rectangle holds it (``frame_bound``).
- Early termination below 1: each frame stops within 1 - early_termination of its full sum, so
  2 (1 - early_termination) is added once any brick moves.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.selection import normalised_ranges

CELL_PIXELS = 4  # the frame bound's grid: rectangles rounded out to 4 x 4 pixel cells (only grows it)


class RangeExtremes:
    """Minimum and maximum of table rows over index ranges [lo, hi], in O(1) per query (a sparse
    table of powers of two)."""

    def __init__(self, table: np.ndarray):
        self.low, self.high = [table], [table]
        width = 1
        while 2 * width <= len(table):
            low, high = self.low[-1], self.high[-1]
            self.low.append(np.minimum(low[:-width], low[width:]))
            self.high.append(np.maximum(high[:-width], high[width:]))
            width *= 2

    def __call__(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = np.floor(np.log2(hi - lo + 1)).astype(np.int64)
        low = np.empty(lo.shape + self.low[0].shape[1:])
        high = np.empty_like(low)
        for power in np.unique(k):
            at = k == power
            a, b = lo[at], hi[at] - (1 << int(power)) + 1
            low[at] = np.minimum(self.low[power][a], self.low[power][b])
            high[at] = np.maximum(self.high[power][a], self.high[power][b])
        return low, high


class TransferFunctionSpread:
    """Per LUT entry range: opacity extremes and the colour extremes of the entries that can
    colour a sample with opacity (module docstring)."""

    def __init__(self, lut: np.ndarray, lighting: tuple[float, float, float] | None = None):
        lut = np.asarray(lut, dtype=np.float64)
        alpha, colour = lut[:, 3], lut[:, :3]
        self.last = len(lut) - 1
        seen = ndimage.maximum_filter1d((alpha > 0.0).astype(np.uint8), size=3, mode="nearest") > 0
        self.alpha = RangeExtremes(alpha[:, None])
        self.colour_low = RangeExtremes(np.where(seen[:, None], colour, np.inf))
        self.colour_high = RangeExtremes(np.where(seen[:, None], colour, -np.inf))
        self.lighting = lighting

    def entries(self, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """LUT entries of normalised values [low, high] (unknown, +-inf: the whole LUT)."""
        lo = np.floor(np.clip(np.nan_to_num(low, nan=0.0), 0.0, 1.0) * self.last).astype(np.int64) - 1
        hi = np.ceil(np.clip(np.nan_to_num(high, nan=1.0), 0.0, 1.0) * self.last).astype(np.int64) + 1
        return np.clip(lo, 0, self.last), np.clip(hi, 0, self.last)

    def __call__(self, low, high):
        """(a_min, a_max, c_min [..., 3], c_max [..., 3]) of samples with values in [low, high]."""
        lo, hi = self.entries(np.asarray(low), np.asarray(high))
        a_min, a_max = (v[..., 0] for v in self.alpha(lo, hi))
        c_min, _ = self.colour_low(lo, hi)
        _, c_max = self.colour_high(lo, hi)
        c_min, c_max = np.minimum(c_min, c_max), np.maximum(c_min, c_max)  # (+-inf where no opacity)
        if self.lighting is not None:
            ambient, diffuse, specular = self.lighting
            c_min = c_min * ambient
            c_max = np.minimum(1.0, np.maximum(c_max, (ambient + diffuse) * c_max + specular))
        return a_min, a_max, c_min, c_max


def segment_bound(a_min, a_max, c_min, c_max, steps: float, exponent: float) -> np.ndarray:
    """e_b (module docstring) for samples within these extremes over at most ``steps`` steps."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t_min = -exponent * np.log1p(-np.minimum(a_min, 1.0))
        t_max = -exponent * np.log1p(-np.minimum(a_max, 1.0))
        peak = np.log(t_max / t_min) / (t_max - t_min)  # where exp(-t_min n) - exp(-t_max n) peaks
        peak = np.where(np.isfinite(peak), peak, 1.0)
        candidates = np.stack([np.ones_like(t_min), np.full_like(t_min, steps), np.clip(peak, 1.0, steps)])
        gap = np.exp(-t_min * candidates) - np.exp(-t_max * candidates)
        d_alpha = np.nan_to_num(gap.max(axis=0), nan=1.0)
        opaque = 1.0 - np.exp(-t_max * steps)
        # (both colours lie in [0, c_max A_max] too)
        d_colour = np.minimum(c_max * d_alpha[..., None] + (c_max - c_min) * opaque[..., None],
                              c_max * opaque[..., None])
        bound = np.nan_to_num(d_colour.max(axis=-1), nan=2.0, posinf=2.0) + d_alpha
    return np.where(a_max > 0.0, np.clip(bound, 0.0, 2.0), 0.0)


def value_ranges(source, geometry: BrickGeometry, level: int, value_range=None) -> tuple[np.ndarray, np.ndarray]:
    """Normalised [low, high] per cell [z, y, x] of ``level``, holding every value a sample of the
    cell takes at level 0 or at ``level``: the level-0 ranges (each brick's and its neighbours')
    gathered over the cell's level-0 bricks and widened to the 3^3 cells around it (a level voxel
    is the mean of the level-0 voxels under it, pyramid.halve, and a sample reads level voxels up to
    one away); joined with the level's own ranges where its bricks are the cells."""
    low0, high0 = normalised_ranges(source, 0, value_range)
    factor = np.asarray(geometry.spans[level] // geometry.brick, dtype=np.int64)[::-1]  # [z, y, x]
    grid = tuple(int(n) for n in geometry.grids[level][::-1])
    low, high = _gathered(low0, factor, grid, np.minimum, np.inf), _gathered(high0, factor, grid, np.maximum, -np.inf)
    low = ndimage.minimum_filter(low, size=3, mode="nearest")
    high = ndimage.maximum_filter(high, size=3, mode="nearest")
    own_low, own_high = normalised_ranges(source, level, value_range)
    if own_low.shape == low.shape:
        low, high = np.minimum(low, own_low), np.maximum(high, own_high)
    return low, high


def _gathered(values: np.ndarray, factor, grid, reduce, fill) -> np.ndarray:
    """``reduce`` over blocks of ``factor`` entries per axis ([z, y, x]), ``grid`` blocks."""
    padded = np.full(tuple(g * f for g, f in zip(grid, factor)), fill, dtype=np.float64)
    padded[tuple(slice(0, n) for n in values.shape)] = values
    blocks = padded.reshape(grid[0], factor[0], grid[1], factor[1], grid[2], factor[2])
    return reduce.reduce(reduce.reduce(reduce.reduce(blocks, axis=5), axis=3), axis=1)


class LodErrors:
    """e_b per cell of each level for one frame (computed on first use) and the frame's bound."""

    def __init__(self, source, geometry: BrickGeometry, spread: TransferFunctionSpread, sampling_rate: float,
                 exponent: float, early_termination: float = 1.0, value_range=None):
        self.source, self.geometry, self.spread = source, geometry, spread
        self.exponent, self.value_range = exponent, value_range
        self.step = float(geometry.spacing0.min()) / sampling_rate  # level 0's step, world units
        self.truncation = 2.0 * (1.0 - early_termination)
        self._levels: dict = {}

    def steps(self, level: int) -> float:
        """N: level-0 steps a ray can take through a cell of ``level`` (its diagonal, + 1)."""
        return float(np.linalg.norm(self.geometry.spans[level] * self.geometry.spacing0)) / self.step + 1.0

    def __call__(self, level: int) -> np.ndarray:
        if level not in self._levels:
            if level == 0:
                self._levels[0] = np.zeros(tuple(int(n) for n in self.geometry.grids[0][::-1]))
            else:
                low, high = value_ranges(self.source, self.geometry, level, self.value_range)
                self._levels[level] = segment_bound(*self.spread(low, high), self.steps(level), self.exponent)
        return self._levels[level]

    def frame_bound(self, bricks, size) -> float:
        """The largest sum of e_b over the bricks whose rectangles hold a pixel (+ the termination
        term once any brick moves), at most 1."""
        moves = [(self(key[0])[key[1:]], rect) for key, rect in bricks if key[0] > 0]
        moves = [(e, rect) for e, rect in moves if e > 0.0]
        if not moves:
            return 0.0
        cells = (-(-int(size[1]) // CELL_PIXELS) + 1, -(-int(size[0]) // CELL_PIXELS) + 1)
        corners = np.zeros(cells)
        for e, (x, y, w, h) in moves:
            x0, y0 = x // CELL_PIXELS, y // CELL_PIXELS
            x1, y1 = -(-(x + w) // CELL_PIXELS), -(-(y + h) // CELL_PIXELS)
            corners[y0, x0] += e
            corners[y0, x1] -= e
            corners[y1, x0] -= e
            corners[y1, x1] += e
        summed = corners.cumsum(axis=0).cumsum(axis=1)
        return float(min(1.0, summed.max() + self.truncation))
