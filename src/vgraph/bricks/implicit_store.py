"""ImplicitStore: a read-only zarr v3 store holding an OME-Zarr image of an implicit function whose
chunks are computed when they are read; nothing is written anywhere (docs/guide/large-data.md,
"Virtual stores"). It lets the out-of-core renderer be measured on volumes larger than any disk
here (8192^3, 16384^3 uint8: 512 GiB, 4 TiB) with the exact function as the truth.

What it serves, as vgraph convert would lay it out (pyramid.py's conventions):
- ``zarr.json``: a group with NGFF 0.5 "multiscales" (axes z, y, x of type space; one dataset per
  level with its scale and translation) and, under "implicit", the function, its parameters, the
  size and ``value_scale``; no "vgraph" attributes, so vgraph opens it as another tool's image
  (per-brick ranges of large levels unknown: no store could record them without evaluating the
  whole volume);
- ``<k>/zarr.json``: level k, uint8, chunks of ``brick`` voxels, no compression (the bytes codec);
- ``<k>/c/<z>/<y>/<x>``: a chunk, computed on read.

The lattice is implicit.sample's: level 0 has ``size`` voxel centres per axis spanning the
function's box (origin = box min, spacing = box / (size - 1)); level k + 1 is pyramid.next_level of
level k, down to a level of one brick. Values are implicit.sample's uint8 map,
``clip(rint((f / 2m + 0.5) * 255))``, with m = ``value_scale``: max |f| over level 0's lattice when
it has at most SCALE_POINTS points per axis (then a small store equals ``sample`` exactly), else
over a lattice of SCALE_POINTS per axis spanning the box (its corners included, where the
distance-like functions are largest; a larger |f| between its points clips at 0 or 255).

Coarser levels: voxel i of level k > 0 is the map of the MEAN of f at its 2 x 2 x 2 children's
centres on level k - 1's lattice (an odd axis's last voxel: its one child, as pyramid.halve does).
Averaging all 8^k level-0 voxels, as a real pyramid does, would cost the whole volume for the
coarsest brick; sampling f at the coarse centre alone would alias (marschner_lobb). The mean of one
step is the real pyramid's level 1 to within one unit (the real one rounds level 0 first) and
follows it closely above (tests/test_virtual_store.py measures how closely); its values lie within
the children's range, which the LOD error bound (lod_error.py) assumes of every coarse voxel.

Pure: every chunk is a function of its key alone, so reads are deterministic and any number of
threads (dask workers, zarr's concurrent reads) may read at once; COMPUTE_THREADS of them compute
at a time so that memory stays bounded whatever zarr's concurrency. The last KEPT_CHUNKS chunks
computed are kept (under a lock), since the renderer reads each brick with a halo from its
neighbours' chunks.
"""

from __future__ import annotations

import asyncio
import json
import math
import threading
from collections import OrderedDict

import numpy as np
from zarr.abc.store import ByteRequest, Store
from zarr.core.buffer import Buffer, BufferPrototype, default_buffer_prototype

from vgraph.bricks.pyramid import Level, level_count, next_level
from vgraph.bricks.store import BrickStore
from vgraph.bricks.store_files import byte_span
from vgraph.implicit.functions import ImplicitFunction
from vgraph.implicit.sampling import value_to_level

SCALE_POINTS = 129        # lattice points per axis that value_scale is the max |f| over
SLAB_POINTS = 1 << 18     # function evaluations at once: bounds a chunk's temporaries (2 MiB each)
COMPUTE_THREADS = 2       # chunks computed at once (the machine's cores; memory stays bounded)
KEPT_CHUNKS = 64          # computed chunks kept (16 MiB of 64^3): a brick read with its one-voxel
                          # halo spans 27 chunks, and its neighbours' reads share 18 of them
FULL_SCALE = 255.0
_compute = threading.BoundedSemaphore(COMPUTE_THREADS)


class ImplicitStore(Store):
    """The OME-Zarr image of ``function`` at ``size``^3 voxels in ``brick``^3 chunks (arguments
    checked by implicit_url.py; see the module docstring)."""

    supports_writes = False
    supports_deletes = False
    supports_partial_writes = False
    supports_listing = True

    def __init__(self, function: ImplicitFunction, size: int, brick: int, name: str = ""):
        super().__init__(read_only=True)
        self.function, self.size, self.brick = function, int(size), int(brick)
        self.name = name or f"implicit:{function.name}"
        lo, hi = (np.asarray(c, dtype=np.float64) for c in function.box)
        self.levels = [Level((self.size,) * 3, tuple(map(float, (hi - lo) / (self.size - 1))),
                             tuple(map(float, lo)))]
        for _ in range(level_count(self.levels[0].shape, (self.brick,) * 3) - 1):
            self.levels.append(next_level(self.levels[-1]))
        self.value_scale = self._value_scale()
        self._documents = self._metadata_documents()
        self._kept: OrderedDict[str, bytes] = OrderedDict()
        self._kept_lock = threading.Lock()

    # --- what it holds --------------------------------------------------------------------------
    def _value_scale(self) -> float:
        """m = max |f| over the lattice the module docstring names (1 where f is 0 throughout)."""
        level = self.levels[0]
        points = min(self.size, SCALE_POINTS)
        axes = [np.linspace(o, o + s * (self.size - 1), points) for o, s in zip(level.origin, level.spacing)]
        m = max(float(np.abs(f).max()) for f in _slabs(self.function, *axes))
        return m if m > 0.0 else 1.0

    def _metadata_documents(self) -> dict[str, bytes]:
        datasets = [{"path": str(k), "coordinateTransformations": [
            {"type": "scale", "scale": list(level.spacing[::-1])},
            {"type": "translation", "translation": list(level.origin[::-1])}]}
            for k, level in enumerate(self.levels)]
        image = {"name": self.name, "axes": [{"name": a, "type": "space"} for a in "zyx"],
                 "datasets": datasets}
        group = {"zarr_format": 3, "node_type": "group", "attributes": {
            "ome": {"version": "0.5", "multiscales": [image]},
            "implicit": {"function": self.function.name, "parameters": self.function.parameters(),
                         "size": self.size, "brick": self.brick, "value_scale": self.value_scale}}}
        documents = {"zarr.json": group}
        for k, level in enumerate(self.levels):
            documents[f"{k}/zarr.json"] = {
                "zarr_format": 3, "node_type": "array", "shape": list(level.shape), "data_type": "uint8",
                "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": [self.brick] * 3}},
                "chunk_key_encoding": {"name": "default", "configuration": {"separator": "/"}},
                "fill_value": 0, "codecs": [{"name": "bytes"}], "attributes": {},
                "dimension_names": ["z", "y", "x"]}
        return {key: json.dumps(doc).encode() for key, doc in documents.items()}

    def chunk_index(self, key: str) -> tuple[int, tuple[int, int, int]] | None:
        """(level, chunk [z, y, x]) of a chunk key '<k>/c/<z>/<y>/<x>' inside the image, else None."""
        parts = key.split("/")
        if len(parts) != 5 or parts[1] != "c" or not all(p.isdigit() for p in parts[:1] + parts[2:]):
            return None
        level, index = int(parts[0]), tuple(int(p) for p in parts[2:])
        if level >= len(self.levels):
            return None
        grid = [math.ceil(n / self.brick) for n in self.levels[level].shape]
        return (level, index) if all(i < n for i, n in zip(index, grid)) else None

    def chunk(self, level: int, index) -> np.ndarray:
        """The uint8 chunk [z, y, x] (brick^3; zero beyond the level's edge, zarr's fill value)."""
        shape = self.levels[level].shape
        start = [i * self.brick for i in index]
        stop = [min(a + self.brick, n) for a, n in zip(start, shape)]
        out = np.zeros((self.brick,) * 3, dtype=np.uint8)
        with _compute:
            f = self.values(level, start, stop)
        out[:f.shape[0], :f.shape[1], :f.shape[2]] = np.clip(
            np.rint(value_to_level(f, self.value_scale) * FULL_SCALE), 0, FULL_SCALE)
        return out

    def values(self, level: int, start, stop) -> np.ndarray:
        """f (float64, [z, y, x]) of level ``level``'s voxels [start, stop): level 0 at its centres,
        a coarser level the mean over each voxel's children on the finer lattice."""
        if level == 0:
            return np.concatenate(list(_slabs(self.function, *self._axes(0, start, stop))))
        finer = self.levels[level - 1].shape
        children = [np.minimum(np.arange(2 * a, 2 * b), n - 1) for a, b, n in zip(start, stop, finer)]
        axes = [self.levels[level - 1].origin[i] + self.levels[level - 1].spacing[i] * children[2 - i]
                for i in range(3)]  # x, y, z
        f = np.concatenate(list(_slabs(self.function, *axes)))
        z, y, x = (b - a for a, b in zip(start, stop))
        return f.reshape(z, 2, y, 2, x, 2).mean(axis=(1, 3, 5))

    def _axes(self, level: int, start, stop) -> list[np.ndarray]:
        """The lattice coordinates (x, y, z) of voxels [start, stop) ([z, y, x]) of ``level``."""
        geometry = self.levels[level]
        return [geometry.origin[i] + geometry.spacing[i] * np.arange(start[2 - i], stop[2 - i])
                for i in range(3)]

    # --- zarr's Store -----------------------------------------------------------------------------
    def __eq__(self, other: object) -> bool:
        return isinstance(other, ImplicitStore) and (other.function, other.size, other.brick) == \
            (self.function, self.size, self.brick)

    __hash__ = None

    def __reduce__(self):  # what a worker process needs to compute the same chunks (no lock, no kept bytes)
        return (type(self), (self.function, self.size, self.brick, self.name))

    def with_read_only(self, read_only: bool = False) -> ImplicitStore:
        return self  # never writable; immutable, so the same store serves both

    def limit_chunks(self, array, decoded_bytes: int) -> None:
        """BrickStore bounds each chunk file it reads (store_files.CheckedStore); these chunks are
        computed, always exactly one chunk: nothing to bound."""

    async def get(self, key: str, prototype: BufferPrototype | None = None,
                  byte_range: ByteRequest | None = None) -> Buffer | None:
        data = await asyncio.to_thread(self.get_bytes, key)
        if data is None:
            return None
        start, stop = byte_span(byte_range, len(data))
        return (prototype or default_buffer_prototype()).buffer.from_bytes(data[start:stop])

    def get_bytes(self, key: str) -> bytes | None:
        """The bytes at ``key`` (None: no such key, what zarr calls absent)."""
        if key in self._documents:
            return self._documents[key]
        found = self.chunk_index(key)
        if found is None:
            return None
        with self._kept_lock:
            if key in self._kept:
                self._kept.move_to_end(key)
                return self._kept[key]
        data = self.chunk(*found).tobytes()  # two threads may compute one chunk: the same bytes
        with self._kept_lock:
            self._kept[key] = data
            while len(self._kept) > KEPT_CHUNKS:
                self._kept.popitem(last=False)
        return data

    async def get_partial_values(self, prototype, key_ranges):
        return await asyncio.gather(*(self.get(key, prototype, byte_range) for key, byte_range in key_ranges))

    async def exists(self, key: str) -> bool:
        return key in self._documents or self.chunk_index(key) is not None

    async def set(self, key: str, value: Buffer) -> None:
        self._check_writable()

    async def delete(self, key: str) -> None:
        self._check_writable()

    async def list(self):
        for key in self._documents:  # chunks are not listed: 2^30 of them at 16384^3
            yield key

    async def list_prefix(self, prefix: str):
        for key in self._documents:
            if key.startswith(prefix):
                yield key

    async def list_dir(self, prefix: str):
        prefix = prefix.rstrip("/")
        names = set()
        for key in self._documents:
            if not prefix or key.startswith(prefix + "/"):
                names.add(key[len(prefix) + 1 if prefix else 0:].split("/")[0])
        for name in sorted(names):
            yield name

    def __repr__(self) -> str:
        return f"ImplicitStore({self.name!r}, {self.size}^3 uint8, brick {self.brick}, {len(self.levels)} levels)"


class ImplicitBrickStore(BrickStore):
    """A BrickStore over an ImplicitStore: it declares implicit.sample's range [0, 255], so that
    the surface f = 0 sits at intensity 0.5 as in the sampled volume (the data's own min..max
    would move it)."""

    @property
    def declared_range(self) -> tuple[float, float]:
        return (0.0, FULL_SCALE)

    @property
    def value_scale(self) -> float:
        """m: the function value of intensity 1 (implicit.sampling.level_to_value)."""
        return self._files.value_scale


def _slabs(function: ImplicitFunction, x: np.ndarray, y: np.ndarray, z: np.ndarray):
    """f on the grid (x, y, z) in z-slabs of at most SLAB_POINTS points, each [z, y, x]."""
    step = max(1, SLAB_POINTS // max(1, x.size * y.size))
    for k in range(0, z.size, step):
        yield np.asarray(function.value_on_grid(x, y, z[k:k + step]), dtype=np.float64)
