"""Float data beyond float32's range (|v| > 3.4028235e38): every reader keeps float64 data as
float64 with its exact values, scaled NIfTI and DICOM values that leave float32's range become
float64 instead of +-Inf, and NaN/Inf voxels are still reported."""

import base64

import nibabel as nib
import numpy as np
import pydicom
import pytest

from vgraph.io import NonFiniteVoxelsWarning, read_volume, write_volume
from vgraph.volume import Volume

F32_MAX = float(np.finfo(np.float32).max)
VALUES = np.array([1e300, -1e300, 3.5e38, -1e39, 1.0, 0.0, np.nan, np.inf]).reshape(2, 2, 2)
NONFINITE = r"2 of 8 voxels are not finite \(1 NaN, 1 \+Inf, 0 -Inf\)"


def written_by_vgraph(folder, name):
    path = folder / name
    write_volume(Volume(VALUES.copy()), path)
    return path


def raw_file(folder, name, header: str = "", order: str = "<"):
    (folder / "d.raw").write_bytes(VALUES.astype(order + "f8").tobytes())
    path = folder / name
    path.write_text(header)
    return path


def vti_file(folder, fmt):
    if fmt == "ascii":
        data = " ".join(repr(float(v)) for v in VALUES.ravel())
    else:
        payload = VALUES.astype("<f8").tobytes()
        data = base64.b64encode(np.array([len(payload)], "<u4").tobytes() + payload).decode()
    path = folder / "v.vti"
    path.write_text(f'<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian">'
                    f'<ImageData WholeExtent="0 1 0 1 0 1"><Piece><PointData>'
                    f'<DataArray type="Float64" Name="v" format="{fmt}">{data}</DataArray>'
                    f'</PointData></Piece></ImageData></VTKFile>')
    return path


SOURCES = {
    "npy": lambda f: written_by_vgraph(f, "v.npy"),
    "npz": lambda f: written_by_vgraph(f, "v.npz"),
    "nrrd": lambda f: written_by_vgraph(f, "v.nrrd"),
    "nii": lambda f: written_by_vgraph(f, "v.nii"),
    "nii.gz": lambda f: written_by_vgraph(f, "v.nii.gz"),
    "raw": lambda f: raw_file(f, "v_2x2x2_float64.raw"),
    "qvis": lambda f: raw_file(f, "v.dat", "ObjectFileName: d.raw\nResolution: 2 2 2\n"
                                           "Format: DOUBLE\nEndianness: BIG\n", ">"),
    "metaimage": lambda f: raw_file(f, "v.mhd", "NDims = 3\nDimSize = 2 2 2\n"
                                                "ElementType = MET_DOUBLE\nElementDataFile = d.raw\n"),
    "nhdr ascii": lambda f: raw_file(f, "v.nrrd", "NRRD0004\ntype: double\ndimension: 3\n"
                                     "sizes: 2 2 2\nencoding: ascii\n\n"
                                     + " ".join(repr(float(v)) for v in VALUES.ravel())),
    "vti ascii": lambda f: vti_file(f, "ascii"),
    "vti binary": lambda f: vti_file(f, "binary"),
}


@pytest.mark.parametrize("source", SOURCES)
def test_float64_beyond_float32_is_kept_exactly(tmp_path, source):
    path = SOURCES[source](tmp_path)
    if source == "raw":
        (tmp_path / "v_2x2x2_float64.raw").write_bytes(VALUES.astype("<f8").tobytes())
    with pytest.warns(NonFiniteVoxelsWarning, match=NONFINITE):
        volume = read_volume(path)
    assert volume.data.dtype == np.float64
    np.testing.assert_array_equal(volume.data, VALUES)  # NaN where NaN, 1e300 as 1e300
    assert volume.nonfinite_count == 2


def nifti_scaled(folder, stored: np.ndarray, slope: float, inter: float = 0.0):
    image = nib.Nifti1Image(stored.T, np.eye(4))
    image.header.set_slope_inter(slope, inter)
    path = folder / "s.nii"
    nib.save(image, path)
    return path


def test_nifti_scaled_beyond_float32_becomes_float64(tmp_path):
    stored = np.arange(8, dtype=np.uint8).reshape(2, 2, 2) * 30
    volume = read_volume(nifti_scaled(tmp_path, stored, 1e37, -5.0))
    assert volume.data.dtype == np.float64 and np.isfinite(volume.data).all()
    np.testing.assert_array_equal(volume.data, stored.astype(np.float64) * np.float32(1e37) - 5.0)
    assert np.abs(volume.data).max() > F32_MAX


def test_nifti_scaled_within_float32_stays_float32(tmp_path):
    stored = np.arange(8, dtype=np.int16).reshape(2, 2, 2)
    volume = read_volume(nifti_scaled(tmp_path, stored, 2.0, -1.0))
    assert volume.data.dtype == np.float32
    np.testing.assert_array_equal(volume.data, stored * 2.0 - 1.0)


def dicom_series(folder, slope: str):
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian
    stored = np.array([[[0, 1000], [30000, 65535]], [[5, 6], [7, 8]]], dtype=np.uint16)
    for k, plane in enumerate(stored):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID = "1.2.3", f"1.2.3.{k}"
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = Dataset()
        ds.file_meta, ds.SeriesInstanceUID, ds.Rows, ds.Columns = meta, "1.2", 2, 2
        ds.BitsAllocated, ds.BitsStored, ds.PixelRepresentation, ds.SamplesPerPixel = 16, 16, 0, 1
        ds.PhotometricInterpretation, ds.PixelSpacing = "MONOCHROME2", [1, 1]
        ds.ImageOrientationPatient, ds.ImagePositionPatient = [1, 0, 0, 0, 1, 0], [0, 0, k]
        ds.RescaleSlope, ds.RescaleIntercept = slope if k == 0 else "1", "0"
        ds.PixelData = plane.tobytes()
        ds.save_as(folder / f"{k}.dcm", enforce_file_format=True)
    return stored


def test_dicom_rescaled_beyond_float32_becomes_float64(tmp_path):
    stored = dicom_series(tmp_path, "1e35")
    volume = read_volume(tmp_path)
    assert volume.data.dtype == np.float64 and np.isfinite(volume.data).all()
    np.testing.assert_array_equal(volume.data[0], stored[0] * 1e35)
    np.testing.assert_array_equal(volume.data[1], stored[1])
    assert pydicom.dcmread(tmp_path / "0.dcm").RescaleSlope == 1e35


def test_dicom_rescaled_within_float32_stays_float32(tmp_path):
    stored = dicom_series(tmp_path, "0.5")
    volume = read_volume(tmp_path)
    assert volume.data.dtype == np.float32
    np.testing.assert_array_equal(volume.data[0], stored[0] * 0.5)
