"""The distributed frame-time model of issue #31 (item 4), composed from separately measured costs.

bench/distributed_costs.py measures each constant on its own (a microbenchmark per cost, rounds
interleaved, min / median / max over the rounds); this module only does the arithmetic: no
constant is fitted to the frames it predicts.

Constants (seconds unless said otherwise; ``Costs`` holds one value of each, ``Spread`` three):

- ``read``: one brick read from the store into RAM (zarr read, halo, texture values);
  ``upload``: that brick made a 3D texture (and its block ranges) on the worker's GL context.
- ``slope[grid]`` / ``fixed[grid]``: a frame of one tile of ``grid`` (the heaviest tile) drawn
  warm with k bricks takes ``fixed + slope * k`` (the least-squares line over k, per round): the
  per-brick render cost at that tile size, and what a tile frame costs without bricks (entry and
  exit points, the plan, the resolve pass, the read-back).
- ``build``: building the shipped network on a worker; ``cold``: what the first frame of a freshly
  built network costs beyond a warm one (opening the store, first passes); ``plan``: a warm frame
  of the whole picture that draws no brick (the leaves split's plan task); ``resolve``: the leaves
  split's resolve task's frame.
- ``roundtrip``: a trivial task submitted and its result back; ``task``: each further task queued
  on the same worker; ``mb``: per MiB a task's result travels (worker to client; taken for worker
  to worker as well).
- ``assemble[grid]``: the client puts a frame's tiles together (vgraph.distributed.tiles.assemble);
  ``composite``: two partial accumulations of the leaves split combined (leaves.composite).
- ``contention``: how much slower a worker's frame is while the cluster's other workers draw too
  (applied only when more than one worker is busy; measured with 2 workers on the machine that
  runs the bench, whose cores they share; 1 for workers on machines of their own).

Every term grows with every constant, so the model evaluated at every constant's minimum and at
every constant's maximum brackets what the measured spreads allow (``predict``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from itertools import combinations

import numpy as np

from vgraph.distributed.leaves import split_runs

MIB = 2 ** 20
PIXEL_BYTES = 16  # float32 RGBA: a tile's image, and each of the two images of a partial accumulation


@dataclass(frozen=True)
class Spread:
    """min / median / max of one constant over the rounds."""

    low: float
    mid: float
    high: float

    @classmethod
    def of(cls, values) -> "Spread":
        values = np.asarray(list(values), dtype=np.float64)
        if values.size == 0:
            raise ValueError("a spread of no values")
        return cls(float(values.min()), float(np.median(values)), float(values.max()))

    def pick(self, which: str) -> float:
        return getattr(self, which)

    def text(self, scale: float = 1.0, digits: int = 2) -> str:
        return f"{self.low * scale:.{digits}f} / {self.mid * scale:.{digits}f} / {self.high * scale:.{digits}f}"


@dataclass(frozen=True)
class Costs:
    """One value of every constant (or, through ``Spread``s, three: see ``pick``)."""

    read: float
    upload: float
    slope: dict = field(default_factory=dict)
    fixed: dict = field(default_factory=dict)
    build: float = 0.0
    cold: float = 0.0
    plan: float = 0.0
    resolve: float = 0.0
    roundtrip: float = 0.0
    task: float = 0.0
    mb: float = 0.0
    assemble: dict = field(default_factory=dict)
    composite: float = 0.0
    contention: float = 1.0

    def pick(self, which: str) -> "Costs":
        """These costs with every Spread replaced by its ``which`` ('low', 'mid', 'high') value."""
        def one(value):
            if isinstance(value, dict):
                return {key: one(v) for key, v in value.items()}
            return value.pick(which) if isinstance(value, Spread) else value
        return replace(self, **{f.name: one(getattr(self, f.name)) for f in fields(self)})


@dataclass(frozen=True)
class TileWork:
    """A tile of the picture as the model sees it: the keys of the bricks it draws and its
    rendered rectangle's pixels (halo included)."""

    bricks: frozenset
    pixels: int


def in_turn(tiles: int, workers: int) -> list[list[int]]:
    """Tile i to worker i mod n: the order Dask's scheduler hands a frame's tasks out in when the
    workers are equally free (seen with get_task_stream: 2x2 on 2 workers gives tiles 0, 2 and 1, 3)."""
    return [list(range(w, tiles, workers)) for w in range(workers)]


def assignments(tiles: int, workers: int) -> list[list[list[int]]]:
    """The ways a frame's tiles may be spread over the workers, as far as the model knows them:
    for 2 workers and up to 12 tiles every even split (a worker that is done first takes the next
    tile, so any pair of tiles can share a worker: 2x2 on 2 workers also ran as 0, 3 and 1, 2,
    whose bricks overlap less); otherwise tiles in turn."""
    if workers != 2 or tiles > 12 or tiles < 3:
        return [in_turn(tiles, workers)]
    half = (tiles + 1) // 2
    return [[list(first), [i for i in range(tiles) if i not in first]]
            for first in combinations(range(tiles), half) if 0 in first]


def worker_tiles(c: Costs, grid: str, tiles: list[TileWork]) -> float:
    """One cold worker drawing ``tiles`` one task after the other: the network built once, each
    brick read and uploaded once (the union of its tiles'), every tile drawn."""
    if not tiles:
        return 0.0
    read = len(frozenset().union(*(t.bricks for t in tiles)))
    drawn = sum(c.fixed[grid] + c.slope[grid] * len(t.bricks) for t in tiles)
    return c.build + c.cold + (c.read + c.upload) * read + drawn + c.task * (len(tiles) - 1)


def tiles_frame(c: Costs, grid: str, tiles: list[TileWork], workers: int, dealt=None) -> float:
    """A cold frame of the tiles split: the busiest worker (slowed by contention), one round trip,
    every tile's image to the client and the client's assembly. ``dealt``: each worker's tile
    indices (default: in turn)."""
    dealt = [[tiles[i] for i in d] for d in (dealt or in_turn(len(tiles), workers))]
    busiest = max(worker_tiles(c, grid, d) for d in dealt)
    images = sum(t.pixels for t in tiles) * PIXEL_BYTES / MIB
    return c.roundtrip + busiest * sharing(c, sum(1 for d in dealt if d)) + c.mb * images + c.assemble[grid]


def sharing(c: Costs, busy: int) -> float:
    """The slow-down of a worker's frame while ``busy`` workers draw at once (none alone)."""
    return c.contention if busy > 1 else 1.0


def leaves_frame(c: Costs, weights, pixels: int, workers: int) -> float:
    """A cold frame of the leaves split of a picture of ``pixels`` whose planned bricks (front to
    back) have ``weights``: the plan task (a cold worker builds and plans), one run per worker
    (each other worker builds its network in its run; the busiest run counts), the composite tree
    (log2 levels, one partial travelling to each pair) and the resolve task (the composited partial
    travels to it, the picture to the client). The full picture's ``fixed``/``slope`` ('1x1') are
    the runs' costs per frame and per brick."""
    weights = list(weights)
    runs = split_runs(weights, workers)
    partial = 2 * pixels * PIXEL_BYTES / MIB
    planned = c.roundtrip + c.build + c.cold + c.plan
    per_brick = c.read + c.upload + c.slope["1x1"]
    loads = []
    for i, (start, stop) in enumerate(runs):
        bricks = stop - start
        setup = (c.build + c.cold) if i > 0 else 0.0  # the first run lands where the plan built it
        loads.append(setup + c.fixed["1x1"] + per_brick * bricks)
    ran = c.roundtrip + max(loads, default=c.fixed["1x1"]) * sharing(c, len(runs))
    levels = math.ceil(math.log2(len(runs))) if len(runs) > 1 else 0
    composited = levels * (c.roundtrip + c.composite + c.mb * partial)
    moved = c.mb * partial if len(runs) > 1 else 0.0
    resolved = c.roundtrip + c.resolve + moved + c.mb * pixels * PIXEL_BYTES / MIB
    return planned + ran + composited + resolved


def predict(costs: Costs, frame, *args) -> Spread:
    """``frame(costs, *args)`` at every constant's minimum, median and maximum: the point and the
    interval the measured spreads allow (every term grows with every constant)."""
    return Spread(*(frame(costs.pick(which), *args) for which in ("low", "mid", "high")))


def predict_tiles(costs: Costs, grid: str, tiles: list[TileWork], workers: int) -> Spread:
    """``predict`` of tiles_frame, the interval also spanning the ways the tiles may be dealt
    (``assignments``): the least at every minimum, the most at every maximum; the point in turn."""
    ways = assignments(len(tiles), workers)
    low, high = costs.pick("low"), costs.pick("high")
    return Spread(min(tiles_frame(low, grid, tiles, workers, way) for way in ways),
                  tiles_frame(costs.pick("mid"), grid, tiles, workers),
                  max(tiles_frame(high, grid, tiles, workers, way) for way in ways))


def tiles_for(grid: str) -> int:
    columns, rows = (int(v) for v in grid.split("x"))
    return columns * rows


def grid_for(workers: int, grids) -> str:
    """The smallest of ``grids`` with a tile per worker."""
    return min((g for g in grids if tiles_for(g) >= workers), key=tiles_for)
