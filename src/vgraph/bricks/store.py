"""BrickStore: an OME-Zarr image on disk as a BrickSource (docs/large-data.md).

Opens vgraph's own stores (store_writer.py) and OME-Zarr images written by other tools (NGFF 0.4
on zarr v2, 0.5 on zarr v3): the first image of "multiscales", its axes (three of type space,
taken as z, y, x by name, else in their order; a time and a channel axis are indexed with
``time`` and ``channel``; any other axis must have size 1), one level per dataset with the
spacing and origin of its scale and translation (a multiscale-wide transformation applies on
top). Opening reads metadata only; voxels are read by ``read`` and, for stores without vgraph's
attributes, by ``brick_ranges`` (once per level, then cached) and ``value_range`` (the coarsest
level's min..max: the finer levels would mean reading the whole volume, and averaging only
narrows the range, so it is within the full-resolution one).

Every problem raises VolumeFileError naming the store and, where known, the metadata field.
"""

from __future__ import annotations

import math
from functools import cached_property
from pathlib import Path

import numpy as np
import zarr

from vgraph.bricks.pyramid import Level, block_ranges
from vgraph.errors import VolumeFileError
from vgraph.io._common import TimeStepError, to_native
from vgraph.value_range import range_of

_TYPES = {"t": "time", "c": "channel", "x": "space", "y": "space", "z": "space"}


class BrickStore:
    """A BrickSource over the OME-Zarr image at ``path`` (time point ``time``, channel
    ``channel``)."""

    def __init__(self, path, time: int = 0, channel: int = 0):
        self.path = Path(path)
        self.source = str(path)
        group = _open_group(self.path)
        attributes = group.attrs.asdict()
        image = _first_image(attributes, self.path)
        self.axes = _axes(image, self.path)
        self.arrays = _level_arrays(group, image, len(self.axes), self.path)
        self._space = _space_axes(self.axes, self.path)
        self.unit = self.axes[self._space[0]].get("unit")
        self.time_steps, self.time = self._index("time", time)
        self.channels, self.channel = self._index("channel", channel)
        self._check_other_axes()
        self.levels = [self._level(k, array, image) for k, array in enumerate(self.arrays)]
        first = self.arrays[0]
        self.brick = tuple(int(first.chunks[a]) for a in self._space[::-1])
        self.dtype = _dtype(first, self.path)
        self.ours = attributes.get("vgraph") if isinstance(attributes.get("vgraph"), dict) else None
        self._group = group
        self._ranges: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    # --- the BrickSource protocol -----------------------------------------------------------------
    def read(self, level: int, start, stop) -> np.ndarray:
        """Voxels [start, stop) ([z, y, x]) of ``level``, clamped to it, native byte order."""
        shape = self.levels[level].shape
        lo = [min(max(0, int(a)), n) for a, n in zip(start, shape)]
        hi = [max(min(n, int(b)), a) for a, b, n in zip(lo, stop, shape)]
        index = [0] * len(self.axes)
        for axis, name in enumerate(self.axes):
            if axis in self._space:
                which = self._space.index(axis)
                index[axis] = slice(lo[which], hi[which])
            elif name["type"] == "time":
                index[axis] = self.time
            elif name["type"] == "channel":
                index[axis] = self.channel
        try:
            block = np.asarray(self.arrays[level][tuple(index)])
        except Exception as error:  # a damaged or missing chunk: zarr and its codecs raise many types
            raise VolumeFileError(self.path, f"cannot read level {level} voxels {lo}..{hi}: "
                                             f"{type(error).__name__}: {error}", str(level)) from error
        order = np.argsort(np.argsort(self._space))  # array order of the space axes -> z, y, x
        return to_native(np.transpose(block, order) if list(order) != [0, 1, 2] else block)

    def brick_ranges(self, level: int) -> tuple[np.ndarray, np.ndarray]:
        """Min and max of every brick's finite voxels ([bz, by, bx] float64, NaN: none): from the
        store's own arrays, else computed by reading the level slab by slab (once)."""
        if level not in self._ranges:
            self._ranges[level] = self._stored_ranges(level) or self._computed_ranges(level)
        return self._ranges[level]

    @cached_property
    def value_range(self) -> tuple[float, float]:
        if self.ours and self.ours.get("value_range"):
            return tuple(float(v) for v in self.ours["value_range"])
        return range_of(self.data_range)

    # --- what a Volume needs beyond the protocol --------------------------------------------------
    @property
    def declared_range(self) -> tuple[float, float] | None:
        declared = self.ours.get("declared_range") if self.ours else None
        return tuple(float(v) for v in declared) if declared else None

    @cached_property
    def data_range(self) -> tuple[float, float] | None:
        """Min and max of the finite voxels (None: none is finite): recorded by vgraph convert;
        for other stores those of the coarsest level (one read of its voxels)."""
        if self.ours and "data_range" in self.ours:
            recorded = self.ours["data_range"]
            return tuple(float(v) for v in recorded) if recorded else None
        low, high = self.brick_ranges(len(self.levels) - 1)
        return (float(np.nanmin(low)), float(np.nanmax(high))) if np.isfinite(low).any() else None

    @property
    def nonfinite(self) -> int | None:
        """NaN/Inf voxels at full resolution, as vgraph convert counted them (None: unknown)."""
        if self.dtype.kind != "f":
            return 0
        return int(self.ours["nonfinite"]) if self.ours and "nonfinite" in self.ours else None

    # --- opening ----------------------------------------------------------------------------------
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

    def _level(self, k: int, array, image: dict) -> Level:
        scale, translation = _transform(image["datasets"][k], image, len(self.axes), self.path, k)
        space = self._space
        spacing = tuple(float(scale[a]) for a in space[::-1])
        if not all(math.isfinite(s) and s > 0 for s in spacing):
            raise VolumeFileError(self.path, f"level {k}: the scale of the spatial axes must be "
                                             f"positive, got {spacing} (x, y, z)", "coordinateTransformations")
        origin = tuple(float(translation[a]) for a in space[::-1])
        shape = tuple(int(array.shape[a]) for a in space)
        if 0 in shape:
            raise VolumeFileError(self.path, f"level {k} is empty: shape {shape} (z, y, x)", "datasets")
        return Level(shape, spacing, origin)

    def _stored_ranges(self, level: int):
        if not self.ours or self.time or self.channel:
            return None
        try:
            low = self._group[f"vgraph/min/{level}"][...]
            high = self._group[f"vgraph/max/{level}"][...]
        except KeyError:
            return None
        return np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)

    def _computed_ranges(self, level: int):
        shape = self.levels[level].shape
        bz = self.brick[2]
        rows = [block_ranges(self.read(level, (z, 0, 0), (z + bz, shape[1], shape[2])), self.brick)
                for z in range(0, shape[0], bz)]
        return np.concatenate([r[0] for r in rows]), np.concatenate([r[1] for r in rows])

    def __repr__(self) -> str:
        shape = " x ".join(map(str, self.levels[0].shape[::-1]))
        return f"BrickStore({self.source!r}, {shape} {self.dtype}, {len(self.levels)} levels, brick {self.brick})"


def _open_group(path: Path):
    if not path.exists():
        raise VolumeFileError(path, "store does not exist")
    if not path.is_dir():
        raise VolumeFileError(path, "is not a folder: an OME-Zarr store is a folder holding "
                                    "zarr.json (or .zgroup)")
    try:
        return zarr.open_group(str(path), mode="r")
    except Exception as error:  # GroupNotFoundError, a damaged zarr.json (JSON errors)...
        raise VolumeFileError(path, f"not a zarr group (no readable zarr.json or .zgroup): "
                                    f"{type(error).__name__}: {error}", "zarr.json") from error


def _first_image(attributes: dict, path: Path) -> dict:
    """The first multiscale image: NGFF 0.5 keeps it under "ome", 0.4 at the top level."""
    ome = attributes.get("ome") if isinstance(attributes.get("ome"), dict) else attributes
    images = ome.get("multiscales")
    if not isinstance(images, list) or not images or not isinstance(images[0], dict):
        raise VolumeFileError(path, "not an OME-Zarr image: the group attributes have no "
                                    "'multiscales' list (ome.multiscales in NGFF 0.5)", "multiscales")
    image = images[0]
    if not isinstance(image.get("datasets"), list) or not image["datasets"]:
        raise VolumeFileError(path, "the multiscale image lists no datasets (levels)",
                              "multiscales.datasets")
    return image


def _axes(image: dict, path: Path) -> list[dict]:
    """Axes as {"name", "type", "unit"?}; NGFF 0.3's plain names get their type from the name."""
    axes = image.get("axes")
    if not isinstance(axes, list) or not axes:
        raise VolumeFileError(path, "the multiscale image has no 'axes' list", "multiscales.axes")
    out = []
    for axis in axes:
        spec = {"name": axis} if isinstance(axis, str) else dict(axis) if isinstance(axis, dict) else None
        if spec is None or not isinstance(spec.get("name"), str):
            raise VolumeFileError(path, f"an axis must be a name or an object with a name, got "
                                        f"{axis!r}", "multiscales.axes")
        spec["type"] = spec.get("type") or _TYPES.get(spec["name"].lower(), "unknown")
        out.append(spec)
    return out


def _space_axes(axes: list[dict], path: Path) -> list[int]:
    """Indices of the z, y and x axes (by name when named so, else the order given)."""
    space = [a for a, spec in enumerate(axes) if spec["type"] == "space"]
    names = [axes[a]["name"] for a in space]
    if len(space) != 3:
        kind = "a 2D image" if len(space) == 2 else f"an image with {len(space)} spatial axes"
        raise VolumeFileError(path, f"{kind} (spatial axes {', '.join(names) or 'none'}): a volume "
                                    f"needs three spatial axes z, y, x", "multiscales.axes")
    by_name = {axes[a]["name"].lower(): a for a in space}
    return [by_name[n] for n in "zyx"] if set(by_name) == set("zyx") else space


def _level_arrays(group, image: dict, ndim: int, path: Path) -> list:
    arrays = []
    for k, dataset in enumerate(image["datasets"]):
        name = dataset.get("path") if isinstance(dataset, dict) else None
        try:
            array = group[str(name)]
        except (KeyError, TypeError):
            array = None
        if not isinstance(array, zarr.Array):
            raise VolumeFileError(path, f"level {k}: dataset path {name!r} is not an array in the "
                                        f"store", "multiscales.datasets")
        if array.ndim != ndim:
            raise VolumeFileError(path, f"level {k} ({name}) has {array.ndim} dimensions but "
                                        f"{ndim} axes are declared", "multiscales.axes")
        arrays.append(array)
    return arrays


def _transform(dataset: dict, image: dict, ndim: int, path: Path, k: int):
    """Scale and translation per axis of level k: the dataset's, then the image-wide one."""
    scale, translation = _scale_translation(dataset.get("coordinateTransformations"), ndim, path, k)
    outer_scale, outer_translation = _scale_translation(image.get("coordinateTransformations"),
                                                        ndim, path, k)
    return scale * outer_scale, translation * outer_scale + outer_translation


def _scale_translation(transforms, ndim: int, path: Path, k: int):
    scale, translation = np.ones(ndim), np.zeros(ndim)
    for transform in transforms or []:
        kind = transform.get("type") if isinstance(transform, dict) else None
        if kind == "identity":
            continue
        values = transform.get(kind) if kind in ("scale", "translation") else None
        if values is None or len(values) != ndim:
            raise VolumeFileError(path, f"level {k}: unsupported or malformed transformation "
                                        f"{transform!r} (need scale/translation with {ndim} values)",
                                  "coordinateTransformations")
        if kind == "scale":
            scale, translation = scale * np.asarray(values, float), translation * np.asarray(values, float)
        else:
            translation = translation + np.asarray(values, float)
    return scale, translation


def _dtype(array, path: Path) -> np.dtype:
    dtype = np.dtype(array.dtype)
    if dtype.kind not in "uif" or dtype.itemsize > 8:
        raise VolumeFileError(path, f"unsupported data type {dtype} (integer or float voxels only)",
                              "data_type")
    return dtype.newbyteorder("=")
