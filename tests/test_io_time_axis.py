"""Files with a time axis (fMRI-like 4D NIfTI, NRRD with a `time` kind, 4D MetaImage, NumPy
[t, z, y, x]): each time point reads alone, equal to the format's reference library, with the
number of time points in `Volume.time_steps`; a time point the file does not hold is refused
naming the file and the count. Fixtures are written here; nothing is downloaded."""

import gzip
import zlib

import nibabel as nib
import nrrd
import numpy as np
import pytest

import vgraph.io._common
from vgraph.errors import VolumeFileError
from vgraph.io import TimeStepError, read_volume

# [t, z, y, x]: 3 time points of 4 x 5 x 6 voxels (x = 6 fastest), each time point different
SERIES = (np.arange(3 * 4 * 5 * 6, dtype=np.int16).reshape(3, 4, 5, 6) * 7 - 500)


def nifti(folder, name="bold.nii.gz", data=SERIES, zooms=(2.0, 2.5, 3.0, 1.5)):
    """nibabel's (x, y, z, t) order is our [t, z, y, x] transposed."""
    image = nib.Nifti1Image(np.ascontiguousarray(data.T), np.diag([*zooms[:3], 1.0]))
    image.header.set_zooms(zooms[:data.ndim])
    path = folder / name
    nib.save(image, str(path))
    return path


def nrrd_file(folder, encoding="raw", kinds=("domain", "domain", "domain", "time")):
    path = folder / f"series_{encoding}.nrrd"
    header = {"encoding": encoding, "spacings": [1.0, 2.0, 3.0, 0.5]}
    if kinds:
        header["kinds"] = list(kinds)
    nrrd.write(str(path), SERIES, header, index_order="C")
    return path


def metaimage(folder, compressed=False):
    payload = SERIES.astype("<i2").tobytes()
    (folder / "series.raw").write_bytes(zlib.compress(payload) if compressed else payload)
    path = folder / "series.mhd"
    path.write_text("NDims = 4\nDimSize = 6 5 4 3\nElementSpacing = 1 2 3 0.5\n"
                    "Offset = 10 20 30 0\nElementType = MET_SHORT\n"
                    f"CompressedData = {compressed}\nElementDataFile = series.raw\n")
    return path


def numpy_file(folder, name, fortran=False):
    path = folder / name
    data = np.asfortranarray(SERIES) if fortran else SERIES
    if name.endswith(".npz"):
        np.savez_compressed(path, data=data, spacing=np.array([1.0, 2.0, 3.0]))
    else:
        np.save(path, data)
    return path


SOURCES = {
    "nii": lambda f: nifti(f, "bold.nii"),
    "nii.gz": lambda f: nifti(f),
    "nrrd raw": lambda f: nrrd_file(f),
    "nrrd gzip": lambda f: nrrd_file(f, "gzip"),
    "nrrd bzip2": lambda f: nrrd_file(f, "bzip2"),
    "nrrd ascii": lambda f: nrrd_file(f, "ascii"),
    "mhd": lambda f: metaimage(f),
    "mhd zlib": lambda f: metaimage(f, compressed=True),
    "npy": lambda f: numpy_file(f, "series.npy"),
    "npy fortran": lambda f: numpy_file(f, "series.npy", fortran=True),
    "npz": lambda f: numpy_file(f, "series.npz"),
    "npz fortran": lambda f: numpy_file(f, "series.npz", fortran=True),
}


@pytest.mark.parametrize("kind", SOURCES)
def test_every_time_point_reads_alone_with_the_count(kind, tmp_path):
    path = SOURCES[kind](tmp_path)
    for t in range(3):
        volume = read_volume(path, time_step=t)
        np.testing.assert_array_equal(volume.data, SERIES[t])
        assert volume.time_steps == 3 and volume.dims == (6, 5, 4)
        assert volume.value_range == (float(SERIES[t].min()), float(SERIES[t].max()))
    with pytest.raises(TimeStepError, match=r"time step 3 is out of range: the file holds 3 time "
                                            r"points \(0 \.\. 2\)") as error:
        read_volume(path, time_step=3)
    assert error.value.file == str(path) and error.value.time_steps == 3


def test_nifti_time_points_equal_nibabel_and_keep_the_spatial_geometry(tmp_path):
    path = nifti(tmp_path)
    image = nib.load(path)
    for t in range(3):
        volume = read_volume(path, time_step=t)
        np.testing.assert_array_equal(volume.data, np.asarray(image.dataobj[..., t]).T)
    assert volume.spacing == (2.0, 2.5, 3.0)  # the 4th zoom is the repetition time, not a length


def test_metaimage_and_nrrd_take_the_spatial_part_of_4d_geometry(tmp_path):
    assert read_volume(metaimage(tmp_path)).spacing == (1.0, 2.0, 3.0)
    assert read_volume(metaimage(tmp_path)).origin == (10.0, 20.0, 30.0)
    assert read_volume(nrrd_file(tmp_path)).spacing == (1.0, 2.0, 3.0)


def test_a_time_point_of_an_uncompressed_file_reads_only_its_bytes(tmp_path, monkeypatch):
    """A big 4D file is not read whole to show one time point."""
    read_sizes = []
    original = vgraph.io._common._read_into
    monkeypatch.setattr(vgraph.io._common, "_read_into",
                        lambda path, start, target, nbytes: (read_sizes.append(nbytes),
                                                             original(path, start, target, nbytes)))
    for make in (lambda: nifti(tmp_path, "bold.nii"), lambda: nrrd_file(tmp_path),
                 lambda: metaimage(tmp_path), lambda: numpy_file(tmp_path, "s.npy")):
        read_sizes.clear()
        read_volume(make(), time_step=1)
        assert read_sizes == [SERIES[1].nbytes]


def test_inflating_stops_after_the_time_point(tmp_path):
    """The first time point of a .nii.gz whose later part is damaged still reads: only the
    stream up to the end of the time point asked for is inflated."""
    path = nifti(tmp_path)
    whole = gzip.decompress(path.read_bytes())
    cut = tmp_path / "cut.nii.gz"
    cut.write_bytes(gzip.compress(whole)[:-len(SERIES[2].tobytes()) // 2])
    np.testing.assert_array_equal(read_volume(cut, time_step=0).data, SERIES[0])
    with pytest.raises(VolumeFileError, match="cut.nii.gz"):
        read_volume(cut, time_step=2)


def test_files_without_a_time_axis_hold_one_time_point(data_dir, tmp_path):
    for path in (data_dir / "ct_head_headsq/quarter.nhdr", data_dir / "dicom_mr_scout",
                 data_dir / "sim_neghip/neghip_66x66x66_uint8.dat", data_dir / "mri_head_t1/MR.nii.gz"):
        assert read_volume(path).time_steps == 1
        with pytest.raises(TimeStepError, match=r"time step 1 is out of range: the file holds 1 "
                                                r"time point \(0\)"):
            read_volume(path, time_step=1)


@pytest.mark.parametrize("bad", [-1, 1.5, "0", True])
def test_a_time_step_must_be_a_whole_number(bad, tmp_path):
    with pytest.raises(TimeStepError, match="out of range"):
        read_volume(nifti(tmp_path), time_step=bad)


def test_a_4d_nrrd_without_a_time_kind_is_refused_saying_how_to_mark_it(tmp_path):
    with pytest.raises(VolumeFileError, match=r"\[sizes\]: expected a 3D scalar volume, got 4 axes "
                                              r"with sizes \(6, 5, 4, 3\); a 4th axis is read as "
                                              r"time when 'kinds' marks it so") as error:
        read_volume(nrrd_file(tmp_path, kinds=None))
    assert error.value.file.endswith("series_raw.nrrd")


def test_nifti_vector_data_with_a_5th_axis_is_refused(tmp_path):
    image = nib.Nifti1Image(np.zeros((4, 4, 4, 1, 3), np.float32), np.eye(4))
    nib.save(image, str(tmp_path / "vectors.nii"))
    with pytest.raises(VolumeFileError, match=r"vectors.nii \[dim\]: .*5 axes.*vector or tensor"):
        read_volume(tmp_path / "vectors.nii")


def test_a_single_time_point_file_is_a_plain_volume(tmp_path):
    path = nifti(tmp_path, data=SERIES[:1])
    volume = read_volume(path)
    assert volume.time_steps == 1
    np.testing.assert_array_equal(volume.data, SERIES[0])
