"""Fuzz cases for OME-Zarr stores, the "stores" target of fuzz_cases.py (docs/guide/large-data.md).

A case is a valid store built from scratch, then damaged the ways stores get damaged:
- seeds: vgraph's own (vgraph convert: per-brick statistics, NGFF 0.5 on zarr v3), another
  tool's on zarr v3 (two levels, the second by striding) and on zarr v2 (NGFF 0.4, time and
  channel axes), tiny volumes of every voxel type (fuzz_seeds.volume_values);
- metadata: a zarr.json, .zarray or .zattrs edited as a document (values replaced by extremes,
  keys deleted, shapes, chunk shapes, data types, fill values, dataset paths, scales changed);
- chunks: truncated, bits flipped, deleted, emptied, swapped with another chunk (another shape),
  grown past anything a chunk can be, replaced by a decompression bomb (a zstd frame declaring
  64 MiB or declaring nothing, a blosc header claiming a gigabyte);
- links and special files: a file replaced by a symbolic link to /dev/zero, to a file outside
  the store, to a folder, to itself (a loop) or to nothing, or by a FIFO.

``open_store`` is what run_case does with a case: open it as VolumeSource does and read a little
(value range, percentiles, a brick of the coarsest level and its ranges, the whole array when it
is small). The contract: a result or a VGraphError, within bench/fuzz.py's time and memory limits.
"""

from __future__ import annotations

import copy
import json
import math
import tempfile
from pathlib import Path

import numpy as np

from fuzz_seeds import Case, volume_values

STORE = "v.zarr"
OUTSIDE = "outside.bin"  # a regular file beside the store, for links that leave it
METADATA = (".zarray", ".zattrs", ".zgroup", "zarr.json")
NUMBERS = (0, -1, 1, 3, 2**31, 2**63, 10**11, 10**30, 1e308, -1e308, 0.5, float("nan"),
           float("inf"), 1e-320)
VALUES = NUMBERS + (None, True, "", "x" * 5000, [], {}, [[]], "../x", "/dev/zero", "\ud800",
                    [1, 2], [1, 2, 3], [0, 0, 0], [10**11, 1, 1], [-4, 4, 4], [1e308, 1, 1])
DATA_TYPES = ("uint8", "int64", "float16", "complex64", "bool", "string", "|S4", "<f8", ">i2",
              "V8", "uint99", "")
PATHS = ("../x", "/etc", "", ".", "0/../1", "a//b", "vgraph", "vgraph/min/0", "0/c", "1" * 5000,
         "\u0000", 0, None)
LINK_TARGETS = ("/dev/zero", "/dev/null", "/dev/urandom", "/proc/self/mem", ".", "..", "missing",
                "/")


# --- seeds --------------------------------------------------------------------------------------------
def store(rng) -> Case:
    """A valid store of one of the three kinds, then 0 to 3 store damages."""
    with tempfile.TemporaryDirectory(prefix="vgraph-fuzz-store-") as scratch:
        folder = Path(scratch)
        kind = rng.choice((ours, ours, foreign_v3, foreign_v2))
        kind(rng, folder)
        files = {f"{STORE}/{p.relative_to(folder / STORE).as_posix()}": p.read_bytes()
                 for p in sorted((folder / STORE).rglob("*")) if p.is_file()}
    header = f"{STORE}/zarr.json" if f"{STORE}/zarr.json" in files else f"{STORE}/.zattrs"
    files = {header: files.pop(header), **files}  # first: fuzz_cases' random-bytes case replaces it
    files[OUTSIDE] = bytes(range(256)) * 4
    case = Case("stores", files, STORE, header=header)
    for _ in range(rng.choice((0, 1, 1, 2, 3))):
        damage(rng, case)
    return case


def ours(rng, folder: Path) -> None:
    from vgraph.io.convert import convert
    values = volume_values(rng)
    np.save(folder / "v.npy", values)
    convert(folder / "v.npy", folder / STORE, brick=rng.choice((2, 4)), progress=False)


def foreign_v3(rng, folder: Path) -> None:
    import zarr
    values = volume_values(rng)
    group = zarr.open_group(str(folder / STORE), mode="w", zarr_format=3)
    levels = [values, values[::2, ::2, ::2]]
    chunks = tuple(rng.choice((1, 2, 3)) for _ in range(3))
    for k, level in enumerate(levels):
        group.create_array(str(k), shape=level.shape, chunks=chunks, dtype=level.dtype,
                           fill_value=rng.choice((0, 1)))[...] = level
    group.attrs["ome"] = {"version": "0.5", "multiscales": [_image(rng, "zyx", len(levels))]}


def foreign_v2(rng, folder: Path) -> None:
    import zarr
    base = volume_values(rng, "uint16")
    values = np.stack([base, base[::-1]])[:, None]  # time 2, channel 1
    group = zarr.open_group(str(folder / STORE), mode="w", zarr_format=2)
    group.create_array("0", shape=values.shape, chunks=(1, 1, 2, 2, 2), dtype=values.dtype)[...] = values
    group.attrs["multiscales"] = [{"version": "0.4", **_image(rng, "tczyx", 1)}]


def _image(rng, names: str, count: int) -> dict:
    types = {"t": "time", "c": "channel"}
    axes = [{"name": n, "type": types.get(n, "space"), **({"unit": "micrometer"} if n in "zyx" else {})}
            for n in names]
    scale = [1.0] * (len(names) - 3) + [rng.uniform(0.1, 3), 1.0, 2.0]
    return {"axes": axes, "datasets": [{"path": str(k), "coordinateTransformations": [
        {"type": "scale", "scale": [s * (2**k if n in "zyx" else 1) for s, n in zip(scale, names)]},
        {"type": "translation", "translation": [0.0] * len(names)}]} for k in range(count)]}


# --- damage -------------------------------------------------------------------------------------------
def damage(rng, case: Case) -> None:
    """One damage of the store in place (see the module docstring)."""
    kind = rng.choice((_edit_metadata, _edit_metadata, _edit_metadata, _edit_chunk, _edit_chunk,
                       _link, _fifo))
    kind(rng, case)


def _metadata_names(case: Case) -> list[str]:
    return [n for n in case.files if n.rpartition("/")[2] in METADATA]


def _chunk_names(case: Case) -> list[str]:
    return [n for n in case.files if n.startswith(STORE + "/") and n.rpartition("/")[2] not in METADATA]


def _edit_metadata(rng, case: Case) -> None:
    names = _metadata_names(case)
    if not names:
        return
    name = rng.choice(names)
    try:
        document = json.loads(case.files[name])
    except ValueError:
        return
    _edit_document(rng, document)
    case.files[name] = json.dumps(document, allow_nan=True).encode("utf-8", "surrogatepass")


def _edit_document(rng, document) -> None:
    places = list(_places(document))
    if not places:
        return
    container, key = rng.choice(places)
    value = container[key]
    targeted = {"shape": NUMBERS, "chunk_shape": NUMBERS, "chunks": NUMBERS, "scale": NUMBERS,
                "translation": NUMBERS, "data_type": DATA_TYPES, "dtype": DATA_TYPES,
                "path": PATHS, "fill_value": NUMBERS + ("NaN", "Infinity", "0x7fc00000", None)}
    choice = rng.random()
    if key in targeted and isinstance(value, list) and value and choice < 0.6:
        value[rng.randrange(len(value))] = rng.choice(targeted[key])
    elif key in targeted and choice < 0.8:
        container[key] = rng.choice(targeted[key])
    elif choice < 0.2 and isinstance(container, dict):
        del container[key]
    elif choice < 0.3 and isinstance(value, list) and value:
        del value[rng.randrange(len(value))]
    elif choice < 0.4 and isinstance(value, list) and value:
        value.append(copy.deepcopy(value[-1]))
    else:
        container[key] = copy.deepcopy(rng.choice(VALUES))


def _places(node, depth: int = 0):
    """(container, key) of every value in a document."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in list(items):
        yield node, key
        if depth < 20:
            yield from _places(value, depth + 1)


def _edit_chunk(rng, case: Case) -> None:
    names = _chunk_names(case)
    if not names:
        return
    name = rng.choice(names)
    data = bytearray(case.files[name])
    kind = rng.randrange(7)
    if kind == 0:
        _remove(case, name)
    elif kind == 1 and data:
        del data[rng.randrange(len(data)):]
    elif kind == 2 and data:
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    elif kind == 3:
        data = bytearray(case.files[rng.choice(names)])  # another chunk: often another shape
    elif kind == 4:
        data += rng.randbytes(rng.choice((100, 70_000, 300_000)))
    elif kind == 5:
        data = bytearray(_bomb(rng, bytes(data)))
    else:
        data = bytearray()
    if name in case.files:
        case.files[name] = bytes(data)


def _bomb(rng, chunk: bytes) -> bytes:
    import numcodecs
    kind = rng.randrange(3)
    if kind == 0:
        return numcodecs.Zstd().encode(bytes(rng.choice((2**16, 2**26))))
    if kind == 1:
        return zstd_frame_without_size(rng.choice((1, 10, 1000)))
    return chunk[:4] + rng.choice((2**30, 2**32 - 1)).to_bytes(4, "little") + chunk[8:]


def zstd_frame_without_size(blocks: int) -> bytes:
    """A zstd frame that declares no content size, of RLE blocks of 128 KiB zeros (4 bytes each):
    numcodecs decodes it into a growing buffer, 128 MiB from 4 KB for 1000 blocks."""
    frame = (0xFD2FB528).to_bytes(4, "little") + bytes([0x00, 7 << 3])  # no size; window 128 KiB
    for i in range(blocks):
        frame += ((131072 << 3) | (1 << 1) | (i == blocks - 1)).to_bytes(3, "little") + b"\0"
    return frame


def _link(rng, case: Case) -> None:
    name = _any_store_file(rng, case)
    if name is None:
        return
    depth = name.count("/")
    target = rng.choice(LINK_TARGETS + ("../" * depth + OUTSIDE, name.rpartition("/")[2], "self"))
    _remove(case, name)
    case.links[name] = name.rpartition("/")[2] if target == "self" else target


def _fifo(rng, case: Case) -> None:
    name = _any_store_file(rng, case)
    if name is not None:
        _remove(case, name)
        case.fifos.add(name)


def _remove(case: Case, name: str) -> None:
    del case.files[name]
    if case.header == name:
        case.header = None  # no longer a document fuzz_cases' line edits can take


def _any_store_file(rng, case: Case) -> str | None:
    metadata, chunks = _metadata_names(case), _chunk_names(case)
    pool = metadata if metadata and (not chunks or rng.random() < 0.3) else chunks
    return rng.choice(pool) if pool else None


# --- opening -------------------------------------------------------------------------------------------
def open_store(path: Path):
    """Open the store as VolumeSource does and read a little of it."""
    from vgraph.bricks.pyramid import brick_grid
    from vgraph.io import read_volume
    volume = read_volume(path)
    source = volume.bricks
    coarsest = len(source.levels) - 1
    volume.value_range
    source.read(coarsest, (0, 0, 0), tuple(source.brick)[::-1])
    source.brick_ranges(coarsest)
    volume.percentiles([1, 50, 99])
    volume.nonfinite_count
    if volume.nbytes <= 2**20 and math.prod(brick_grid(source.levels[0].shape, source.brick)) <= 512:
        volume.data
    return volume
