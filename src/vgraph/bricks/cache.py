"""An LRU cache of bricks for the bricked ray caster: numpy bricks read from a BrickSource (RAM) and
their 3D textures (GL), each under its own budget in bytes.

Conventions (docs/explanations/bricked-ray-casting.md has the long form):
- A brick's key is (level, bz, by, bx). Its data is the brick's voxels with a halo of HALO voxels
  on every side, read from the neighbours and replicated at the level's border (what the whole
  volume's clamp-to-edge texture gives there). HALO = 2: a sample owned by the brick lies within
  half a voxel of its core, trilinear filtering reaches one voxel further and the shading gradients
  (central differences and Sobel, one voxel away) one more, so every value the ray caster computes
  inside a brick equals the whole volume's: no seams.
- Bricks are held in the texture format of Volume.texture() (uint8 as R16 holding value * 257,
  uint16 as R16, everything else R32F with non-finite voxels clamped to the value range), so the
  normalised intensity is ``sample * scale + offset`` with ``texture_format()``'s scale and offset.
- With each brick's texture goes a small RG32F texture of its blocks' ranges (``block_ranges_of``,
  blocks of BLOCK^3 core voxels), for empty-space skipping inside the brick; it is evicted with
  the brick and not counted in the GL budget (8 bytes per 512 voxels).
- ``begin_frame(keys)`` pins the bricks a frame needs: eviction takes the least recently used of
  the others and never a pinned one (a frame that does not fit is the selection's problem: it
  chooses a coarser level first). Evicted textures are released at once.
- Counters (``stats``): hits and misses of each cache, bytes read from the source (and the seconds
  it took), evictions and uploads; tests and benchmarks read them.
- A ``LoadLimit`` bounds the reading of one frame (the GUI's, so a frame never waits long for the
  disk; scripts have none): ``read_ahead`` reads bricks a later frame needs until it is used up.
  The time a read will take is estimated from this source's measured rate (``seconds_per_byte``).
"""

from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from vgraph import derived
from vgraph.bricks.cells import cell_extent, table_of
from vgraph.bricks.pyramid import BrickSource
from vgraph.gl_context import release_quietly
from vgraph.progress import report
from vgraph.volume_texture import FLOAT32_SAFE, TEXTURE_FORMATS

HALO = 2
BLOCK = 8  # voxels per block edge of the empty-space skipping inside a brick
MB = 1024 * 1024


@dataclass(frozen=True)
class TextureFormat:
    gl_dtype: str        # moderngl dtype of the brick textures
    itemsize: int        # bytes per voxel
    scale: float         # normalised intensity = sample * scale + offset
    offset: float
    normalized: bool     # float data uploaded as normalised intensities (float32 cannot carry them)


@dataclass(frozen=True)
class LoadLimit:
    """How much one frame may read: ``seconds`` of reading and/or ``bricks`` (None: no bound)."""
    seconds: float | None = None
    bricks: int | None = None

    def allows(self, count: int, nbytes: int, seconds_per_byte: float | None) -> bool:
        """Whether reading ``count`` bricks of ``nbytes`` fits. An unknown rate (nothing read from
        this source yet) fits nothing: a new volume's first frame is drawn from coarse bricks."""
        if count == 0:
            return True
        if self.bricks is not None and count > self.bricks:
            return False
        return self.seconds is None or (seconds_per_byte is not None and nbytes * seconds_per_byte <= self.seconds)

    def used_up(self, count: int, seconds: float) -> bool:
        """Whether a frame that read ``count`` bricks in ``seconds`` may read no more."""
        return ((self.bricks is not None and count >= self.bricks)
                or (self.seconds is not None and seconds >= self.seconds))


def usable_range(value_range) -> tuple[float, float]:
    """The value range, widened as Volume widens a constant volume's (a zero width divides by 0)."""
    lo, hi = map(float, value_range)
    return (lo, hi) if hi > lo else (lo, lo + max(1.0, abs(lo) * 1e-6))


def texture_format(dtype, value_range) -> TextureFormat:
    """The brick texture format of a source (the rule of Volume.texture and texture_scale_offset)."""
    dtype = np.dtype(dtype)
    lo, hi = usable_range(value_range)
    if dtype in TEXTURE_FORMATS:
        gl_dtype, full = TEXTURE_FORMATS[dtype]
        return TextureFormat(gl_dtype, 2, full / (hi - lo), -lo / (hi - lo), False)
    if max(abs(lo), abs(hi)) > FLOAT32_SAFE or hi - lo < 1.0 / FLOAT32_SAFE:
        return TextureFormat("f4", 4, 1.0, 0.0, True)
    return TextureFormat("f4", 4, 1.0 / (hi - lo), -lo / (hi - lo), False)


def to_texture_values(block: np.ndarray, fmt: TextureFormat, value_range) -> np.ndarray:
    """A block of source voxels as the texture stores them (see the module docstring)."""
    lo, hi = usable_range(value_range)
    if block.dtype == np.uint8:
        return block.astype(np.uint16) * np.uint16(257)
    if block.dtype == np.uint16:
        return block
    if fmt.normalized:
        values = (block.astype(np.float64) - lo) / (hi - lo)
        return np.nan_to_num(values, nan=0.0, posinf=1.0, neginf=0.0).astype(np.float32)
    return np.nan_to_num(block.astype(np.float32), nan=lo, posinf=hi, neginf=lo)


def brick_extent(source: BrickSource, key) -> tuple[np.ndarray, np.ndarray]:
    """Voxels [start, stop) ([z, y, x]) of a brick's core in its level: [i * brick, (i + 1) *
    brick) where the level halves level 0 (cells.py), else the voxels covering its region."""
    return cell_extent(source, key)


def brick_texture_shape(source: BrickSource, key) -> tuple[int, int, int]:
    """[z, y, x] voxels of a brick with its halo."""
    start, stop = brick_extent(source, key)
    return tuple(int(n) for n in stop - start + 2 * HALO)


def level_brick_bytes(source: BrickSource) -> list[np.ndarray]:
    """Per level, int64 [z, y, x]: the bytes of every brick with its halo in the texture format,
    made once per source and format (vgraph.derived): a frame's plan sums them over its bricks
    in a few numpy operations instead of asking brick by brick."""
    itemsize = texture_format(source.dtype, source.value_range).itemsize
    return derived.value(source, "brick bytes", lambda: _level_brick_bytes(source, itemsize), params=itemsize)


def _level_brick_bytes(source: BrickSource, itemsize: int) -> list[np.ndarray]:
    tables = []
    for spans in table_of(source).spans:  # per axis [z, y, x]: the cores' (starts, stops)
        z, y, x = (stops - starts + 2 * HALO for starts, stops in spans)
        tables.append(z[:, None, None] * y[None, :, None] * x[None, None, :] * itemsize)
    return tables


def brick_bytes(source: BrickSource, key) -> int:
    """Bytes of one brick with its halo in the texture format."""
    return int(level_brick_bytes(source)[key[0]][tuple(key[1:])])


def bricks_bytes(source: BrickSource, keys) -> int:
    """Bytes of the bricks ``keys`` (an iterable of keys, or an int array [n, 4]) together."""
    keys = keys if isinstance(keys, np.ndarray) else np.asarray(list(keys), dtype=np.int64)
    keys = keys.reshape(-1, 4)
    tables = level_brick_bytes(source)
    return sum(int(tables[level][tuple(keys[keys[:, 0] == level, 1:].T)].sum()) for level in np.unique(keys[:, 0]))


def read_with_halo(source: BrickSource, key) -> np.ndarray:
    """The brick's voxels and HALO more on every side; outside the level the border is replicated."""
    level = key[0]
    start, stop = brick_extent(source, key)
    shape = np.asarray(source.levels[level].shape)
    want_lo, want_hi = start - HALO, stop + HALO
    got_lo, got_hi = np.maximum(want_lo, 0), np.minimum(want_hi, shape)
    block = np.asarray(source.read(level, tuple(got_lo), tuple(got_hi)))
    pad = [(int(a), int(b)) for a, b in zip(got_lo - want_lo, want_hi - got_hi)]
    return np.pad(block, pad, mode="edge") if any(a or b for a, b in pad) else block


def block_ranges_of(data: np.ndarray, fmt: TextureFormat, block: int = BLOCK) -> np.ndarray:
    """Normalised min and max, float32 [nbz, nby, nbx, 2], over what the samples in each block of
    ``block`` core voxels of a brick (``data``: with its halo, in texture values) can read: a
    sample in block k (core coordinates [bk - 1/2, bk + b - 1/2)) filters voxels bk - 1 .. bk + b,
    so each range covers those (the shader's empty-space skipping inside a brick)."""
    low = high = data
    for axis in range(3):
        core = data.shape[axis] - 2 * HALO
        count = -(-core // block)
        slabs = [(block * k + HALO - 1, min(block * k + block + HALO + 1, data.shape[axis])) for k in range(count)]
        low = np.stack([np.take(low, range(a, b), axis=axis).min(axis=axis) for a, b in slabs], axis=axis)
        high = np.stack([np.take(high, range(a, b), axis=axis).max(axis=axis) for a, b in slabs], axis=axis)
    full = 65535.0 if fmt.gl_dtype == "nu2" else 1.0  # a normalised texture samples value / 65535
    ranges = np.stack([low, high], axis=-1).astype(np.float64) / full * fmt.scale + fmt.offset
    return ranges.astype(np.float32)


class BrickCache:
    """The two LRU caches (see the module docstring). One per ray caster; a new source clears it."""

    def __init__(self, ram_budget_mb: float = 1024.0, gl_budget_mb: float = 512.0):
        self.ram: OrderedDict = OrderedDict()  # key -> texture-ready numpy brick
        self.gl: OrderedDict = OrderedDict()   # key -> moderngl 3D texture
        self.block_textures: dict = {}         # key -> its blocks' ranges (RG32F), evicted with it
        self.pinned: frozenset = frozenset()
        # Bytes each cache holds, kept as entries come and go: summing the cache at every insertion
        # made reading n bricks O(n^2) (0.5 s of a 512-brick cold frame, bench/distributed_costs.py).
        self.held = {"ram": 0, "gl": 0}
        self.source = None
        self.value_range = None
        self._rate = [0, 0.0]
        self.set_budgets(ram_budget_mb, gl_budget_mb)
        self.reset_stats()

    # --- configuration --------------------------------------------------------------------------
    def set_budgets(self, ram_budget_mb: float, gl_budget_mb: float) -> None:
        self.ram_budget = int(ram_budget_mb * MB)
        self.gl_budget = int(gl_budget_mb * MB)

    def reset_stats(self) -> None:
        self.stats = {"ram_hits": 0, "ram_misses": 0, "gl_hits": 0, "gl_misses": 0, "bytes_read": 0,
                      "bricks_read": 0, "read_seconds": 0.0, "ram_evictions": 0, "gl_evictions": 0, "uploads": 0}

    def use_source(self, source: BrickSource, value_range=None) -> None:
        """Bricks of another source (or range: it sets the texture format) are not these bricks:
        forget them all. ``value_range``: the volume's (a declared range overrides the source's)."""
        value_range = tuple(map(float, value_range if value_range is not None else source.value_range))
        if source is not self.source or value_range != self.value_range:
            self.clear()
            self.source, self.value_range = source, value_range
            self.format = texture_format(source.dtype, value_range)
            self._rate = [0, 0.0]  # (bytes, seconds) read from this source: another disk, another speed

    def begin_frame(self, keys) -> None:
        """Pin the bricks of this frame (never evicted until the next begin_frame)."""
        self.pinned = frozenset(keys)

    # --- lookups --------------------------------------------------------------------------------
    def brick(self, key) -> np.ndarray:
        """The brick with its halo, in texture values (read from the source on a miss)."""
        data = self.ram.get(key)
        if data is not None:
            self.ram.move_to_end(key)
            self.stats["ram_hits"] += 1
            return data
        self.stats["ram_misses"] += 1
        started = time.perf_counter()
        raw = read_with_halo(self.source, key)
        data = np.ascontiguousarray(to_texture_values(raw, self.format, self.value_range))
        seconds = time.perf_counter() - started
        self.stats["bytes_read"] += raw.nbytes
        self.stats["bricks_read"] += 1
        self.stats["read_seconds"] += seconds
        self._rate[0] += data.nbytes
        self._rate[1] += seconds
        self.ram[key] = data
        self.held["ram"] += data.nbytes
        self._evict("ram", self.ram_budget)
        return data

    def texture(self, ctx, key):
        """The brick's 3D texture on ``ctx`` (uploaded from the RAM cache on a miss)."""
        texture = self.gl.get(key)
        if texture is not None and texture.ctx is ctx:
            self.gl.move_to_end(key)
            self.stats["gl_hits"] += 1
            return texture
        self.stats["gl_misses"] += 1
        if texture is not None:  # of a context that is gone
            self._drop_texture(key)
        data = self.brick(key)
        texture = _texture3d(ctx, data, self.format.gl_dtype)
        self.block_textures[key] = _texture3d(ctx, block_ranges_of(data, self.format), "f4", components=2)
        self.stats["uploads"] += 1
        self.gl[key] = texture
        self.held["gl"] += _texture_bytes(texture)
        self._evict("gl", self.gl_budget)
        return texture

    def blocks(self, ctx, key):
        """The RG32F texture of the brick's block ranges (block_ranges_of), uploaded with it (ask
        for ``texture`` first: this one does not count as a lookup)."""
        blocks = self.block_textures.get(key)
        if blocks is None or blocks.ctx is not ctx:
            self.texture(ctx, key)
            blocks = self.block_textures[key]
        return blocks

    def resident(self, ctx) -> set:
        """Keys of the bricks a frame on ``ctx`` can draw without reading."""
        return set(self.ram) | {key for key, texture in self.gl.items() if texture.ctx is ctx}

    def seconds_per_byte(self) -> float | None:
        """Measured reading time per byte (of texture data, as ``brick_bytes`` counts) of this
        source; None before its first read."""
        nbytes, seconds = self._rate
        return seconds / nbytes if nbytes else None

    def read_ahead(self, keys, limit: LoadLimit, count: int = 0, seconds: float = 0.0) -> int:
        """Read ``keys`` (those not in RAM) in order into the RAM cache until ``limit`` is used up,
        counting ``count`` bricks and ``seconds`` the frame read already; at least one brick, so
        a frame that reads ahead always makes progress. Returns the bricks read."""
        read = 0
        for number, key in enumerate(keys):
            report(number, len(keys), "reading bricks ahead")  # the GUI's progress bar
            if key in self.ram:
                continue
            if read and limit.used_up(count + read, seconds):
                break
            before = self.stats["read_seconds"]
            self.brick(key)
            seconds += self.stats["read_seconds"] - before
            read += 1
        return read

    def _drop_texture(self, key) -> None:
        texture = self.gl.pop(key)
        self.held["gl"] -= _texture_bytes(texture)
        release_quietly({key: texture, "blocks": self.block_textures.pop(key, None) or {}})

    # --- eviction -------------------------------------------------------------------------------
    def _evict(self, name: str, budget: int) -> None:
        """Drop least-recently-used unpinned entries while cache ``name`` ("ram" or "gl") exceeds
        its budget."""
        cache = self.ram if name == "ram" else self.gl
        for key in list(cache):
            if self.held[name] <= budget:
                break
            if key in self.pinned:
                continue
            self.stats[f"{name}_evictions"] += 1
            if name == "gl":
                self._drop_texture(key)
            else:
                self.held["ram"] -= cache.pop(key).nbytes

    def resident_bytes(self) -> tuple[int, int]:
        """(RAM bytes, GL bytes) held now."""
        return self.held["ram"], self.held["gl"]

    def clear(self) -> None:
        release_quietly(self.gl)
        release_quietly(self.block_textures)
        self.ram.clear()
        self.held = {"ram": 0, "gl": 0}
        self.pinned = frozenset()

    release = clear


def _texture3d(ctx, data: np.ndarray, dtype: str, components: int = 1):
    nz, ny, nx = data.shape[:3]
    texture = ctx.texture3d((nx, ny, nz), components, np.ascontiguousarray(data).tobytes(), dtype=dtype, alignment=1)
    texture.repeat_x = texture.repeat_y = texture.repeat_z = False
    return texture


def _texture_bytes(texture) -> int:
    width, height, depth = texture.size
    return width * height * depth * (2 if texture.dtype == "nu2" else 4)
