"""Volume readers: every shared data set against its format's reference library, then bad input.

References: nibabel (NIfTI, scaling applied), pydicom (DICOM), pynrrd (hydrogen .nhdr), numpy
(npz, raw files, the 93 headsq slice files concatenated, the MetaImage .raw).
"""

import hashlib
import shutil
import warnings
from pathlib import Path

import nibabel as nib
import nrrd
import numpy as np
import pydicom
import pytest

from vgraph.errors import VolumeFileError
from vgraph.io import SUPPORTED_EXTENSIONS, NonFiniteVoxelsWarning, read_volume

DATA = Path(__file__).parents[1].parent / "shared" / "data"


@pytest.fixture
def data() -> Path:
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA} (the /work/shared checkout is absent)")
    return DATA


def assert_geometry(volume, shape_zyx, dtype, spacing, origin=(0, 0, 0)):
    assert volume.data.shape == shape_zyx
    assert volume.data.dtype == np.dtype(dtype)
    assert volume.data.dtype.isnative and volume.data.flags.c_contiguous
    np.testing.assert_allclose(volume.spacing, spacing, rtol=1e-6)
    np.testing.assert_allclose(volume.origin, origin, rtol=1e-6)


# --- the shared data sets ------------------------------------------------------------------------
def test_headsq_multi_file_nrrd_equals_the_93_slices_concatenated(data):
    folder = data / "ct_head_headsq"
    volume = read_volume(folder / "quarter.nhdr")
    slices = b"".join((folder / f"quarter.{k}").read_bytes() for k in range(1, 94))
    reference = np.frombuffer(slices, dtype="<i2").reshape(93, 64, 64)
    assert_geometry(volume, (93, 64, 64), np.int16, (3.2, 3.2, 1.5))
    np.testing.assert_array_equal(volume.data, reference)
    digest = hashlib.sha256(volume.data.astype("<i2").tobytes()).hexdigest()
    assert digest.startswith("74011a33") and digest.endswith("96ce3")  # README checksum
    assert volume.source == str(folder / "quarter.nhdr")
    assert (volume.data.min(), volume.data.max()) == (0, 3926)


@pytest.mark.parametrize("name, shape, spacing", [
    ("ct_engine/engine.nii.gz", (128, 256, 256), (1, 1, 1)),
    ("ct_bonsai/bonsai.nii.gz", (256, 256, 256), (1, 1, 1)),
])
def test_unscaled_nifti_keeps_uint8_and_equals_nibabel(data, name, shape, spacing):
    volume = read_volume(data / name)
    image = nib.load(data / name)
    assert_geometry(volume, shape, np.uint8, spacing, image.affine[:3, 3])
    np.testing.assert_array_equal(volume.data, np.asanyarray(image.dataobj).T)
    assert volume.declared_range is None and volume.value_range == (0.0, 255.0)


def test_scaled_nifti_is_float32_equal_to_nibabel_scaling(data):
    volume = read_volume(data / "mri_head_t1/MR.nii.gz")
    image = nib.load(data / "mri_head_t1/MR.nii.gz")
    assert image.dataobj.slope == pytest.approx(2.00784, abs=1e-5)
    assert_geometry(volume, (160, 232, 160), np.float32, (1.0, 0.898437, 0.898437),
                    image.affine[:3, 3])
    reference = image.get_fdata().T  # float64, scaling applied by nibabel
    np.testing.assert_allclose(volume.data, reference, rtol=1e-7, atol=0)
    assert volume.value_range == pytest.approx((0.0, 512.0), abs=1e-4)


def test_npz_stent_equals_numpy(data):
    volume = read_volume(data / "cta_stent/stent.npz")
    with np.load(data / "cta_stent/stent.npz") as archive:
        reference = archive["arr_0"]
    assert_geometry(volume, (256, 128, 128), np.int16, (1, 1, 1))
    np.testing.assert_array_equal(volume.data, reference)


def test_metaimage_equals_its_raw_file(data):
    volume = read_volume(data / "mri_head_tiny/HeadMRVolume.mhd")
    reference = np.fromfile(data / "mri_head_tiny/HeadMRVolume.raw", np.uint8).reshape(42, 62, 48)
    assert_geometry(volume, (42, 62, 48), np.uint8, (4, 4, 4))
    np.testing.assert_array_equal(volume.data, reference)


@pytest.mark.parametrize("name", ["neghip_66x66x66_uint8.dat", "neghip_66x66x66_uint8.raw"])
def test_qvis_and_named_raw_neghip_equal_numpy(data, name):
    volume = read_volume(data / "sim_neghip" / name)
    reference = np.fromfile(data / "sim_neghip/neghip_66x66x66_uint8.raw", np.uint8)
    assert_geometry(volume, (66, 66, 66), np.uint8, (1, 1, 1))
    np.testing.assert_array_equal(volume.data, reference.reshape(66, 66, 66))


def test_hydrogen_nhdr_equals_pynrrd(data):
    path = data / "sim_hydrogen/hydrogen_64x64x64_float32.nhdr"
    volume = read_volume(path)
    reference, _ = nrrd.read(str(path), index_order="C")
    assert_geometry(volume, (64, 64, 64), np.float32, (1, 1, 1))
    np.testing.assert_array_equal(volume.data, reference)
    assert volume.nonfinite_count == 0
    assert volume.value_range == pytest.approx((0.0, 1.0), abs=1e-6)


def test_raw_description_gives_dims_dtype_spacing_origin(data):
    path = data / "sim_hydrogen/hydrogen_64x64x64_float32.raw"
    volume = read_volume(path, raw={"dims": (64, 64, 64), "dtype": "float32",
                                    "spacing": (0.5, 1, 2), "origin": (1, 2, 3)})
    assert_geometry(volume, (64, 64, 64), np.float32, (0.5, 1, 2), (1, 2, 3))
    np.testing.assert_array_equal(volume.data, np.fromfile(path, "<f4").reshape(64, 64, 64))


def dicom_reference(folder: Path):
    slices = [pydicom.dcmread(f) for f in sorted(folder.glob("*.dcm"))]
    slices.sort(key=lambda ds: float(ds.ImagePositionPatient[2]))  # axial: normal = +z
    return slices, np.stack([ds.pixel_array for ds in slices])


@pytest.mark.parametrize("target", ["dicom_mr_scout", "dicom_mr_scout/1-2.dcm"])
def test_dicom_series_sorted_by_position_equals_pydicom(data, target):
    volume = read_volume(data / target)
    slices, reference = dicom_reference(data / "dicom_mr_scout")
    assert [Path(ds.filename).name for ds in slices] == ["1-3.dcm", "1-2.dcm", "1-1.dcm"]
    # ImagePositionPatient (-250, -250, -12) and the axial orientation are LPS: RAS negates x, y
    assert_geometry(volume, (3, 512, 512), np.uint16, (0.9765625, 0.9765625, 12.0),
                    (250, 250, -12))
    assert volume.direction == ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))
    np.testing.assert_array_equal(volume.data, reference)
    # BitsStored 12 of 16 is the storage's width, not a value range: min..max of 0..346
    assert volume.declared_range is None and volume.value_range == (0.0, 346.0)
    assert volume.source == str(data / target)


def test_every_supported_extension_is_a_string_with_a_dot():
    assert {".dat", ".raw", ".nrrd", ".nhdr", ".nii", ".nii.gz", ".mhd", ".mha", ".dcm", ".npy",
            ".npz"} <= set(SUPPORTED_EXTENSIONS)


# --- formats written here --------------------------------------------------------------------
def test_big_endian_raw_and_header_offset(tmp_path):
    values = np.arange(2 * 3 * 4, dtype=np.uint16).reshape(4, 3, 2) * 1000
    path = tmp_path / "scan.bin"
    path.write_bytes(b"H" * 10 + values.astype(">u2").tobytes() + b"tail")
    volume = read_volume(path, raw={"dims": (2, 3, 4), "dtype": "uint16", "endianness": "big",
                                    "offset": 10})
    np.testing.assert_array_equal(volume.data, values)
    assert volume.data.dtype == np.dtype("=u2")
    end = tmp_path / "end.bin"
    end.write_bytes(b"junk header" + values.astype("<u2").tobytes())
    np.testing.assert_array_equal(read_volume(end, raw={"dims": (2, 3, 4), "dtype": "uint16",
                                                        "offset": -1}).data, values)


def test_big_endian_scaled_nifti_equals_nibabel(tmp_path):
    stored = np.random.default_rng(1).integers(-300, 3000, size=(5, 6, 7)).astype(np.int16)
    header = nib.Nifti1Header(endianness=">")
    header.set_data_dtype(np.int16)
    image = nib.Nifti1Image(stored, np.diag([0.5, 0.75, 2.0, 1.0]), header=header)
    image.header.set_slope_inter(0.5, -1024.0)
    path = tmp_path / "big.nii"
    nib.save(image, path)
    assert nib.load(path).header.endianness == ">"
    volume = read_volume(path)
    assert_geometry(volume, (7, 6, 5), np.float32, (0.5, 0.75, 2.0))
    np.testing.assert_array_equal(volume.data, nib.load(path).get_fdata().T.astype(np.float32))
    np.testing.assert_array_equal(volume.data, stored.T * 0.5 - 1024)
    header = nib.Nifti1Header(endianness=">")
    header.set_data_dtype(np.int16)
    unscaled = nib.Nifti1Image(stored, np.eye(4), header=header)
    nib.save(unscaled, tmp_path / "big_int.nii.gz")
    assert nib.load(tmp_path / "big_int.nii.gz").header.endianness == ">"
    plain = read_volume(tmp_path / "big_int.nii.gz")
    assert plain.data.dtype == np.dtype("=i2")
    np.testing.assert_array_equal(plain.data, stored.T)


def test_attached_nrrd_and_mha_and_npy(tmp_path):
    values = np.random.default_rng(2).random((3, 4, 5)).astype(np.float32)
    nrrd.write(str(tmp_path / "a.nrrd"), values, {"encoding": "raw", "spacings": [1, 2, 3]},
               index_order="C")
    volume = read_volume(tmp_path / "a.nrrd")
    assert_geometry(volume, (3, 4, 5), np.float32, (1, 2, 3))
    np.testing.assert_array_equal(volume.data, values)
    header = ("ObjectType = Image\nNDims = 3\nDimSize = 5 4 3\nElementType = MET_FLOAT\n"
              "ElementSpacing = 1 1 2\nOffset = 1 2 3\nElementByteOrderMSB = True\n"
              "ElementDataFile = LOCAL\n").encode()
    (tmp_path / "a.mha").write_bytes(header + values.astype(">f4").tobytes())
    volume = read_volume(tmp_path / "a.mha")
    assert_geometry(volume, (3, 4, 5), np.float32, (1, 1, 2), (1, 2, 3))
    np.testing.assert_array_equal(volume.data, values)
    np.save(tmp_path / "a.npy", values)
    np.testing.assert_array_equal(read_volume(tmp_path / "a.npy").data, values)


def test_nan_and_inf_voxels_load_with_a_warning(tmp_path):
    values = np.linspace(0, 1, 4 * 4 * 4, dtype=np.float32).reshape(4, 4, 4)
    values[0, 0, :3] = [np.nan, np.inf, -np.inf]
    values[3, 3, 3] = np.nan
    path = tmp_path / "f_4x4x4_float32.raw"
    values.tofile(path)
    with pytest.warns(NonFiniteVoxelsWarning, match=r"4 of 64 voxels are not finite \(2 NaN, 1 \+Inf, 1 -Inf\)"):
        volume = read_volume(path)
    assert volume.nonfinite_count == 4
    finite = values[np.isfinite(values)]
    assert volume.value_range == (float(finite.min()), float(finite.max()))
    counts, _ = volume.histogram(16)
    assert counts.sum() == 60
    values[np.isnan(values) | np.isinf(values)] = 0.5
    values.tofile(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonFiniteVoxelsWarning)  # finite data: no warning
        assert read_volume(path).nonfinite_count == 0


# --- bad input: every message names the file and the field ---------------------------------------
def error_of(path, **kwargs) -> VolumeFileError:
    with pytest.raises(VolumeFileError) as info:
        read_volume(path, **kwargs)
    return info.value


def write_dat(folder: Path, **fields) -> Path:
    defaults = {"ObjectFileName": "v.raw", "Resolution": "4 3 2", "SliceThickness": "1 1 2",
                "Format": "UCHAR"}
    defaults.update(fields)
    path = folder / "v.dat"
    path.write_text("".join(f"{k}: {v}\n" for k, v in defaults.items() if v is not None))
    return path


def test_qvis_reads_relative_data_file_and_spacing(tmp_path):
    (tmp_path / "v.raw").write_bytes(bytes(range(24)))
    volume = read_volume(write_dat(tmp_path))
    assert_geometry(volume, (2, 3, 4), np.uint8, (1, 1, 2))
    np.testing.assert_array_equal(volume.data.ravel(), np.arange(24))
    (tmp_path / "w.raw").write_bytes(np.arange(24, dtype="<u2").tobytes())
    volume = read_volume(write_dat(tmp_path, ObjectFileName="w.raw", Format="USHORT_12"))
    # USHORT_12 is a storage width, not a value range: min..max
    assert volume.data.dtype == np.uint16 and volume.value_range == (0.0, 23.0)


@pytest.mark.parametrize("change, field, words", [
    ({"Format": "RGB24"}, "Format", ["unknown Format", "'RGB24'"]),
    ({"ObjectFileName": "missing.raw"}, "ObjectFileName", ["missing.raw", "does not exist"]),
    ({"Resolution": "4 0 2"}, "Resolution", ["at least 1", "(4, 0, 2)"]),
    ({"Resolution": "4 3 1"}, "Resolution", ["larger", "expected 12 bytes, found 24"]),
    ({"Resolution": "4 3"}, "Resolution", ["expected 3 values"]),
    ({"Format": "USHORT"}, "Resolution", ["truncated", "expected 48 bytes, found 24"]),
    ({"SliceThickness": "1 -1 1"}, "SliceThickness", ["positive"]),
    ({"Format": None}, "Format", ["missing"]),
])
def test_bad_qvis_headers(tmp_path, change, field, words):
    (tmp_path / "v.raw").write_bytes(bytes(24))
    path = write_dat(tmp_path, **change)
    error = error_of(path)
    assert error.file == str(path) and error.field == field
    assert str(error).startswith(f"{path} [{field}]: ")
    for word in words:
        assert word in str(error)


def test_truncated_and_oversized_raw(tmp_path):
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(100))
    raw = {"dims": (5, 5, 5), "dtype": "uint8"}
    error = error_of(path, raw=raw)
    assert (error.file, error.field) == (str(path), "dims")
    assert "truncated: expected 125 bytes, found 100" in str(error)
    error = error_of(path, raw={"dims": (3, 3, 3), "dtype": "uint8"})
    assert "larger than the header describes: expected 27 bytes, found 100" in str(error)
    assert read_volume(path, raw={**raw, "dims": (3, 3, 3), "offset": 0}).data.shape == (3, 3, 3)
    assert error_of(path, raw={**raw, "dims": (5, 0, 5)}).field == "dims"
    assert error_of(path, raw={**raw, "dtype": "complex64"}).field == "dtype"
    assert error_of(path, raw={**raw, "colour": 1}).field == "raw"
    assert error_of(path).field == "raw"  # no description and no dims in the name


def copy_headsq(data: Path, target: Path, drop=None) -> Path:
    for k in range(1, 94):
        if k != drop:
            shutil.copy(data / f"ct_head_headsq/quarter.{k}", target / f"quarter.{k}")
    shutil.copy(data / "ct_head_headsq/quarter.nhdr", target / "quarter.nhdr")
    return target / "quarter.nhdr"


def test_multi_file_nrrd_errors(data, tmp_path):
    header = copy_headsq(data, tmp_path, drop=93)
    error = error_of(header)
    assert (error.file, error.field) == (str(header), "data file")
    assert "quarter.93" in str(error) and "does not exist" in str(error)
    (tmp_path / "quarter.93").write_bytes(bytes(8000))
    error = error_of(header)
    assert error.field == "sizes" and "quarter.93" in str(error)
    assert "truncated: expected 8192 bytes, found 8000" in str(error)
    header.write_text(header.read_text().replace("sizes: 64 64 93", "sizes: 64 64 0"))
    assert error_of(header).field == "sizes"


def test_list_form_multi_file_nrrd(tmp_path):
    values = np.arange(2 * 3 * 4, dtype=np.int16).reshape(4, 3, 2)
    names = []
    for k, plane in enumerate(values):
        names.append(f"s{k}.raw")
        plane.astype(">i2").tofile(tmp_path / names[-1])
    (tmp_path / "l.nhdr").write_text("NRRD0004\ntype: short\ndimension: 3\nsizes: 2 3 4\n"
                                     "endian: big\nencoding: raw\ndata file: LIST\n"
                                     + "\n".join(names) + "\n")
    np.testing.assert_array_equal(read_volume(tmp_path / "l.nhdr").data, values)


@pytest.mark.parametrize("line, field", [("type: block", "type"), ("sizes: 64 64", "sizes"),
                                         ("data file: nothing.raw", "data file")])
def test_bad_nrrd_fields(data, tmp_path, line, field):
    shutil.copy(data / "sim_hydrogen/hydrogen_64x64x64_float32.raw", tmp_path / "h.raw")
    text = (data / "sim_hydrogen/hydrogen_64x64x64_float32.nhdr").read_text()
    key = line.split(":")[0]
    text = "\n".join(line if l.startswith(key + ":") else l for l in text.splitlines())
    path = tmp_path / "h.nhdr"
    path.write_text(text.replace("hydrogen_64x64x64_float32.raw", "h.raw") + "\n")
    error = error_of(path)
    assert (error.file, error.field) == (str(path), field)


def test_bad_metaimage(data, tmp_path):
    shutil.copy(data / "mri_head_tiny/HeadMRVolume.raw", tmp_path / "HeadMRVolume.raw")
    text = (data / "mri_head_tiny/HeadMRVolume.mhd").read_text()
    path = tmp_path / "h.mhd"
    path.write_text(text.replace("MET_UCHAR", "MET_RGB"))
    assert error_of(path).field == "ElementType"
    path.write_text(text.replace("DimSize = 48 62 42", "DimSize = 48 62 43"))
    error = error_of(path)
    assert error.field == "DimSize" and "expected 127968 bytes, found 124992" in str(error)
    path.write_text(text.replace("HeadMRVolume.raw", "gone.raw"))
    assert error_of(path).field == "ElementDataFile"


def test_truncated_nifti_and_npy(tmp_path):
    image = nib.Nifti1Image(np.arange(1000, dtype=np.float32).reshape(10, 10, 10), np.eye(4))
    nib.save(image, tmp_path / "t.nii.gz")
    blob = (tmp_path / "t.nii.gz").read_bytes()
    (tmp_path / "t.nii.gz").write_bytes(blob[: len(blob) // 2])
    error = error_of(tmp_path / "t.nii.gz")
    assert error.file == str(tmp_path / "t.nii.gz")
    np.save(tmp_path / "t.npy", np.zeros((4, 4, 4), np.float32))
    blob = (tmp_path / "t.npy").read_bytes()
    (tmp_path / "t.npy").write_bytes(blob[:-10])
    error = error_of(tmp_path / "t.npy")
    assert error.field == "shape" and "truncated" in str(error)
    np.save(tmp_path / "v.npy", np.zeros(5))
    assert error_of(tmp_path / "v.npy").field == "shape"


def test_too_large_for_memory_names_both_sizes(tmp_path, monkeypatch, data):
    monkeypatch.setattr("vgraph.memory.available_memory", lambda: 1000)
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(4096))
    error = error_of(path, raw={"dims": (16, 16, 16), "dtype": "uint8"})
    assert "too large for memory" in str(error) and "(4096 bytes)" in str(error)
    assert "1000 bytes is available" in str(error)
    assert "too large for memory" in str(error_of(data / "ct_engine/engine.nii.gz"))
    assert "too large for memory" in str(error_of(data / "dicom_mr_scout"))


def copy_dicom(data: Path, target: Path) -> list[Path]:
    files = []
    for name in ("1-1.dcm", "1-2.dcm", "1-3.dcm"):
        shutil.copy(data / "dicom_mr_scout" / name, target / name)
        files.append(target / name)
    return files


def test_dicom_non_uniform_spacing_is_refused(data, tmp_path):
    files = copy_dicom(data, tmp_path)
    ds = pydicom.dcmread(files[0])  # z = 12 -> 20: steps 12 and 20
    ds.ImagePositionPatient = [-250, -250, 20]
    ds.save_as(files[0])
    error = error_of(tmp_path)
    assert (error.file, error.field) == (str(tmp_path), "ImagePositionPatient")
    assert "non-uniform slice spacing" in str(error) and "from 12 to 20 mm" in str(error)
    assert "20 mm between 1-2.dcm and 1-1.dcm" in str(error)
    ds.ImagePositionPatient = [-250, -250, 0]
    ds.save_as(files[0])
    assert "duplicate slice" in str(error_of(tmp_path))


def test_dicom_rescale_gives_float32(data, tmp_path):
    files = copy_dicom(data, tmp_path)
    for f in files:
        ds = pydicom.dcmread(f)
        ds.RescaleSlope, ds.RescaleIntercept = 0.5, -100
        ds.save_as(f)
    volume = read_volume(tmp_path)
    _, reference = dicom_reference(tmp_path)
    assert volume.data.dtype == np.float32
    np.testing.assert_array_equal(volume.data, reference * 0.5 - 100)
    assert volume.declared_range is None
    assert volume.value_range == (float(reference.min()) * 0.5 - 100, reference.max() * 0.5 - 100)


def test_dicom_folder_errors(data, tmp_path):
    assert error_of(tmp_path).field == "folder"  # empty
    files = copy_dicom(data, tmp_path)
    ds = pydicom.dcmread(files[2])
    ds.SeriesInstanceUID = "1.2.3"
    ds.save_as(files[2])
    assert error_of(tmp_path).field == "SeriesInstanceUID"
    assert read_volume(files[2]).data.shape == (1, 512, 512)
    assert read_volume(files[0]).data.shape == (2, 512, 512)


def test_missing_and_unknown_files(tmp_path):
    assert "does not exist" in str(error_of(tmp_path / "none.nii.gz"))
    (tmp_path / "a.xyz").write_text("hello")
    error = error_of(tmp_path / "a.xyz")
    assert error.field == "extension" and ".nrrd" in str(error)


# --- the VTK source files (optional formats) -----------------------------------------------------
@pytest.mark.parametrize("name, raw_copy, dtype", [
    ("sim_neghip/neghip.slc", "sim_neghip/neghip_66x66x66_uint8.raw", "u1"),
    ("sim_hydrogen/hydrogen.vti", "sim_hydrogen/hydrogen_64x64x64_float32.raw", "<f4"),
])
def test_vtk_sources_equal_their_derived_raw_copies(data, name, raw_copy, dtype):
    volume = read_volume(data / name)
    reference = np.fromfile(data / raw_copy, dtype)
    n = round(len(reference) ** (1 / 3))
    assert_geometry(volume, (n, n, n), dtype, (1, 1, 1))
    np.testing.assert_array_equal(volume.data, reference.reshape(n, n, n))


def vti_text(array_xml: str, appended: bytes = b"", compressor: str = "",
             extent="0 1 0 2 0 3") -> bytes:
    head = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="BigEndian" '
            f'header_type="UInt64"{compressor}>\n<ImageData WholeExtent="{extent}" '
            f'Origin="1 2 3" Spacing="0.5 1 2">\n<Piece Extent="{extent}">\n'
            f'<PointData Scalars="b">\n{array_xml}\n</PointData>\n</Piece>\n</ImageData>\n')
    tail = b'<AppendedData encoding="raw">\n_' + appended + b"\n</AppendedData>\n" if appended else b""
    return head.encode() + tail + b"</VTKFile>\n"


def test_vti_inline_appended_and_compressed_forms(tmp_path):
    import base64
    import zlib
    values = np.arange(24, dtype=np.int16).reshape(4, 3, 2) * 100 - 700
    payload = values.astype(">i2").tobytes()
    joint = base64.b64encode(np.array([len(payload)], ">u8").tobytes() + payload).decode()
    (tmp_path / "inline.vti").write_bytes(vti_text(
        f'<DataArray type="Int16" Name="b" format="binary">{joint}</DataArray>'))
    volume = read_volume(tmp_path / "inline.vti")
    assert_geometry(volume, (4, 3, 2), np.int16, (0.5, 1, 2), (1, 2, 3))
    np.testing.assert_array_equal(volume.data, values)

    other = np.zeros(24, ">f8").tobytes()
    block = np.array([len(other)], ">u8").tobytes() + other
    appended = block + np.array([len(payload)], ">u8").tobytes() + payload
    (tmp_path / "appended.vti").write_bytes(vti_text(
        '<DataArray type="Float64" Name="a" format="appended" offset="0"/>\n'
        f'<DataArray type="Int16" Name="b" format="appended" offset="{len(block)}"/>', appended))
    np.testing.assert_array_equal(read_volume(tmp_path / "appended.vti").data, values)

    halves = [zlib.compress(payload[:24]), zlib.compress(payload[24:])]
    header = np.array([2, 24, 24, *map(len, halves)], ">u8").tobytes()
    (tmp_path / "zlib.vti").write_bytes(vti_text(
        '<DataArray type="Int16" Name="b" format="appended" offset="0"/>',
        header + b"".join(halves), ' compressor="vtkZLibDataCompressor"'))
    np.testing.assert_array_equal(read_volume(tmp_path / "zlib.vti").data, values)

    (tmp_path / "short.vti").write_bytes(vti_text(
        f'<DataArray type="Int16" Name="b" format="binary">{joint}</DataArray>', extent="0 1 0 2 0 4"))
    assert error_of(tmp_path / "short.vti").field == "DataArray"


def test_truncated_slc_names_the_slice(data, tmp_path):
    blob = (data / "sim_neghip/neghip.slc").read_bytes()
    (tmp_path / "n.slc").write_bytes(blob[: len(blob) - 500])
    error = error_of(tmp_path / "n.slc")
    assert error.field.startswith("slice ") and "truncated" in str(error)
