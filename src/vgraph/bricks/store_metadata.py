"""What an OME-Zarr image's metadata says, checked before a voxel is read (docs/guide/large-data.md).

The NGFF side: the first image of "multiscales" (under "ome" in NGFF 0.5), its axes (two or three
of type space: a 2D image is one slice), the dataset paths (relative paths inside the store) and
their scale and translation (only those: other transformation types are refused by name), axis
units (lengths converted to one unit: foreign_stores.py). The zarr side, per level: the dimensions, one data type for
every level, chunks of at most MAX_CHUNK_BYTES and a brick grid of at most MAX_BRICKS. Across
levels: the same time and channel lengths, boxes that agree with level 0's, levels no finer than the
one before along any axis (other tools' pyramids may keep an axis and need not halve exactly:
cells.py). vgraph's own stores ("vgraph" attributes, written by vgraph convert) are held to their
layout exactly: every level the halving of the one before (pyramid.next_level), chunks equal to
the recorded brick, recorded ranges that are ranges.

Every problem raises VolumeFileError naming the store and the metadata field.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from vgraph.bricks.pyramid import Level, brick_grid, next_level
from vgraph.errors import VGraphWarning, VolumeFileError
from vgraph.memory import format_bytes
from vgraph.volume_grid import IDENTITY, VolumeGeometryError, checked_direction

MAX_CHUNK_BYTES = 2**30  # one decoded chunk: zarr holds it whole while reading any voxel of it
MAX_BRICKS = 2**24       # per level: the per-brick ranges are arrays of this many values
_TYPES = {"t": "time", "c": "channel", "x": "space", "y": "space", "z": "space"}


class StoreLevelsWarning(VGraphWarning):
    """Levels of another tool's OME-Zarr image that are finer than the level before along some
    axis are not used (a pyramid's levels grow coarser): the store is rendered from the levels
    before."""


# --- the NGFF image -----------------------------------------------------------------------------------
def first_image(attributes: dict, path) -> dict:
    """The first multiscale image: NGFF 0.5 keeps it under "ome", 0.4 at the top level."""
    ome = attributes.get("ome") if isinstance(attributes.get("ome"), dict) else attributes
    images = ome.get("multiscales")
    if not isinstance(images, list) or not images or not isinstance(images[0], dict):
        raise VolumeFileError(path, "not an OME-Zarr image: the group attributes have no "
                                    "'multiscales' list (ome.multiscales in NGFF 0.5)" + _what_else(ome),
                              "multiscales")
    image = images[0]
    if not isinstance(image.get("datasets"), list) or not image["datasets"]:
        raise VolumeFileError(path, "the multiscale image lists no datasets (levels)",
                              "multiscales.datasets")
    return image


def _what_else(ome: dict) -> str:
    """What a group without an image holds instead, and where its images are."""
    if isinstance(ome.get("labels"), list):
        names = ", ".join(str(n) for n in ome["labels"][:5])
        return f"; it is a labels group: open one of its label images ({names})"
    if "plate" in ome or "well" in ome:
        return "; it is a high-content screening plate or well: open one field's image group"
    return ""


def image_axes(image: dict, path) -> list[dict]:
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
        kind = spec.get("type") or _TYPES.get(spec["name"].lower(), "unknown")
        spec["type"] = kind if isinstance(kind, str) else "unknown"
        out.append(spec)
    return out


def space_axes(axes: list[dict], path) -> list[int | None]:
    """Indices of the z, y and x axes (by name when named so, else the order given); z is None
    for a 2D image (y, x), which is read as a volume of one slice."""
    space = [a for a, spec in enumerate(axes) if spec["type"] == "space"]
    names = [axes[a]["name"] for a in space]
    if len(space) not in (2, 3):
        raise VolumeFileError(path, f"an image with {len(space)} spatial axes ({', '.join(names) or 'none'}): "
                                    f"vgraph reads images with two (y, x) or three (z, y, x)",
                              "multiscales.axes")
    by_name = {axes[a]["name"].lower(): a for a in space}
    order = "zyx"[3 - len(space):]
    chosen = [by_name[n] for n in order] if set(by_name) == set(order) else space
    return [None] * (3 - len(space)) + chosen


def dataset_path(image: dict, k: int, path) -> str:
    """Level k's array path: a relative path inside the store ('0', 'scale0/image'); never
    absolute, empty or through '.' or '..' (zarr refuses those with its own ValueError)."""
    dataset = image["datasets"][k]
    name = dataset.get("path") if isinstance(dataset, dict) else None
    parts = name.split("/") if isinstance(name, str) else []
    if not parts or any(p in ("", ".", "..") or "\\" in p or "\x00" in p for p in parts) \
            or len(name) > 1024:
        raise VolumeFileError(path, f"level {k}: dataset path {name!r} is not a path inside the store "
                                    f"(relative names separated by '/', no '.' or '..')",
                              f"multiscales.datasets[{k}].path")
    return name


def transform(image: dict, k: int, ndim: int, path):
    """Scale and translation per axis of level k: the dataset's, then the image-wide one."""
    dataset = image["datasets"][k]
    scale, translation = _scale_translation(dataset.get("coordinateTransformations"), ndim, path, k)
    outer_scale, outer_translation = _scale_translation(image.get("coordinateTransformations"),
                                                        ndim, path, k)
    with np.errstate(all="ignore"):  # overflow to inf is refused by the caller's finiteness check
        return scale * outer_scale, translation * outer_scale + outer_translation


def _scale_translation(transforms, ndim: int, path, k: int):
    scale, translation = np.ones(ndim), np.zeros(ndim)
    for transform in transforms if isinstance(transforms, list) else [transforms] if transforms else []:
        kind = transform.get("type") if isinstance(transform, dict) else None
        if kind == "identity":
            continue
        if isinstance(kind, str) and kind not in ("scale", "translation"):
            raise VolumeFileError(path, f"level {k}: a coordinate transformation of type {kind!r} "
                                        f"cannot be rendered yet (vgraph reads scale and translation, "
                                        f"what NGFF 0.4 and 0.5 allow)", "coordinateTransformations")
        if isinstance(kind, str) and kind not in transform and "path" in transform:
            raise VolumeFileError(path, f"level {k}: a {kind} stored as binary data at path "
                                        f"{_short(transform['path'])} cannot be read yet (vgraph "
                                        f"reads {kind} given as a list of numbers)",
                                  "coordinateTransformations")
        values = transform.get(kind) if kind in ("scale", "translation") else None
        numbers = _numbers(values, ndim)
        if numbers is None:
            raise VolumeFileError(path, f"level {k}: unsupported or malformed transformation "
                                        f"{_short(transform)} (need scale/translation with {ndim} "
                                        f"numbers)", "coordinateTransformations")
        with np.errstate(all="ignore"):
            if kind == "scale":
                scale, translation = scale * numbers, translation * numbers
            else:
                translation = translation + numbers
    return scale, translation


def _numbers(values, count: int) -> np.ndarray | None:
    if not isinstance(values, list) or len(values) != count \
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return None
    try:
        return np.asarray(values, dtype=np.float64)
    except OverflowError:  # an integer beyond float64
        return None


def level_geometry(image: dict, k: int, shape, space: list, ndim: int, path,
                   units=(1.0, 1.0, 1.0)) -> Level:
    """Level k as a pyramid Level: [z, y, x] voxels, (x, y, z) spacing and origin (the centre of
    voxel (0, 0, 0): the transformations map array index i to scale * i + translation, and
    index i is voxel i's centre); ``units`` scales each axis to the world's unit. A 2D image's
    slice gets the finer of its two spacings as thickness (so it does not change the sampling
    step) and origin 0."""
    scale, translation = transform(image, k, ndim, path)
    with np.errstate(all="ignore"):  # overflow to inf is refused below
        spacing = [float(scale[a]) * f if a is not None else None for a, f in zip(space[::-1], units)]
        origin = [float(translation[a]) * f if a is not None else 0.0 for a, f in zip(space[::-1], units)]
    if not all(math.isfinite(s) and s > 0 for s in spacing if s is not None):
        raise VolumeFileError(path, f"level {k}: the scale of the spatial axes must be "
                                    f"positive, got {_xyz(spacing)} (x, y, z)", "coordinateTransformations")
    if not all(math.isfinite(o) for o in origin):
        raise VolumeFileError(path, f"level {k}: the translation of the spatial axes must be finite, "
                                    f"got {_xyz(origin)} (x, y, z)", "coordinateTransformations")
    spacing = [min(spacing[:2]) if s is None else s for s in spacing]
    level_shape = tuple(int(shape[a]) if a is not None else 1 for a in space)
    if 0 in level_shape:
        raise VolumeFileError(path, f"level {k} is empty: shape {level_shape} (z, y, x)", "datasets")
    return Level(level_shape, tuple(spacing), tuple(origin))


def _xyz(values) -> tuple:
    return tuple(v for v in values if v is not None)


# --- each level's array --------------------------------------------------------------------------------
def array_field(array) -> str:
    """The metadata document of an array, for messages: '0/zarr.json' or '0/.zarray'."""
    return f"{array.path}/{'zarr.json' if array.metadata.zarr_format == 3 else '.zarray'}"


def voxel_dtype(array, path, k: int) -> np.dtype:
    try:
        dtype = np.dtype(array.dtype)
    except TypeError:  # one of zarr's own types without a NumPy equivalent
        dtype = None
    if dtype is None or dtype.kind not in "uif" or dtype.itemsize > 8:
        raise VolumeFileError(path, f"level {k}: unsupported data type {array.dtype} (integer or "
                                    f"float voxels only)", "data_type")
    return dtype.newbyteorder("=")


def stored_chunk(array) -> tuple[int, ...]:
    """The chunk that is one file (the shard of a sharded array): what zarr reads at once."""
    return tuple(int(n) for n in (array.shards or array.chunks))


def check_chunks(array, dtype: np.dtype, path, k: int) -> int:
    """The decoded bytes of one stored chunk, refused beyond MAX_CHUNK_BYTES."""
    chunk = stored_chunk(array)
    if min(chunk) < 1:
        raise VolumeFileError(path, f"level {k}: chunks of {' x '.join(map(str, chunk))} voxels: every "
                                    f"chunk edge must be at least 1", array_field(array))
    nbytes = math.prod(chunk) * dtype.itemsize
    if nbytes > MAX_CHUNK_BYTES:
        raise VolumeFileError(path, f"level {k}: a chunk of {' x '.join(map(str, chunk))} voxels is "
                                    f"{format_bytes(nbytes)} decoded, more than the "
                                    f"{format_bytes(MAX_CHUNK_BYTES)} vgraph reads at once",
                              array_field(array))
    return nbytes


def check_brick_count(level: Level, brick, path, k: int, field: str) -> None:
    count = math.prod(brick_grid(level.shape, brick))
    if count > MAX_BRICKS:
        raise VolumeFileError(path, f"level {k} has {count} bricks of {' x '.join(map(str, brick))} "
                                    f"voxels (x, y, z), more than the {MAX_BRICKS} vgraph keeps "
                                    f"ranges for: chunks this small do not suit a volume this large",
                              field)


# --- across levels -------------------------------------------------------------------------------------
def check_same_kind(arrays, dtypes, axes, space, path) -> None:
    """One data type and the same time and channel lengths on every level."""
    for k, (array, dtype) in enumerate(zip(arrays, dtypes)):
        if dtype != dtypes[0]:
            raise VolumeFileError(path, f"level {k} holds {dtype} voxels but level 0 {dtypes[0]}: the "
                                        f"levels of a pyramid have one data type", array_field(array))
        for axis, spec in enumerate(axes):
            if axis not in space and array.shape[axis] != arrays[0].shape[axis]:
                raise VolumeFileError(path, f"level {k} has {array.shape[axis]} entries along axis "
                                            f"{spec['name']!r} but level 0 {arrays[0].shape[axis]}",
                                      array_field(array))


def check_extents(levels: list[Level], path) -> None:
    """Every level must cover level 0's extent to within one of its own voxels (ceil or floor of
    n / 2^k voxels of 2^k times the spacing do), and its box (voxel edges) must lie on level 0's
    to within one of its voxels at both ends: shapes, scales or translations that disagree are
    damage (a level drawn elsewhere than level 0)."""
    base = levels[0]
    for k, level in enumerate(levels[1:], start=1):
        for axis in range(3):  # x, y, z
            n0, nk = base.shape[2 - axis], level.shape[2 - axis]
            s0, s = base.spacing[axis], level.spacing[axis]
            extent0, extent = n0 * s0, nk * s
            name = "x, y, z".split(", ")[axis]
            if abs(extent - extent0) > s * (1 + 1e-6):
                raise VolumeFileError(path, f"level {k} ({name}: {nk} voxels of {s:g}) does not cover "
                                            f"level 0's extent ({n0} voxels of {s0:g}): the levels "
                                            f"disagree", f"multiscales.datasets[{k}]")
            start0, start = base.origin[axis] - 0.5 * s0, level.origin[axis] - 0.5 * s
            if abs(start - start0) > s * (1 + 1e-6) or \
                    abs(start + extent - start0 - extent0) > s * (1 + 1e-6):
                raise VolumeFileError(path, f"level {k} ({name}: voxels of {s:g} from {start:g}) lies "
                                            f"more than one of its voxels off level 0's box ({s0:g} "
                                            f"from {start0:g}): the translations disagree",
                                      f"multiscales.datasets[{k}].coordinateTransformations")


def check_our_pyramid(levels: list[Level], path) -> None:
    """vgraph's own stores: each level exactly next_level of the one before."""
    for k in range(1, len(levels)):
        expected, level = next_level(levels[k - 1]), levels[k]
        if level.shape != expected.shape:
            raise VolumeFileError(path, f"level {k} has {level.shape} voxels (z, y, x) but the halving "
                                        f"of level {k - 1} has {expected.shape}: the store is damaged",
                                  f"multiscales.datasets[{k}]")
        if not (np.allclose(level.spacing, expected.spacing, rtol=1e-9, atol=0)
                and np.allclose(level.origin, expected.origin, rtol=1e-9, atol=1e-9 * max(expected.spacing))):
            raise VolumeFileError(path, f"level {k}: spacing {level.spacing} and origin {level.origin} "
                                        f"are not level {k - 1}'s doubled and shifted half a voxel "
                                        f"({expected.spacing}, {expected.origin})",
                                  f"multiscales.datasets[{k}].coordinateTransformations")


def coarsening_levels(levels: list[Level], path) -> int:
    """How many levels from level 0 are each no finer than the one before along every axis
    (spacing and voxel count): a pyramid of another tool may keep an axis and reduce by any
    factor (cells.py); a level finer than the one before is not a pyramid's, and it and the
    levels after it are dropped with a StoreLevelsWarning."""
    count = 1
    while count < len(levels) and _not_finer(levels[count], levels[count - 1]):
        count += 1
    if count < len(levels):
        warnings.warn(StoreLevelsWarning(
            f"{path}: level {count} ({_describe(levels[count])}) is finer than level {count - 1} "
            f"({_describe(levels[count - 1])}) along some axis; levels {count} and after are not "
            f"used (a pyramid's levels grow coarser)"), stacklevel=3)
    return count


def _not_finer(level: Level, before: Level) -> bool:
    return all(s >= b * (1 - 1e-9) for s, b in zip(level.spacing, before.spacing)) and \
        all(n <= m for n, m in zip(level.shape, before.shape))


def _describe(level: Level) -> str:
    return f"{level.shape} voxels (z, y, x) of {tuple(float(f'{s:.6g}') for s in level.spacing)} (x, y, z)"


# --- vgraph's own attributes ---------------------------------------------------------------------------
def our_attributes(attributes: dict, levels: int, voxels: int, path) -> dict | None:
    """The "vgraph" attributes of a store written by vgraph convert, checked; None for another
    tool's image."""
    ours = attributes.get("vgraph")
    if ours is None:
        return None
    if not isinstance(ours, dict):
        raise VolumeFileError(path, f"the vgraph attributes must be an object, got {_short(ours)}", "vgraph")
    if ours.get("format") != 1:
        raise VolumeFileError(path, f"unknown store format {_short(ours.get('format'))} (this vgraph "
                                    f"reads format 1)", "vgraph.format")
    brick = ours.get("brick")
    if not (isinstance(brick, list) and len(brick) == 3
            and all(isinstance(b, int) and not isinstance(b, bool) and 0 < b <= 2**20 for b in brick)):
        raise VolumeFileError(path, f"brick must be three positive integers (x, y, z), got "
                                    f"{_short(brick)}", "vgraph.brick")
    if ours.get("levels") != levels:
        raise VolumeFileError(path, f"the store records {_short(ours.get('levels'))} levels but lists "
                                    f"{levels} datasets", "vgraph.levels")
    nonfinite = ours.get("nonfinite")
    if not (isinstance(nonfinite, int) and not isinstance(nonfinite, bool) and 0 <= nonfinite <= voxels):
        raise VolumeFileError(path, f"nonfinite must be a count of voxels (0 to {voxels}), got "
                                    f"{_short(nonfinite)}", "vgraph.nonfinite")
    return {"brick": tuple(brick), "nonfinite": nonfinite, "direction": _direction(ours, path),
            "value_range": _range(ours.get("value_range"), "value_range", path, required=True),
            "declared_range": _range(ours.get("declared_range"), "declared_range", path),
            "data_range": _range(ours.get("data_range"), "data_range", path)}


def _direction(ours: dict, path):
    """vgraph.direction (rows of Volume.direction, written by vgraph convert for a turned
    volume: NGFF 0.4/0.5 hold no rotation), default identity."""
    if "direction" not in ours:
        return IDENTITY
    value = ours["direction"]
    if not (isinstance(value, list) and len(value) == 3
            and all(_numbers(row, 3) is not None for row in value)):
        raise VolumeFileError(path, f"direction must be three rows of three numbers, got "
                                    f"{_short(value)}", "vgraph.direction")
    try:
        return checked_direction(value)
    except VolumeGeometryError as error:
        raise VolumeFileError(path, error.reason, "vgraph.direction") from None


def _range(value, name: str, path, required: bool = False):
    if value is None and not required:
        return None
    numbers = _numbers(value, 2)
    if numbers is None or not np.isfinite(numbers).all() or numbers[0] > numbers[1]:
        raise VolumeFileError(path, f"{name} must be two finite numbers, low <= high, got "
                                    f"{_short(value)}", f"vgraph.{name}")
    return (float(numbers[0]), float(numbers[1]))


def check_range_array(array, level: Level, brick, path, k: int, which: str) -> None:
    """vgraph/min/<k> or vgraph/max/<k>: float64 over level k's brick grid."""
    grid = brick_grid(level.shape, brick)
    if tuple(array.shape) != grid or np.dtype(array.dtype) != np.float64:
        raise VolumeFileError(path, f"the per-brick {which} of level {k} are {tuple(array.shape)} "
                                    f"{array.dtype}, not float64 over the level's {grid} bricks (z, y, "
                                    f"x): the store is damaged", f"vgraph/{which}/{k}")


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
