"""BrickStore: an OME-Zarr image on disk as a BrickSource (docs/guide/large-data.md).

Opens vgraph's own stores (store_writer.py) and OME-Zarr images written by other tools (NGFF 0.4
on zarr v2, 0.5 on zarr v3; ome-zarr-py, napari, bioformats2raw's layout 3, whose first image it
opens): the first image of "multiscales", its axes (three of type space, taken as z, y, x by
name, else in their order, or two: a 2D image read as one slice; a time and a channel axis are
indexed with ``time`` and ``channel``; any other axis must have size 1), one level per dataset
with the spacing and origin of its scale and translation (a multiscale-wide transformation
applies on top; lengths in one unit), whatever the factor between levels (cells.py). A label
image ("image-label") sets ``holds_labels``. Opening reads metadata only, checked as
store_metadata.py says; every file is read through store_files.CheckedStore (regular files only,
sizes bounded before reading).

Voxels are read by ``read``. A chunk with no file reads as the array's fill value, which is what
zarr means by it, unless the store's own statistics say otherwise: in vgraph's stores a brick
whose recorded min and max are not both the fill value must have its chunk (vgraph convert
leaves out only chunks of fill value), and a read that finds it missing is refused as damage.
Other tools' images have no such statistics: their missing chunks are the fill value (zarr's
sparse arrays).

Statistics never read a whole large array: the value range and per-brick ranges of vgraph's
stores are recorded; for other stores ``value_range`` is the min..max of the finest level of at
most SAMPLE_VOXELS voxels in SAMPLE_BRICKS bricks, read whole (level 0 of a store that small:
exact), else of a bounded sample of the coarsest level (pyramid.sample_blocks; averaging only
narrows the range, so it lies within the full-resolution one) and
``brick_ranges`` reads a level once only if it has at most SCAN_VOXELS voxels in at most SCAN_BRICKS bricks; a larger level's
bricks are unknown: (-inf, +inf), drawn whenever the renderer asks for them.

Every problem raises VolumeFileError naming the store and, where known, the level, the chunk (its
key in the store) or the metadata field.
"""

from __future__ import annotations

import itertools
import math
import warnings
from functools import cached_property
from pathlib import Path

import numpy as np
import zarr.api.asynchronous as zarr_async
from zarr.core.array import AsyncArray

from vgraph.bricks import foreign_stores as foreign
from vgraph.bricks import store_metadata as meta
from vgraph.bricks.pyramid import block_ranges, brick_grid, sample_blocks
from vgraph.bricks.store_files import CheckedStore, StoreFileError, run
from vgraph.byte_order import to_native
from vgraph.errors import VGraphError, VolumeFileError
from vgraph.errors import TimeStepError
from vgraph.memory import check_memory
from vgraph.value_range import blockwise_extremes, range_of
from vgraph.volume_grid import IDENTITY

SAMPLE_VOXELS = 2**22  # voxels read for another tool's value range: 4 M ...
SAMPLE_BRICKS = 2**10  # ... in at most 1024 bricks (a read each: about 0.5 ms a chunk here)
SCAN_VOXELS = 2**25    # a level without recorded ranges is read for them only up to 32 M voxels
SCAN_BRICKS = 2**12    # ... in up to 4096 bricks


class BrickStore:
    """A BrickSource over the OME-Zarr image at ``path`` (time point ``time``, channel
    ``channel``). ``files``: the zarr store to read instead of the folder at ``path`` (a virtual
    store, implicit_store.py; ``path`` then only names it)."""

    def __init__(self, path, time: int = 0, channel: int = 0, *, files=None):
        self.path = Path(path)
        self.source = str(path)
        self._files = files if files is not None else CheckedStore(self.path) if self.path.is_dir() else None
        group = _open_group(self.path, self._files)
        attributes = dict(group.attrs)
        if foreign.bioformats2raw_layout(attributes):
            group, attributes = self._first_series(group, attributes)
        image = meta.first_image(attributes, self.path)
        self.holds_labels = foreign.is_label_image(attributes)  # an image of a labels/ group
        self.axes = meta.image_axes(image, self.path)
        self._space = meta.space_axes(self.axes, self.path)
        self.arrays = [self._open_level(group, image, k) for k in range(len(image["datasets"]))]
        dtypes = [meta.voxel_dtype(array, self.path, k) for k, array in enumerate(self.arrays)]
        meta.check_same_kind(self.arrays, dtypes, self.axes, self._space, self.path)
        self.unit, units = foreign.space_units(self.axes, self._space, self.path)
        self.time_steps, self.time = self._index("time", time)
        self.channels, self.channel = self._index("channel", channel)
        self._check_other_axes()
        levels = [meta.level_geometry(image, k, array.shape, self._space, len(self.axes), self.path, units)
                  for k, array in enumerate(self.arrays)]
        meta.check_extents(levels, self.path)
        self.dtype = dtypes[0]
        self.ours = meta.our_attributes(attributes, len(levels), math.prod(levels[0].shape), self.path)
        self.direction = self.ours["direction"] if self.ours else IDENTITY  # BrickedVolume takes it
        if self.ours:
            self.brick = self._chunks_xyz(self.arrays[0])
            meta.check_our_pyramid(levels, self.path)
            self._check_our_chunks()
        else:
            self.brick = foreign.foreign_brick(self._chunks_xyz(self.arrays[0]))
            levels = levels[:meta.coarsening_levels(levels, self.path)]
            self.arrays = self.arrays[:len(levels)]
        self.levels = levels
        for k, level in enumerate(levels):
            meta.check_brick_count(level, self.brick, self.path, k, meta.array_field(self.arrays[0]))
        self._range_arrays = [self._open_range_arrays(group, k) for k in range(len(levels))] \
            if self.ours else None
        self._ranges: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    # --- the BrickSource protocol -----------------------------------------------------------------
    def read(self, level: int, start, stop) -> np.ndarray:
        """Voxels [start, stop) ([z, y, x]) of ``level``, clamped to it, native byte order."""
        shape = self.levels[level].shape
        lo = [min(max(0, int(a)), n) for a, n in zip(start, shape)]
        hi = [max(min(n, int(b)), a) for a, b, n in zip(lo, stop, shape)]
        index = self._selection(lo, hi)
        array = self.arrays[level]
        check_memory(self.path, math.prod(b - a for a, b in zip(lo, hi)) * self.dtype.itemsize
                     + meta.check_chunks(array, self.dtype, self.path, level), str(level))
        missing: list[str] = []
        block = self._get(array, index, level, missing, f"level {level} voxels {lo}..{hi}")
        if missing:
            self._check_missing(level, index, missing)
        space = [a for a in self._space if a is not None]
        order = [sorted(space).index(a) for a in space]  # array order of the space axes -> z, y, x
        block = np.transpose(block, order) if order != sorted(order) else block
        if len(space) == 2:  # a 2D image: its one slice
            block = block[np.newaxis][lo[0]:hi[0]]
        return to_native(block)

    def brick_ranges(self, level: int) -> tuple[np.ndarray, np.ndarray]:
        """Min and max of every brick's finite voxels ([bz, by, bx] float64, NaN: none; -inf and
        +inf: unknown, a level too large to read for them): from the store's own arrays, else
        computed by reading the level slab by slab (once)."""
        if level not in self._ranges:
            self._ranges[level] = (self._stored_ranges if self.ours else self._computed_ranges)(level)
        return self._ranges[level]

    @cached_property
    def value_range(self) -> tuple[float, float]:
        return self.ours["value_range"] if self.ours else range_of(self.data_range)

    # --- what a Volume needs beyond the protocol --------------------------------------------------
    @property
    def declared_range(self) -> tuple[float, float] | None:
        return self.ours["declared_range"] if self.ours else None

    @cached_property
    def data_range(self) -> tuple[float, float] | None:
        """Min and max of the finite voxels (None: none is finite): recorded by vgraph convert;
        for other stores those of the finest level small enough to read whole, else of a bounded
        sample of the coarsest (a pyramid of another tool may end in a few voxels of averages)."""
        if self.ours:
            return self.ours["data_range"]
        small = (k for k, level in enumerate(self.levels) if math.prod(level.shape) <= SAMPLE_VOXELS
                 and math.prod(brick_grid(level.shape, self.brick)) <= SAMPLE_BRICKS)
        blocks = sample_blocks(self, next(small, len(self.levels) - 1), SAMPLE_VOXELS, SAMPLE_BRICKS)
        extremes = blockwise_extremes(blocks)
        return None if extremes is None else (float(extremes[0]), float(extremes[1]))

    @property
    def nonfinite(self) -> int | None:
        """NaN/Inf voxels at full resolution, as vgraph convert counted them (None: unknown)."""
        if self.dtype.kind != "f":
            return 0
        return self.ours["nonfinite"] if self.ours else None

    # --- opening ----------------------------------------------------------------------------------
    def _first_series(self, group, attributes: dict):
        """bioformats2raw's collection: the first image (OME/ "series", else group "0"), saying
        when the collection holds more (the layout asks readers to)."""
        foreign.check_bioformats2raw(attributes, self.path)
        ome = _member(group, "OME", self.path)
        series = foreign.series_paths(dict(ome.attrs) if ome is not None and not isinstance(ome, AsyncArray)
                                   else None, self.path)
        name = series[0] if series else "0"
        image = _member(group, name, self.path)
        if image is None or isinstance(image, AsyncArray):
            raise VolumeFileError(self.path, f"a bioformats2raw collection without its image group "
                                             f"{name!r}", "bioformats2raw.layout")
        more = len(series) - 1 if series else int(_member(group, "1", self.path) is not None)
        if more:
            count = f"{len(series)} images" if series else "more than one image"
            warnings.warn(foreign.StoreImagesWarning(
                f"{self.path}: a bioformats2raw collection of {count}: showing the first ({name}); "
                f"open {self.path / (series[1] if series else '1')} for the next"), stacklevel=3)
        return image, dict(image.attrs)

    def _chunks_xyz(self, array) -> tuple[int, int, int]:
        """The array's chunk in voxels (x, y, z); 1 along a 2D image's missing z."""
        return tuple(int(array.chunks[a]) if a is not None else 1 for a in self._space[::-1])

    def _open_level(self, group, image: dict, k: int):
        name = meta.dataset_path(image, k, self.path)
        array = _member(group, name, self.path)
        if not isinstance(array, AsyncArray):
            raise VolumeFileError(self.path, f"level {k}: dataset path {name!r} is not an array in the "
                                             f"store", "multiscales.datasets")
        if array.ndim != len(self.axes):
            raise VolumeFileError(self.path, f"level {k} ({name}) has {array.ndim} dimensions but "
                                             f"{len(self.axes)} axes are declared", "multiscales.axes")
        dtype = meta.voxel_dtype(array, self.path, k)
        self._files.limit_chunks(array, meta.check_chunks(array, dtype, self.path, k))
        return array

    def _check_our_chunks(self) -> None:
        for k, array in enumerate(self.arrays):
            chunks = self._chunks_xyz(array)
            if chunks != self.ours["brick"] or array.shards:
                raise VolumeFileError(self.path, f"level {k}: chunks of {chunks} voxels (x, y, z), but the "
                                                 f"store's brick is {self.ours['brick']}: the store is "
                                                 f"damaged", meta.array_field(array))

    def _open_range_arrays(self, group, k: int):
        """vgraph/min/<k> and vgraph/max/<k> (metadata only; read by brick_ranges)."""
        arrays = []
        for which in ("min", "max"):
            name = f"vgraph/{which}/{k}"
            array = _member(group, name, self.path)
            if not isinstance(array, AsyncArray):
                raise VolumeFileError(self.path, f"the per-brick {which} of level {k} are missing: the "
                                                 f"store is damaged", name)
            meta.check_range_array(array, self.levels[k], self.brick, self.path, k, which)
            self._files.limit_chunks(array, meta.check_chunks(array, np.dtype("f8"), self.path, k))
            arrays.append(array)
        return arrays

    def _index(self, kind: str, value) -> tuple[int, int]:
        """(axis length, the checked index) of the time or channel axis (1, 0 when absent)."""
        axis = next((a for a, spec in enumerate(self.axes) if spec["type"] == kind), None)
        count = 1 if axis is None else int(self.arrays[0].shape[axis])
        if kind == "time":
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < count:
                raise TimeStepError(self.path, value, count)
        elif isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < count:
            raise VolumeFileError(self.path, f"channel {value!r} is out of range: the image has "
                                             f"{count} channel(s) (0 .. {count - 1})", "channel")
        return count, int(value)

    def _check_other_axes(self) -> None:
        for axis, spec in enumerate(self.axes):
            if spec["type"] not in ("space", "time", "channel") and self.arrays[0].shape[axis] != 1:
                raise VolumeFileError(self.path, f"axis {spec['name']!r} of type {spec['type']!r} "
                                                 f"has {self.arrays[0].shape[axis]} entries; only "
                                                 f"time and channel axes can be selected", "axes")

    # --- reading ----------------------------------------------------------------------------------
    def _selection(self, lo, hi) -> tuple:
        index = [0] * len(self.axes)
        for axis, spec in enumerate(self.axes):
            if axis in self._space:
                which = self._space.index(axis)
                index[axis] = slice(lo[which], hi[which])
            elif spec["type"] == "time":
                index[axis] = self.time
            elif spec["type"] == "channel":
                index[axis] = self.channel
        return tuple(index)

    def _get(self, array, index, level: int, missing: list, what: str) -> np.ndarray:
        try:
            return np.asarray(run(array.getitem(index), missing))
        except StoreFileError as error:
            raise VolumeFileError(self.path, f"level {level}: chunk {error.key} {error.reason}",
                                  error.key) from None
        except VGraphError:
            raise
        except Exception as error:  # a chunk its codecs cannot decode into the declared chunk shape
            key = self._undecodable_chunk(array, index) or "?"
            raise VolumeFileError(self.path, f"level {level}: chunk {key} cannot be read as "
                                             f"{' x '.join(map(str, meta.stored_chunk(array)))} voxels of "
                                             f"{array.dtype} ({what}): {type(error).__name__}: "
                                             f"{str(error)[:200]}", key) from None

    def _chunk_keys(self, array, index) -> dict[str, tuple]:
        """Store key -> chunk coordinates of the stored chunks a selection touches."""
        chunk = meta.stored_chunk(array)
        spans = [i.indices(n)[:2] if isinstance(i, slice) else (i, i + 1)
                 for i, n in zip(index, array.shape)]
        ranges = [range(a // c, max(a, b - 1) // c + 1) for (a, b), c in zip(spans, chunk)]
        return {f"{array.path}/{array.metadata.encode_chunk_key(coords)}": coords
                for coords in itertools.product(*ranges)}

    def _undecodable_chunk(self, array, index) -> str | None:
        """The first chunk of the selection that fails alone (on the error path only)."""
        chunk = meta.stored_chunk(array)
        for key, coords in self._chunk_keys(array, index).items():
            one = tuple(slice(c * n, min((c + 1) * n, size))
                        for c, n, size in zip(coords, chunk, array.shape))
            try:
                run(array.getitem(one))
            except Exception:
                return key
        return None

    def _check_missing(self, level: int, index, missing: list[str]) -> None:
        """Chunks without a file are the fill value: refused where the store's statistics say
        their brick holds something else."""
        if not self.ours:
            return
        fill = float(self.arrays[level].metadata.fill_value)
        low, high = self.brick_ranges(level)
        coordinates = self._chunk_keys(self.arrays[level], index)
        for key in missing:
            brick = tuple(coordinates.get(key, ()))
            if len(brick) != 3:
                continue
            lo, hi = low[brick], high[brick]
            if lo == hi == fill or (math.isnan(fill) and np.isnan(lo) and np.isnan(hi)):
                continue
            held = "no finite value" if np.isnan(lo) else f"values {lo:g} to {hi:g}"
            raise VolumeFileError(self.path, f"level {level}: chunk {key} is missing, but the store's "
                                             f"statistics (vgraph/min/{level}, vgraph/max/{level}) say "
                                             f"brick {brick} (z, y, x) holds {held}, not only the fill "
                                             f"value {fill:g}: the store is damaged (a chunk file was "
                                             f"deleted or lost)", key)

    # --- per-brick ranges -------------------------------------------------------------------------
    def _stored_ranges(self, level: int):
        low_array, high_array = self._range_arrays[level]
        check_memory(self.path, 2 * 8 * math.prod(low_array.shape), f"vgraph/min/{level}")
        low, high = (self._get(a, tuple(slice(0, n) for n in a.shape), level, [], "per-brick ranges")
                     for a in (low_array, high_array))
        low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        if (low > high).any() or np.isinf(low).any() or np.isinf(high).any():
            raise VolumeFileError(self.path, f"the per-brick ranges of level {level} have a min above "
                                             f"its max or an infinite one: the store is damaged",
                                  f"vgraph/min/{level}")
        return low, high

    def _computed_ranges(self, level: int):
        shape = self.levels[level].shape
        grid = brick_grid(shape, self.brick)
        if math.prod(shape) > SCAN_VOXELS or math.prod(grid) > SCAN_BRICKS:  # unknown: drawn when asked
            return np.broadcast_to(-np.inf, grid), np.broadcast_to(np.inf, grid)
        bz = self.brick[2]
        rows = [block_ranges(self.read(level, (z, 0, 0), (z + bz, shape[1], shape[2])), self.brick)
                for z in range(0, shape[0], bz)]
        return np.concatenate([r[0] for r in rows]), np.concatenate([r[1] for r in rows])

    def __repr__(self) -> str:
        shape = " x ".join(map(str, self.levels[0].shape[::-1]))
        return f"BrickStore({self.source!r}, {shape} {self.dtype}, {len(self.levels)} levels, brick {self.brick})"


def _open_group(path: Path, files: CheckedStore | None):
    if files is None and not path.exists():
        raise VolumeFileError(path, "store does not exist")
    if files is None:
        raise VolumeFileError(path, "is not a folder: an OME-Zarr store is a folder holding "
                                    "zarr.json (or .zgroup)")
    try:
        return run(zarr_async.open_group(store=files, mode="r"))
    except VGraphError:
        raise
    except Exception as error:  # GroupNotFoundError, a damaged zarr.json (JSON errors)...
        raise VolumeFileError(path, f"not a zarr group (no readable zarr.json or .zgroup): "
                                    f"{type(error).__name__}: {str(error)[:200]}", "zarr.json") from None


def _member(group, name: str, path: Path):
    """The array or group at ``name`` (None when there is none); damaged metadata is refused."""
    try:
        return run(group.getitem(name))
    except KeyError:
        return None
    except VGraphError:
        raise
    except Exception as error:  # zarr's errors for a damaged zarr.json / .zarray
        raise VolumeFileError(path, f"the metadata of {name!r} cannot be read: {type(error).__name__}: "
                                    f"{str(error)[:200]}", name) from None
