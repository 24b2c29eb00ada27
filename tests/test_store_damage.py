"""Damaged and hostile OME-Zarr stores (issue 27, defects 1-4): every file a store reads is a
regular file of bounded size, its metadata is cross-checked before a voxel is read, a missing chunk
is what the store's own statistics say it is, value ranges never read a whole huge array, and every
refusal is `vgraph run` exit 2 naming the store, the level and the chunk or field, with nothing
after the message.

Reproductions that could hang or exhaust memory if they regressed (/dev/zero, FIFOs, 1e11 voxels)
run `vgraph run` in a subprocess under a timeout and an address-space limit (RLIMIT_AS): a
regression fails the test instead of taking the machine.
"""

import gzip
import json
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import warnings

import numcodecs
import numpy as np
import PIL.Image
import pytest
import zarr

from vgraph.bricks import store as store_module
from vgraph.io.convert import convert
from vgraph.bricks.store import BrickStore
from vgraph.bricks.store_metadata import StoreLevelsWarning
from vgraph.bricks.volume import BrickedVolume
from vgraph.cli import main
from vgraph.errors import VolumeFileError
from fuzz_stores import zstd_frame_without_size

SHAPE = (72, 128, 128)  # [z, y, x] uint8: 1.1 MiB, over VolumeSource's smallest budget (1 MiB)
BRICK = 16
ADDRESS_SPACE = 3 * 2**30  # a vgraph run peaks at about 1.5 GB of address space (GL, BLAS threads)
TIMEOUT = 180


def blob() -> np.ndarray:
    """A bright ball in a dark box: the bricks in the corners are all zero (vgraph convert writes
    no chunk for them), those in the middle are not."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in SHAPE), indexing="ij")
    r = np.sqrt(x * x + y * y + z * z)
    return np.where(r < 0.7, 60 + 190 * (1 - r / 0.7), 0).astype(np.uint8)


@pytest.fixture(scope="module")
def converted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("converted")
    np.save(folder / "v.npy", blob())
    convert(folder / "v.npy", folder / "v.zarr", brick=BRICK, progress=False)
    return folder / "v.zarr"


@pytest.fixture
def store(converted, tmp_path):
    """A fresh copy of the converted store for a test to damage."""
    return shutil.copytree(converted, tmp_path / "v.zarr")


def edit(path, change) -> None:
    document = json.loads(path.read_text())
    change(document)
    path.write_text(json.dumps(document))


def level_0_chunk(store, z=2, y=4, x=4):
    """A chunk of the ball's middle (not all zero)."""
    return store / "0" / "c" / str(z) / str(y) / str(x)


def run(store, tmp_path, capsys, *extra):
    """`vgraph run` of the store in this process: (exit code, stderr)."""
    code = main(["run", str(store), "-o", str(tmp_path / "out.png"), "--size", "32x32", *extra])
    return code, capsys.readouterr().err


def run_bounded(store, tmp_path, *extra):
    """`vgraph run` in a subprocess under TIMEOUT seconds and ADDRESS_SPACE bytes: (exit code,
    stderr)."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
    code = "import sys; from vgraph.cli import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    done = subprocess.run([sys.executable, "-c", code, "run", str(store), "-o", str(tmp_path / "out.png"),
                           "--size", "32x32", *extra], capture_output=True, text=True,
                          timeout=TIMEOUT, preexec_fn=limit, env=env)
    return done.returncode, done.stderr


def only_the_message(stderr: str) -> str:
    """The one 'vgraph: error:' line, with nothing after it (no traceback, no asyncio noise)."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("vgraph: error:"), stderr
    return lines[0]


# --- defect 1: only regular files ---------------------------------------------------------------------
@pytest.mark.parametrize("budget", [[], ["--set", "source.memory_budget=1"]], ids=["whole", "bricked"])
def test_a_chunk_linked_to_dev_zero_is_refused_naming_store_level_and_chunk(store, tmp_path, budget):
    chunk = level_0_chunk(store)
    chunk.unlink()
    chunk.symlink_to("/dev/zero")
    code, stderr = run_bounded(store, tmp_path, *budget)
    message = only_the_message(stderr)
    assert code == 2
    assert f"{store} [0/c/2/4/4]: level 0: chunk 0/c/2/4/4 is not a regular file (a character device)" \
        in message


def test_a_chunk_that_is_a_fifo_is_refused_without_waiting_for_a_writer(store, tmp_path):
    chunk = level_0_chunk(store)
    chunk.unlink()
    os.mkfifo(chunk)
    code, stderr = run_bounded(store, tmp_path)
    assert code == 2
    assert "level 0: chunk 0/c/2/4/4 is not a regular file (a FIFO)" in only_the_message(stderr)


@pytest.mark.parametrize("kind", ["dev_zero", "fifo", "folder"])
@pytest.mark.parametrize("document", ["zarr.json", "0/zarr.json"])
def test_metadata_that_is_not_a_regular_file_is_refused(store, tmp_path, kind, document):
    path = store / document
    path.unlink()
    {"dev_zero": lambda: path.symlink_to("/dev/zero"), "fifo": lambda: os.mkfifo(path),
     "folder": path.mkdir}[kind]()
    code, stderr = run_bounded(store, tmp_path)
    assert code == 2
    kind_name = {"dev_zero": "a character device", "fifo": "a FIFO", "folder": "a folder"}[kind]
    assert f"[{document}]: is not a regular file ({kind_name})" in only_the_message(stderr)


def test_links_are_followed_to_regular_files_and_a_loop_is_refused(store, tmp_path, capsys):
    """A link is judged by what it leads to, as for every volume file: to a chunk outside the
    store it is read; a loop is refused naming the chunk."""
    expected = BrickStore(store).read(0, (0, 0, 0), SHAPE)
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    chunk = level_0_chunk(store)
    shutil.move(chunk, outside / "chunk")
    chunk.symlink_to(outside / "chunk")
    np.testing.assert_array_equal(BrickStore(store).read(0, (0, 0, 0), SHAPE), expected)
    chunk.unlink()
    chunk.symlink_to(chunk)
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2
    assert "level 0: chunk 0/c/2/4/4 cannot be read: Too many levels of symbolic links" \
        in only_the_message(stderr)


def test_a_chunk_file_larger_than_its_chunk_can_be_is_refused_before_it_is_read(store, tmp_path, capsys,
                                                                                monkeypatch):
    level_0_chunk(store).write_bytes(b"\0" * 10 * 2**20)
    from vgraph.bricks import store_files
    spans, original = [], store_files._read_span
    monkeypatch.setattr(store_files, "_read_span", lambda fd, start, stop:
                        spans.append(stop - start) or original(fd, start, stop))
    with pytest.raises(VolumeFileError, match=r"v.zarr \[0/c/2/4/4\]: level 0: chunk 0/c/2/4/4 is 10.0 MiB, "
                                              r"more than a chunk of this store can be \(72.0 KiB\)"):
        BrickStore(store).read(0, (32, 64, 64), (48, 80, 80))
    assert spans and max(spans) < 2**20  # metadata and the other chunks only
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2 and "is 10.0 MiB" in only_the_message(stderr)


def foreign_store(path, codec):
    """Another tool's one-level store of 8^3-voxel uint8 chunks written with ``codec``."""
    group = zarr.open_group(str(path), mode="w", zarr_format=3)
    array = group.create_array("0", shape=(16, 16, 16), chunks=(8, 8, 8), dtype="uint8", compressors=codec)
    array[...] = 9
    group.attrs["ome"] = {"version": "0.5", "multiscales": [{"axes": list("zyx"), "datasets": [
        {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 1]}]}]}]}
    return path


@pytest.mark.parametrize("codec, bomb, said", [
    ("zstd", lambda: numcodecs.Zstd().encode(np.zeros(256 * 2**20, np.uint8)),
     "declares 268,435,456 decoded bytes (zstd)"),
    ("zstd", lambda: zstd_frame_without_size(1000), "has blocks that regenerate up to"),
    ("gzip", lambda: gzip.compress(bytes(32 * 2**20)), "inflates to"),
])
def test_a_chunk_that_would_decode_beyond_its_chunk_is_refused_before_decoding(tmp_path, capsys, codec,
                                                                                bomb, said):
    """A 2 KB zstd chunk decoded to 256 MiB before zarr compared it with the chunk's 512 bytes."""
    from zarr.codecs import GzipCodec, ZstdCodec
    path = foreign_store(tmp_path / "s.zarr", ZstdCodec() if codec == "zstd" else GzipCodec())
    (path / "0" / "c" / "1" / "1" / "1").write_bytes(bomb())
    with pytest.raises(VolumeFileError, match=rf"s.zarr \[0/c/1/1/1\]: level 0: chunk 0/c/1/1/1 {re.escape(said)}.* "
                                              rf"but a chunk holds 512: the chunk is damaged or hostile"):
        BrickStore(path).read(0, (0, 0, 0), (16, 16, 16))
    np.testing.assert_array_equal(BrickStore(path).read(0, (0, 0, 0), (8, 8, 8)), 9)  # the others read
    code, stderr = run(path, tmp_path, capsys)
    assert code == 2 and said in only_the_message(stderr)


def test_a_blosc_chunk_whose_header_claims_a_gigabyte_is_refused_before_decoding(store, tmp_path, capsys):
    chunk = level_0_chunk(store)
    data = chunk.read_bytes()
    chunk.write_bytes(data[:4] + (2**30).to_bytes(4, "little") + data[8:])
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2
    assert "chunk 0/c/2/4/4 declares 1,073,741,824 decoded bytes (blosc), but a chunk holds 4,096" \
        in only_the_message(stderr)


def test_a_cut_short_blosc_chunk_is_refused_not_read_past_its_end(store, tmp_path, capsys):
    """Found by the stores fuzz target: blosc trusts its header's compressed size and read past
    the end of a truncated chunk, so the chunk read as different garbage each time (exit 0)."""
    chunk = level_0_chunk(store)
    data = chunk.read_bytes()
    chunk.write_bytes(data[:len(data) * 2 // 3])
    for _ in range(3):
        with pytest.raises(VolumeFileError, match=rf"chunk 0/c/2/4/4 holds {len(data) * 2 // 3:,} bytes but its "
                                                  rf"blosc header says {len(data):,}: the chunk is cut short"):
            BrickStore(store).read(0, (32, 64, 64), (48, 80, 80))
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2 and "cut short or damaged" in only_the_message(stderr)


def test_a_blosc_chunk_shorter_than_its_header_is_refused(store):
    """Found by the stores fuzz target: a chunk of 13 bytes escaped the size check (it read only
    whole headers) and blosc read its header past the end: a different value each time."""
    chunk = level_0_chunk(store)
    chunk.write_bytes(chunk.read_bytes()[:13])
    for _ in range(3):
        with pytest.raises(VolumeFileError, match=r"chunk 0/c/2/4/4 holds 13 bytes, less than the "
                                                  r"16-byte blosc header: the chunk is cut short"):
            BrickStore(store).read(0, (32, 64, 64), (48, 80, 80))


def test_a_chunk_shape_too_large_to_hold_is_refused_at_opening(store):
    edit(store / "0" / "zarr.json",
         lambda a: a["chunk_grid"]["configuration"].__setitem__("chunk_shape", [4096, 4096, 4096]))
    with pytest.raises(VolumeFileError, match=r"\[0/zarr.json\]: level 0: a chunk of 4096 x 4096 x 4096 "
                                              r"voxels is 64.0 GiB decoded, more than the 1.0 GiB"):
        BrickStore(store)


# --- defect 2: value ranges from metadata or a bounded sample -----------------------------------------
def huge_foreign_store(path, shape=(5000, 5000, 4000), dtype="uint8"):
    """1e11 voxels of metadata (a few hundred bytes) and no chunk: another tool's sparse store."""
    group = zarr.open_group(str(path), mode="w", zarr_format=3)
    group.create_array("0", shape=shape, chunks=(64, 64, 64), dtype=dtype, fill_value=0)
    group.attrs["ome"] = {"version": "0.5", "multiscales": [{
        "axes": [{"name": n, "type": "space"} for n in "zyx"],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 1]}]}]}]}
    return path


def test_a_metadata_only_store_of_1e11_voxels_is_refused_by_the_budget_not_read(tmp_path):
    path = huge_foreign_store(tmp_path / "huge.zarr")
    assert sum(f.stat().st_size for f in path.rglob("*") if f.is_file()) < 2048
    code, stderr = run_bounded(path, tmp_path)
    assert code == 2
    assert "the 393183 bricks of the coarsest level need 229188.74 MB but the budget is 512.00 MB" \
        in only_the_message(stderr)


def test_statistics_of_a_huge_store_read_a_bounded_sample(tmp_path, monkeypatch):
    read, original = [], BrickStore.read

    def counted(self, level, start, stop):  # a regression fails here instead of reading for hours
        shape = self.levels[level].shape
        read.append(math.prod(max(0, min(b, n) - max(a, 0)) for a, b, n in zip(start, stop, shape)))
        assert read[-1] <= store_module.SAMPLE_VOXELS and sum(read) <= 4 * store_module.SAMPLE_VOXELS
        return original(self, level, start, stop)

    monkeypatch.setattr(BrickStore, "read", counted)
    volume = BrickedVolume.open(huge_foreign_store(tmp_path / "huge.zarr", dtype="float32"))
    assert volume.dims == (4000, 5000, 5000) and read == []   # opening reads no voxel
    assert volume.value_range == (0.0, 1.0)                  # all fill value: constant 0
    assert sum(read) <= store_module.SAMPLE_VOXELS
    read.clear()
    volume.percentiles([1, 50, 99])                          # one pass for extremes, one for ranks
    assert 0 < sum(read) <= 2 * store_module.SAMPLE_VOXELS
    read.clear()
    assert volume.nonfinite_count == 0                       # of the sample: a lower bound
    assert 0 < sum(read) <= store_module.SAMPLE_VOXELS
    low, high = volume.bricks.brick_ranges(0)                # too large to read for its ranges
    assert low.shape == (79, 79, 63) and np.isneginf(low).all() and np.isposinf(high).all()


# --- defect 3: missing chunks against the store's statistics ------------------------------------------
@pytest.mark.parametrize("budget", [[], ["--set", "source.memory_budget=1"]], ids=["whole", "bricked"])
def test_deleted_level_0_chunks_are_refused_naming_the_chunk_and_the_statistics(store, tmp_path, capsys,
                                                                                 budget):
    for chunk in (store / "0" / "c").rglob("*"):
        if chunk.is_file():
            chunk.unlink()
    code, stderr = run(store, tmp_path, capsys, *budget)
    message = only_the_message(stderr)
    assert code == 2
    assert f"{store} [0/c/" in message and "level 0: chunk 0/c/" in message
    assert "is missing, but the store's statistics (vgraph/min/0, vgraph/max/0) say brick" in message
    assert "not only the fill value 0: the store is damaged" in message


def test_chunks_convert_left_out_are_the_fill_value_its_statistics_record(converted, tmp_path, capsys):
    corner = converted / "0" / "c" / "0" / "0" / "0"
    assert not corner.exists() and level_0_chunk(converted).is_file()  # all zero: not written
    np.testing.assert_array_equal(BrickStore(converted).read(0, (0, 0, 0), SHAPE), blob())
    for budget in ([], ["--set", "source.memory_budget=1"]):
        code, stderr = run(converted, tmp_path, capsys, *budget)
        assert code == 0, stderr
        assert np.asarray(PIL.Image.open(tmp_path / "out.png")).max() > 0


def test_another_tools_missing_chunks_are_its_fill_value(tmp_path):
    group = zarr.open_group(str(tmp_path / "sparse.zarr"), mode="w", zarr_format=2)
    array = group.create_array("0", shape=(8, 8, 8), chunks=(4, 4, 4), dtype="uint16", fill_value=7)
    array[:4, :4, :4] = 100
    group.attrs["multiscales"] = [{"version": "0.4", "axes": list("zyx"), "datasets": [{"path": "0"}]}]
    expected = np.full((8, 8, 8), 7, np.uint16)
    expected[:4, :4, :4] = 100
    np.testing.assert_array_equal(BrickStore(tmp_path / "sparse.zarr").read(0, (0, 0, 0), (8, 8, 8)), expected)


# --- defect 4: metadata cross-checked -------------------------------------------------------------------
@pytest.mark.parametrize("shape, reason", [
    ([20, 20, 20], r"\[multiscales.datasets\[1\]\]: level 1 \(x: 20 voxels of 2\) does not cover level 0's "
                   r"extent \(128 voxels of 1\): the levels disagree"),
    ([36, 64, 65], r"\[multiscales.datasets\[1\]\]: level 1 has \(36, 64, 65\) voxels \(z, y, x\) but the "
                   r"halving of level 0 has \(36, 64, 64\): the store is damaged")])
def test_level_shapes_that_disagree_are_refused(store, tmp_path, capsys, shape, reason):
    edit(store / "1" / "zarr.json", lambda a: a.__setitem__("shape", shape))
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2
    assert re.search(reason, only_the_message(stderr))


def test_levels_of_different_data_types_are_refused(store, tmp_path, capsys):
    edit(store / "2" / "zarr.json", lambda a: a.__setitem__("data_type", "uint16"))
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2
    assert f"{store} [2/zarr.json]: level 2 holds uint16 voxels but level 0 uint8: the levels of a " \
           f"pyramid have one data type" in only_the_message(stderr)


def test_chunks_other_than_the_recorded_brick_are_refused(store, tmp_path, capsys):
    """Was IndexError (exit 1): the brick grid from the chunks did not match the recorded ranges."""
    edit(store / "0" / "zarr.json",
         lambda a: a["chunk_grid"]["configuration"].__setitem__("chunk_shape", [8, 8, 8]))
    code, stderr = run(store, tmp_path, capsys, "--set", "source.memory_budget=1")
    assert code == 2
    assert f"{store} [0/zarr.json]: level 0: chunks of (8, 8, 8) voxels (x, y, z), but the store's brick " \
           f"is (16, 16, 16): the store is damaged" in only_the_message(stderr)


def half_chunk(tmp_path):
    """A valid chunk file of the store's codecs holding 8 x 16 x 16 voxels (the store's hold 16^3)."""
    from zarr.codecs import BloscCodec
    blosc = BloscCodec(cname="zstd", clevel=3, shuffle="bitshuffle")  # the store's codec
    other = zarr.create_array(store=str(tmp_path / "other.zarr"), shape=(8, 16, 16), chunks=(8, 16, 16),
                              dtype="uint8", compressors=blosc)
    other[...] = 200
    return tmp_path / "other.zarr" / "c" / "0" / "0" / "0"


@pytest.mark.parametrize("budget", [[], ["--set", "source.memory_budget=1"]], ids=["whole", "bricked"])
def test_a_chunk_that_decodes_to_another_shape_is_refused_naming_it(store, tmp_path, capsys, budget):
    shutil.copy(half_chunk(tmp_path), level_0_chunk(store))
    code, stderr = run(store, tmp_path, capsys, *budget)
    assert code == 2
    assert f"{store} [0/c/2/4/4]: level 0: chunk 0/c/2/4/4 cannot be read as 16 x 16 x 16 voxels of uint8" \
        in only_the_message(stderr)


@pytest.mark.parametrize("path", ["../x", "/etc", "", "0/../1", "a//b", 7])
def test_a_dataset_path_outside_the_store_is_refused(store, tmp_path, capsys, path):
    edit(store / "zarr.json",
         lambda g: g["attributes"]["ome"]["multiscales"][0]["datasets"][1].__setitem__("path", path))
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2
    assert f"{store} [multiscales.datasets[1].path]: level 1: dataset path {path!r} is not a path " \
           f"inside the store" in only_the_message(stderr)


@pytest.mark.parametrize("field, value, reason", [
    ("value_range", "ab", "[vgraph.value_range]: value_range must be two finite numbers, low <= high, "
                          "got 'ab'"),
    ("value_range", [5, 1], "[vgraph.value_range]: value_range must be two finite numbers"),
    ("data_range", [0, 1e999], "[vgraph.data_range]: data_range must be two finite numbers"),
    ("brick", [16, 16], "[vgraph.brick]: brick must be three positive integers"),
    ("levels", 9, "[vgraph.levels]: the store records 9 levels but lists 4 datasets"),
    ("nonfinite", -1, "[vgraph.nonfinite]: nonfinite must be a count of voxels"),
    ("format", 2, "[vgraph.format]: unknown store format 2")])
def test_damaged_vgraph_attributes_are_refused_naming_the_field(store, field, value, reason):
    edit(store / "zarr.json", lambda g: g["attributes"]["vgraph"].__setitem__(field, value))
    with pytest.raises(VolumeFileError) as error:
        BrickStore(store)
    assert reason in str(error.value)


def test_damaged_per_brick_statistics_are_refused(store, tmp_path, capsys):
    edit(store / "vgraph" / "min" / "0" / "zarr.json", lambda a: a.__setitem__("shape", [5, 8, 9]))
    code, stderr = run(store, tmp_path, capsys)
    assert code == 2
    assert f"{store} [vgraph/min/0]: the per-brick min of level 0 are (5, 8, 9) float64, not float64 over " \
           f"the level's (5, 8, 8) bricks (z, y, x): the store is damaged" in only_the_message(stderr)
    edit(store / "vgraph" / "min" / "0" / "zarr.json", lambda a: a.__setitem__("shape", [5, 8, 8]))
    shutil.rmtree(store / "vgraph" / "max" / "1")
    with pytest.raises(VolumeFileError, match=r"\[vgraph/max/1\]: the per-brick max of level 1 are missing"):
        BrickStore(store)


def test_another_tools_pyramid_that_does_not_halve_uses_every_level(tmp_path):
    """ome-zarr-py's default pyramid keeps z and floors x and y: consistent with its scales, and
    every level is used (the renderer's cells follow any factor between levels: bricks/cells.py;
    tests/test_foreign_ome_zarr.py renders such stores)."""
    group = zarr.open_group(str(tmp_path / "floor.zarr"), mode="w", zarr_format=2)
    data = blob()[:, :, :127]
    levels = [data, data[::2, ::2, ::2][:, :, :64], data[::2, ::4, ::4][:, :, :32]]  # 2: keeps z
    shapes = [level.shape for level in levels]
    assert shapes == [(72, 128, 127), (36, 64, 64), (36, 32, 32)]
    for k, level in enumerate(levels):
        group.create_array(str(k), shape=level.shape, chunks=(16, 16, 16), dtype="uint8")[...] = level
    scales = [[a / b for a, b in zip(shapes[0], shape)] for shape in shapes]
    group.attrs["multiscales"] = [{"version": "0.4", "axes": list("zyx"), "datasets": [
        {"path": str(k), "coordinateTransformations": [{"type": "scale", "scale": scale}]}
        for k, scale in enumerate(scales)]}]
    with warnings.catch_warnings():
        warnings.simplefilter("error", StoreLevelsWarning)
        store = BrickStore(tmp_path / "floor.zarr")
    assert [level.shape for level in store.levels] == shapes


def test_messages_of_refused_stores_are_not_followed_by_asyncio_noise(store, tmp_path):
    """A failed read used to leave its other chunks' tasks pending: "Task was destroyed but it is
    pending!" and "Event loop is closed" tracebacks followed the message at exit."""
    half = half_chunk(tmp_path)
    for chunk in list((store / "0" / "c").rglob("*"))[::3]:
        if chunk.is_file():
            shutil.copy(half, chunk)
    code, stderr = run_bounded(store, tmp_path)
    assert code == 2
    assert "cannot be read as 16 x 16 x 16 voxels" in only_the_message(stderr)
    assert "Task" not in stderr and "Traceback" not in stderr


def test_reads_are_checked_against_the_memory_available(store, monkeypatch):
    opened = BrickStore(store)
    monkeypatch.setattr("vgraph.memory.available_memory", lambda: 2**20)
    with pytest.raises(VolumeFileError, match=r"v.zarr \[0\]: too large for memory: loading needs 1.1 MiB "
                                              r"\(1183744 bytes\) but only 1.0 MiB is available"):
        opened.read(0, (0, 0, 0), SHAPE)
    assert opened.read(0, (0, 0, 0), (16, 16, 16)).shape == (16, 16, 16)
