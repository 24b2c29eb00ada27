"""Volume writers: round trips per format, files readable by the reference libraries, atomicity."""

import warnings
from pathlib import Path

import nibabel as nib
import nrrd
import numpy as np
import pytest

from vgraph.errors import VolumeFileError
from vgraph.io import WRITABLE_EXTENSIONS, NonFiniteVoxelsWarning, read_volume, write_volume
from vgraph.volume import Volume

DATA = Path(__file__).parents[1].parent / "shared" / "data"


def sample_volumes():
    rng = np.random.default_rng(7)
    floats = rng.normal(size=(5, 6, 7)).astype(np.float32)
    floats[0, 0, 0] = np.nan  # non-finite voxels survive a round trip
    return {
        "uint8": Volume(rng.integers(0, 256, (4, 5, 6), dtype=np.uint8), spacing=(0.5, 1, 2),
                        origin=(-10, 20.5, 3)),
        "int16": Volume(rng.integers(-2000, 3000, (3, 8, 2), dtype=np.int16),
                        spacing=(3.2, 3.2, 1.5), origin=(1, 2, 3), declared_range=(-1024, 3071)),
        "uint16": Volume(rng.integers(0, 4096, (2, 3, 4), dtype=np.uint16),
                         declared_range=(0, 4095)),
        "float32": Volume(floats, spacing=(1, 0.898437, 0.898437), origin=(-388.26, -81.12, 405.4)),
        "float64": Volume(rng.random((2, 2, 9)), spacing=(0.25, 0.5, 0.75)),
    }


@pytest.mark.parametrize("ext", [".npz", ".nrrd", ".nii", ".nii.gz"])
@pytest.mark.parametrize("name", list(sample_volumes()))
def test_round_trip_keeps_values_dtype_spacing_origin_range(tmp_path, ext, name):
    volume = sample_volumes()[name]
    path = write_volume(volume, tmp_path / f"out{ext}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        back = read_volume(path)
    nonfinite_warnings = [w for w in caught if issubclass(w.category, NonFiniteVoxelsWarning)]
    assert len(nonfinite_warnings) == (1 if volume.nonfinite_count else 0)
    assert back.data.dtype == volume.data.dtype
    np.testing.assert_array_equal(back.data, volume.data)  # NaN == NaN here
    np.testing.assert_allclose(back.spacing, volume.spacing, rtol=1e-6)  # NIfTI stores float32
    np.testing.assert_allclose(back.origin, volume.origin, rtol=1e-6, atol=1e-5)
    assert back.declared_range == volume.declared_range
    assert back.source == str(tmp_path / f"out{ext}")
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


def test_npy_round_trip_keeps_values_only(tmp_path):
    volume = sample_volumes()["int16"]
    back = read_volume(write_volume(volume, tmp_path / "v.npy"))
    np.testing.assert_array_equal(back.data, volume.data)
    assert back.data.dtype == np.int16
    assert back.spacing == (1.0, 1.0, 1.0) and back.origin == (0.0, 0.0, 0.0)
    np.testing.assert_array_equal(np.load(tmp_path / "v.npy"), volume.data)


def test_written_files_read_correctly_with_reference_libraries(tmp_path):
    volume = sample_volumes()["uint8"]
    write_volume(volume, tmp_path / "v.nrrd")
    data, header = nrrd.read(str(tmp_path / "v.nrrd"), index_order="C")
    np.testing.assert_array_equal(data, volume.data)
    np.testing.assert_allclose(np.diag(header["space directions"]), volume.spacing)
    np.testing.assert_allclose(header["space origin"], volume.origin)
    write_volume(volume, tmp_path / "v.nii.gz")
    image = nib.load(tmp_path / "v.nii.gz")
    np.testing.assert_array_equal(np.asanyarray(image.dataobj), volume.data.T)  # x, y, z
    np.testing.assert_allclose(image.header.get_zooms(), volume.spacing)
    np.testing.assert_allclose(image.affine[:3, 3], volume.origin)
    assert (tmp_path / "v.nii.gz").read_bytes()[:2] == b"\x1f\x8b"  # gzip
    write_volume(volume, tmp_path / "v.nii")
    assert (tmp_path / "v.nii").read_bytes()[344:348] == b"n+1\x00"  # plain NIfTI-1 magic


@pytest.mark.skipif(not DATA.is_dir(), reason=f"shared data sets not found at {DATA}")
def test_real_data_set_round_trips_through_every_format(tmp_path):
    volume = read_volume(DATA / "ct_head_headsq" / "quarter.nhdr")
    for ext in (".npz", ".nrrd", ".nii.gz"):
        back = read_volume(write_volume(volume, tmp_path / f"headsq{ext}"))
        np.testing.assert_array_equal(back.data, volume.data)
        np.testing.assert_allclose(back.spacing, (3.2, 3.2, 1.5), rtol=1e-6)


@pytest.mark.parametrize("ext, target", [(".nrrd", "nrrd.write"), (".nii.gz", "nibabel.save"),
                                         (".npy", "numpy.save"), (".npz", "numpy.savez_compressed")])
def test_failed_write_leaves_the_old_file_intact(tmp_path, monkeypatch, ext, target):
    path = tmp_path / f"keep{ext}"
    old = sample_volumes()["uint8"]
    write_volume(old, path)
    before = path.read_bytes()

    def fail_halfway(*args, **kwargs):
        file = next(a for a in args if hasattr(a, "write") or isinstance(a, (str, Path)))
        if hasattr(file, "write"):
            file.write(b"partial garbage")  # the temporary file is half written, then ...
        else:
            Path(file).write_bytes(b"partial garbage")
        raise OSError(28, "No space left on device")

    module, name = target.rsplit(".", 1)
    monkeypatch.setattr(f"{module}.{name}", fail_halfway)
    with pytest.raises(VolumeFileError) as info:
        write_volume(sample_volumes()["int16"], path)
    assert info.value.file == str(path)
    assert "No space left on device" in str(info.value) and "left untouched" in str(info.value)
    assert path.read_bytes() == before
    assert sorted(tmp_path.iterdir()) == [path]
    monkeypatch.undo()
    np.testing.assert_array_equal(read_volume(path).data, old.data)


def test_failed_rename_leaves_the_old_file_intact(tmp_path, monkeypatch):
    path = tmp_path / "keep.nrrd"
    write_volume(sample_volumes()["uint8"], path)
    before = path.read_bytes()

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr("vgraph.atomic.os.replace", refuse)
    with pytest.raises(VolumeFileError, match="Permission denied"):
        write_volume(sample_volumes()["float32"], path)
    assert path.read_bytes() == before and sorted(tmp_path.iterdir()) == [path]


def test_writer_errors_name_the_file(tmp_path):
    volume = sample_volumes()["uint8"]
    error = pytest.raises(VolumeFileError, write_volume, volume, tmp_path / "v.mhd").value
    assert error.field == "extension" and all(ext in str(error) for ext in WRITABLE_EXTENSIONS)
    error = pytest.raises(VolumeFileError, write_volume, volume, tmp_path / "no" / "v.npy").value
    assert error.field == "path" and error.file == str(tmp_path / "no" / "v.npy")
    error = pytest.raises(VolumeFileError, write_volume, volume.data, tmp_path / "v.npy").value
    assert "expected a Volume" in str(error)


def test_overwrite_keeps_file_mode(tmp_path):
    path = tmp_path / "v.npz"
    write_volume(sample_volumes()["uint8"], path)
    path.chmod(0o640)
    write_volume(sample_volumes()["int16"], path)
    assert path.stat().st_mode & 0o777 == 0o640
