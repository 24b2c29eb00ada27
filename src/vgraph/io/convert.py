"""``vgraph convert``: a volume file -> an OME-Zarr pyramid of bricks (docs/guide/large-data.md).

The input is read in slabs of one brick row (``brick`` z slices) where its format allows
(slabs.py); each slab is written to level 0 and halved (pyramid.halve, or pyramid.halve_labels
for a label volume; in pieces along y so its
float64 temporary stays small) into half a slab of level 1, two of which make a level-1 slab,
and so on down the levels. Memory therefore holds about one slab per level, whatever the
volume's size: level 0's slab, at most one slab being assembled per coarser level, and the
halving's pieces. The levels equal ArrayPyramid's exactly, since a 2x2x2 group never straddles
two slabs (the brick's z size is even).

Orientation: OME-Zarr 0.4/0.5 hold a scale and a translation per level, no rotation. A volume
whose direction is not the identity keeps it in the store's "vgraph" attributes (BrickStore reads
it back), with a StoreOrientationWarning: other tools show such a store unrotated. A mirrored
direction (determinant -1) is stored as a rotation by storing the voxels of every x row in
reverse order (the origin moves to the last voxel of the row), so that every voxel keeps its
world position: a brick pyramid cannot be mirrored for free when it is drawn (the ray casters
turn a box by a rotation; mirroring would mean reading every brick reversed).

The store is written into a temporary folder beside OUT (``.<OUT name>.<pid>.<random>.tmp``) and
renamed to OUT only when complete; an existing OUT is replaced only then, and only if it is a
zarr store. A failure removes the temporary folder and leaves OUT as it was.
"""

from __future__ import annotations

import dataclasses
import math
import os
import resource
import shutil
import sys
import tempfile
import time
import tracemalloc
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vgraph.atomic import remove_stale_temporaries
from vgraph.bricks.pyramid import Level, halve, halver, level_count, next_level
from vgraph.io.slabs import SlabInput, open_input
from vgraph.bricks.store_writer import StoreWriter
from vgraph.errors import OutputFileError, VGraphError, VGraphWarning
from vgraph.memory import format_bytes
from vgraph.value_range import range_of
from vgraph.volume_grid import checked_direction, is_identity

DEFAULT_BRICK = 64
MAX_BRICK = 1024
HALVING_PIECE_VOXELS = 2**18  # voxels halved at once: a 2 MiB float64 temporary


@dataclass
class ConvertReport:
    source: str
    output: str
    how: str                                 # streamed, or read whole and why
    shapes: list[tuple[int, int, int]]       # per level, [z, y, x]
    brick: tuple[int, int, int]              # (x, y, z)
    dtype: str
    value_range: tuple[float, float]
    seconds: float
    peak_rss_bytes: int                      # ru_maxrss: the process's peak resident memory so far
    bytes_written: int
    traced_peak_bytes: int | None = None     # tracemalloc's peak during the conversion, if traced
    notes: list[str] = field(default_factory=list)

    def text(self) -> str:
        levels = "; ".join(f"{k}: {'x'.join(map(str, s[::-1]))}" for k, s in enumerate(self.shapes))
        lines = [f"converted {self.source} -> {self.output}",
                 f"  input: {self.how}",
                 f"  {len(self.shapes)} levels (voxels x, y, z) {levels}",
                 f"  bricks {' x '.join(map(str, self.brick))}, {self.dtype}, value range "
                 f"{self.value_range[0]:g} .. {self.value_range[1]:g}",
                 f"  {self.seconds:.2f} s, {format_bytes(self.bytes_written)} written, peak resident "
                 f"memory of the process {format_bytes(self.peak_rss_bytes)} (ru_maxrss)"]
        if self.traced_peak_bytes is not None:
            lines.append(f"  peak of traced allocations during the conversion "
                         f"{format_bytes(self.traced_peak_bytes)} (tracemalloc)")
        return "\n".join(lines + [f"  note: {n}" for n in self.notes])


def convert(source, output, *, brick=DEFAULT_BRICK, levels: int | None = None, raw: dict | None = None,
            time_step: int = 0, progress: bool = True, trace_memory: bool = False) -> ConvertReport:
    """Convert the volume file ``source`` into the OME-Zarr store ``output`` (a folder, by
    convention named .zarr). ``brick``: voxels per brick edge, one even number or (x, y, z);
    ``levels``: pyramid levels (default: until the coarsest fits in one brick); ``raw`` and
    ``time_step`` as in vgraph.io.read_volume. ``trace_memory`` measures the conversion's peak
    allocation with tracemalloc (slower)."""
    began = time.perf_counter()
    brick = checked_brick(brick)
    output = _checked_output(Path(output))
    if trace_memory:
        tracemalloc.start()
        tracemalloc.reset_peak()
    try:
        data, mirrored = as_rotation(open_input(source, raw=raw, time_step=time_step))
        pyramid = _levels(data, brick, levels)
        with atomic_folder(output) as folder:
            writer = StoreWriter(folder, pyramid, data.dtype, brick,
                                 holds_labels=data.holds_labels)
            stats = write_levels(data, writer, brick, progress, mirrored)
            value_range = data.declared_range or range_of(stats.data_range)
            writer.finish(value_range, data.declared_range, stats.data_range, stats.nonfinite,
                          name=Path(str(source)).name, direction=data.direction)
        if not is_identity(data.direction):
            _warn_turned(output, data.direction, mirrored)
        traced = tracemalloc.get_traced_memory()[1] if trace_memory else None
    finally:
        if trace_memory:
            tracemalloc.stop()
    notes = [] if data.streamed else ["the whole input was in memory: convert an uncompressed "
                                      "raw, NRRD, NIfTI, MetaImage or .npy file to stream it"]
    return ConvertReport(str(source), str(output), data.how, [lv.shape for lv in pyramid], brick,
                         str(data.dtype), tuple(value_range), time.perf_counter() - began,
                         resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                         _folder_bytes(output), traced, notes)


class StoreOrientationWarning(VGraphWarning):
    """A store's direction is not the identity: only vgraph reads it back (module docstring)."""


def as_rotation(data: SlabInput) -> tuple[SlabInput, bool]:
    """The input with a proper rotation as its direction, and whether its x rows must be stored
    reversed for that (a mirrored direction: the module docstring says why)."""
    direction = np.asarray(data.direction)
    if np.linalg.det(direction) > 0:
        return data, False
    last_x = (data.shape[2] - 1) * data.spacing[0]
    origin = tuple(float(v) for v in np.asarray(data.origin) + direction[:, 0] * last_x)
    direction = direction * np.array([-1.0, 1.0, 1.0])  # the x column turned round
    return dataclasses.replace(data, origin=origin, direction=checked_direction(direction)), True


def _warn_turned(output: Path, direction, mirrored: bool) -> None:
    mirror = ", x mirrored to make it a rotation" if mirrored else ""
    warnings.warn(StoreOrientationWarning(
        f"{output}: the volume's axes are turned against the world's (direction "
        f"{np.round(direction, 4).tolist()}{mirror}); OME-Zarr holds no rotation, so it is kept in "
        f"the store's vgraph attributes: vgraph reads it back, other tools show the store "
        f"unrotated"), stacklevel=3)


def checked_brick(brick) -> tuple[int, int, int]:
    values = (brick,) * 3 if isinstance(brick, (int, np.integer)) else tuple(brick)
    if len(values) != 3 or not all(isinstance(b, (int, np.integer)) and 2 <= b <= MAX_BRICK
                                   and b % 2 == 0 for b in values):
        raise VGraphError(f"brick must be an even number of voxels from 2 to {MAX_BRICK} (or three "
                          f"of them, x y z), got {brick!r}: halving pairs slices, and a pair must "
                          f"not straddle two bricks")
    return tuple(int(b) for b in values)


def _levels(data: SlabInput, brick, levels: int | None) -> list[Level]:
    count = level_count(data.shape, brick) if levels is None else levels
    most = 1 + max(math.ceil(math.log2(n)) for n in data.shape)  # until every axis has 1 voxel
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or not 1 <= count <= most:
        raise VGraphError(f"levels must be an integer from 1 to {most} for {data.source} "
                          f"({' x '.join(map(str, data.shape[::-1]))} voxels), got {levels!r}")
    out = [Level(tuple(data.shape), tuple(data.spacing), tuple(data.origin))]
    while len(out) < count:
        out.append(next_level(out[-1]))
    return out


@dataclass
class _Stats:
    low: float = math.inf
    high: float = -math.inf
    nonfinite: int = 0

    @property
    def data_range(self):
        return (self.low, self.high) if self.low <= self.high else None


def write_levels(data: SlabInput, writer: StoreWriter, brick, progress: bool, mirrored: bool,
                 doing: str = "converting") -> _Stats:
    """Stream level 0 slab by slab, feeding the coarser levels as halves come in; ``mirrored``:
    each x row reversed (as_rotation). ``data`` is anything with ``shape``, ``source`` and
    ``slab(z0, z1)`` (the chunked volume filters pass their filtered slabs);
    ``doing`` names the work in the progress bar."""
    stats, bz = _Stats(), brick[2]
    cascade = _Cascade(writer, bz)
    depth = data.shape[0]
    with tqdm(total=depth, unit="slice", desc=f"{doing} {Path(data.source).name}", file=sys.stderr,
              leave=False, disable=None if progress else True) as bar:
        for z0 in range(0, depth, bz):
            slab = data.slab(z0, min(z0 + bz, depth))
            if mirrored:
                slab = np.ascontiguousarray(slab[:, :, ::-1])
            _count(slab, stats)
            cascade.push(0, slab)
            bar.update(slab.shape[0])
            del slab  # before the next one is read: else two slabs are alive at once
    cascade.flush()
    return stats


def _count(slab: np.ndarray, stats: _Stats) -> None:
    if slab.dtype.kind == "f":
        finite = np.isfinite(slab)
        missing = int(slab.size - np.count_nonzero(finite))
        stats.nonfinite += missing
        slab = slab[finite] if missing else slab
    if slab.size:
        stats.low, stats.high = min(stats.low, float(slab.min())), max(stats.high, float(slab.max()))


class _Cascade:
    """Slabs of every level in z order: a written slab of level k is halved into level k + 1's
    pending slices, which are written once a whole brick row (or the level's end) is there."""

    def __init__(self, writer: StoreWriter, bz: int):
        self.writer, self.bz = writer, bz
        self.step = halver(writer.holds_labels)
        count = len(writer.levels)
        self.next_z = [0] * count
        self.pending: list[list[np.ndarray]] = [[] for _ in range(count)]

    def push(self, k: int, slab: np.ndarray) -> None:
        self.writer.write_slab(k, self.next_z[k], slab)
        self.next_z[k] += slab.shape[0]
        if k + 1 < len(self.next_z):
            self._collect(k + 1, halve_slab(slab, self.step))

    def _collect(self, k: int, half: np.ndarray) -> None:
        self.pending[k].append(half)
        if sum(p.shape[0] for p in self.pending[k]) >= self.bz:
            self._emit(k)

    def _emit(self, k: int) -> None:
        slab = np.concatenate(self.pending[k]) if len(self.pending[k]) > 1 else self.pending[k][0]
        self.pending[k] = [slab[self.bz:]] if slab.shape[0] > self.bz else []
        self.push(k, slab[:self.bz])

    def flush(self) -> None:
        """The levels' last (short) slabs, finest first: each feeds the next level's."""
        for k in range(1, len(self.pending)):
            while self.pending[k]:
                self._emit(k)


def halve_slab(slab: np.ndarray, step=halve) -> np.ndarray:
    """``step`` (pyramid.halve or halve_labels) of a slab computed in pieces of an even number of
    y rows (each output voxel is computed exactly as step computes it, so the result is identical)."""
    depth, rows, width = slab.shape
    rows_at_once = max(2, (HALVING_PIECE_VOXELS // max(1, depth * width)) // 2 * 2)
    if rows_at_once >= rows:
        return step(slab)
    out = np.empty(((depth + 1) // 2, (rows + 1) // 2, (width + 1) // 2), dtype=slab.dtype)
    for y0 in range(0, rows, rows_at_once):
        piece = step(slab[:, y0:y0 + rows_at_once])
        out[:, y0 // 2:y0 // 2 + piece.shape[1]] = piece
    return out


# --- the output folder ----------------------------------------------------------------------------
def _checked_output(output: Path) -> Path:
    if not output.name or output.name in (".", ".."):
        raise OutputFileError(output, "give the store's folder name, e.g. volume.zarr")
    if output.suffix.lower() != ".zarr":
        raise OutputFileError(output, "a store's name must end in .zarr (VolumeSource recognises "
                                      "stores by it)")
    if not output.parent.is_dir():
        raise OutputFileError(output, f"the folder {str(output.parent)!r} does not exist")
    if output.exists() and not is_zarr_store(output):
        raise OutputFileError(output, "exists and is not a zarr store: not replaced (remove it or "
                                      "choose another name)")
    return output


def is_zarr_store(path: Path) -> bool:
    return path.is_dir() and any((path / name).is_file() for name in ("zarr.json", ".zgroup"))


@contextmanager
def atomic_folder(output: Path):
    """A temporary folder beside ``output`` that replaces it when the block succeeds."""
    remove_stale_temporaries(output)  # of conversions killed halfway
    try:
        folder = Path(tempfile.mkdtemp(prefix=f".{output.name}.{os.getpid()}.", suffix=".tmp",
                                       dir=output.parent))
    except OSError as error:
        raise OutputFileError(output, error.strerror or str(error)) from None
    try:
        yield folder
        _replace(folder, output)
    except OSError as error:
        shutil.rmtree(folder, ignore_errors=True)
        raise OutputFileError(output, error.strerror or str(error)) from error
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise


def _replace(folder: Path, output: Path) -> None:
    """Two renames (a folder cannot be renamed over a non-empty one): the old store aside, the
    new one in; the old one is restored if the second rename fails."""
    if not output.exists():
        os.rename(folder, output)
        return
    old = folder.with_name(folder.name[:-len(".tmp")] + ".old.tmp")
    os.rename(output, old)
    try:
        os.rename(folder, output)
    except OSError:
        os.rename(old, output)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _folder_bytes(folder: Path) -> int:
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())
