"""vgraph convert (vgraph.io.convert): which formats stream, the memory a conversion takes,
the errors of bad input, atomic replacement of the store, and the command line."""

import os

import nibabel as nib
import numpy as np
import pytest

from vgraph.io.convert import convert
from vgraph.bricks.store import BrickStore
from vgraph.bricks.store_writer import StoreWriter
from vgraph.cli import main
from vgraph.errors import OutputFileError, VGraphError, VolumeFileError

DATA = (np.arange(20 * 18 * 14, dtype=np.uint16).reshape(14, 18, 20) * 7) % 4001  # [z, y, x]


def write_inputs(folder) -> dict[str, str]:
    """The same volume in every format convert streams, and one it reads whole."""
    raw = DATA.astype("<u2").tobytes()
    (folder / "v_20x18x14_uint16.raw").write_bytes(raw)
    (folder / "detached.raw").write_bytes(raw)
    (folder / "v.nhdr").write_text("NRRD0004\ntype: uint16\ndimension: 3\nsizes: 20 18 14\n"
                                   "endian: little\nencoding: raw\nspacings: 0.5 1 2\n"
                                   "data file: detached.raw\n")
    (folder / "v.mhd").write_text("NDims = 3\nDimSize = 20 18 14\nElementSpacing = 0.5 1 2\n"
                                  "ElementType = MET_USHORT\nElementDataFile = detached.raw\n")
    affine = np.diag([0.5, 1.0, 2.0, 1.0])
    nib.save(nib.Nifti1Image(DATA.T, affine), str(folder / "v.nii"))
    nib.save(nib.Nifti1Image(DATA.T, affine), str(folder / "v.nii.gz"))
    np.save(folder / "v.npy", DATA)
    return {"raw": "v_20x18x14_uint16.raw", "nrrd": "v.nhdr", "metaimage": "v.mhd", "nifti": "v.nii",
            "npy": "v.npy", "nifti.gz": "v.nii.gz"}


@pytest.mark.parametrize("kind", ["raw", "nrrd", "metaimage", "nifti", "npy", "nifti.gz"])
def test_every_format_converts_to_the_same_store(tmp_path, kind):
    name = write_inputs(tmp_path)[kind]
    report = convert(tmp_path / name, tmp_path / "out.zarr", brick=8, progress=False)
    assert report.how.startswith("read whole" if kind == "nifti.gz" else "streamed"), report.how
    store = BrickStore(tmp_path / "out.zarr")
    np.testing.assert_array_equal(store.read(0, (0, 0, 0), DATA.shape), DATA)
    expected_spacing = (1.0, 1.0, 1.0) if kind in ("raw", "npy") else (0.5, 1.0, 2.0)
    assert store.levels[0].spacing == expected_spacing
    assert report.shapes == [(14, 18, 20), (7, 9, 10), (4, 5, 5)]
    assert report.bytes_written > 0 and report.peak_rss_bytes > 0


def test_conversion_streams_a_256_cube_in_a_fraction_of_its_size(tmp_path):
    """A 256^3 uint16 .npy (32 MiB) in slabs of 32 slices: the peak of the allocations traced
    by tracemalloc (numpy's buffers, zarr's chunk buffers and compressed bytes) during the
    conversion stays near one 4 MiB slab plus the coarser levels' partial slabs. RSS is not
    used: it includes the interpreter and every imported library."""
    path = tmp_path / "cube.npy"
    cube = np.lib.format.open_memmap(path, mode="w+", dtype=np.uint16, shape=(256, 256, 256))
    cube[:] = np.arange(256, dtype=np.uint16)[:, None, None]
    cube.flush()
    del cube
    report = convert(path, tmp_path / "cube.zarr", brick=32, progress=False, trace_memory=True)
    assert report.how.startswith("streamed")
    assert report.traced_peak_bytes < 12 * 2**20, report.text()  # the input is 32 MiB
    # slices 0..7 average to 3 through the levels' roundings (0 1 -> 0, 2 3 -> 2, 0 2 -> 1, 4 6
    # -> 5, 1 5 -> 3): each level is rounded from the one before, as ArrayPyramid does
    assert BrickStore(tmp_path / "cube.zarr").read(3, (0, 0, 0), (1, 1, 1))[0, 0, 0] == 3


def test_levels_and_brick_options(tmp_path):
    name = write_inputs(tmp_path)["npy"]
    report = convert(tmp_path / name, tmp_path / "out.zarr", brick=(4, 6, 8), levels=2, progress=False)
    store = BrickStore(tmp_path / "out.zarr")
    assert report.shapes == [(14, 18, 20), (7, 9, 10)] and store.brick == (4, 6, 8)
    with pytest.raises(VGraphError, match="brick must be an even number"):
        convert(tmp_path / name, tmp_path / "odd.zarr", brick=7, progress=False)
    with pytest.raises(VGraphError, match="levels must be an integer from 1 to 6"):
        convert(tmp_path / name, tmp_path / "many.zarr", levels=9, progress=False)


# --- bad input --------------------------------------------------------------------------------------
def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(VolumeFileError, match="gone.nii: file does not exist"):
        convert(tmp_path / "gone.nii", tmp_path / "out.zarr", progress=False)
    assert os.listdir(tmp_path) == []


def test_a_truncated_raw_file_is_named(tmp_path):
    path = tmp_path / "short_20x18x14_uint16.raw"
    path.write_bytes(DATA.tobytes()[:-100])
    with pytest.raises(VolumeFileError, match=r"short_20x18x14_uint16.raw \[dims\]: file is truncated: "
                                              r"expected 10080 bytes, found 9980"):
        convert(path, tmp_path / "out.zarr", progress=False)
    assert sorted(os.listdir(tmp_path)) == [path.name]


def test_a_truncated_detached_nrrd_names_the_header(tmp_path):
    write_inputs(tmp_path)
    (tmp_path / "detached.raw").write_bytes(b"\0" * 64)
    with pytest.raises(VolumeFileError, match=r"v.nhdr \[sizes\]: data file .*detached.raw.* is truncated"):
        convert(tmp_path / "v.nhdr", tmp_path / "out.zarr", progress=False)


# --- atomic output ----------------------------------------------------------------------------------
def fail_at_level_one(monkeypatch):
    original = StoreWriter.write_slab

    def write_slab(self, k, z0, slab):
        if k == 1:
            raise RuntimeError("disk on fire")
        return original(self, k, z0, slab)
    monkeypatch.setattr(StoreWriter, "write_slab", write_slab)


def test_a_failed_conversion_leaves_no_store_and_no_temporary_folder(tmp_path, monkeypatch):
    name = write_inputs(tmp_path)["npy"]
    before = sorted(os.listdir(tmp_path))
    fail_at_level_one(monkeypatch)
    with pytest.raises(RuntimeError, match="disk on fire"):
        convert(tmp_path / name, tmp_path / "out.zarr", brick=4, progress=False)
    assert sorted(os.listdir(tmp_path)) == before


def test_an_existing_store_survives_a_failed_conversion_and_is_replaced_by_a_good_one(tmp_path, monkeypatch):
    name = write_inputs(tmp_path)["npy"]
    convert(tmp_path / name, tmp_path / "out.zarr", brick=8, progress=False)
    with monkeypatch.context() as patch:
        fail_at_level_one(patch)
        with pytest.raises(RuntimeError):
            convert(tmp_path / name, tmp_path / "out.zarr", brick=4, progress=False)
    assert BrickStore(tmp_path / "out.zarr").brick == (8, 8, 8)
    convert(tmp_path / name, tmp_path / "out.zarr", brick=4, progress=False)
    assert BrickStore(tmp_path / "out.zarr").brick == (4, 4, 4)
    assert sorted(p for p in os.listdir(tmp_path) if p.startswith(".")) == []


def test_an_output_that_is_not_a_store_is_not_replaced(tmp_path):
    name = write_inputs(tmp_path)["npy"]
    (tmp_path / "notes.zarr").mkdir()
    (tmp_path / "notes.zarr" / "mine.txt").write_text("keep me")
    with pytest.raises(OutputFileError, match="notes.zarr: exists and is not a zarr store"):
        convert(tmp_path / name, tmp_path / "notes.zarr", progress=False)
    with pytest.raises(OutputFileError, match="must end in .zarr"):
        convert(tmp_path / name, tmp_path / "out.nrrd", progress=False)
    assert (tmp_path / "notes.zarr" / "mine.txt").read_text() == "keep me"


# --- the command line -------------------------------------------------------------------------------
def test_vgraph_convert_writes_the_store_and_reports(tmp_path, capsys):
    write_inputs(tmp_path)
    code = main(["convert", str(tmp_path / "detached.raw"), str(tmp_path / "cli.zarr"), "--brick", "8",
                 "--raw-dims", "20", "18", "14", "--raw-dtype", "uint16", "--quiet"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "3 levels (voxels x, y, z) 0: 20x18x14; 1: 10x9x7; 2: 5x5x4" in err
    assert "streamed (raw" in err and "written" in err and "(ru_maxrss)" in err
    np.testing.assert_array_equal(BrickStore(tmp_path / "cli.zarr").read(0, (0, 0, 0), DATA.shape), DATA)


def test_vgraph_convert_bad_input_exits_2_naming_the_file(tmp_path, capsys):
    code = main(["convert", str(tmp_path / "missing.nrrd"), str(tmp_path / "cli.zarr"), "--quiet"])
    assert code == 2
    assert "vgraph: error:" in capsys.readouterr().err and not (tmp_path / "cli.zarr").exists()
