"""Bad input of every kind, in every format, raises VolumeFileError naming the file and the header
field: files that are not regular files, library exceptions on damaged files, truncation, wrong
magic, non-UTF-8 headers and absurd header numbers. (Size limits: test_io_limits.py.)"""

import gzip
import io
import os
import random
import struct
from pathlib import Path

import nibabel as nib
import numpy as np
import pytest

from vgraph.errors import VolumeFileError
from vgraph.io import read_volume
from fuzz_cases import SEEDS, run_case, write_case

VOLUME_TARGETS = [t for t in SEEDS if t not in ("image", "networks")]


def error_of(path, field=None, *words, within: Path | None = None, **kwargs) -> VolumeFileError:
    """The error reading ``path``; it names ``path`` (or a file ``within`` a series folder)."""
    with pytest.raises(VolumeFileError) as info:
        read_volume(path, **kwargs)
    error = info.value
    if within is None:
        assert error.file == str(path), str(error)
    else:
        assert Path(error.file).parent == within, str(error)
    if field is not None:
        assert error.field == field, str(error)
    for word in words:
        assert word in str(error), str(error)
    return error


# --- files that are not regular files -------------------------------------------------------------
def test_fifo_device_and_folder_given_as_raw_files_are_not_regular_files(tmp_path):
    os.mkfifo(tmp_path / "v.raw")
    raw = {"dims": (2, 2, 2), "dtype": "uint8"}
    for path, kind in [(tmp_path / "v.raw", "a FIFO"), (Path("/dev/zero"), "a character device"),
                       (tmp_path, "a directory")]:
        error_of(path, None, f"is not a regular file ({kind})", raw=raw)


HEADERS = {
    "v.dat": ("ObjectFileName: d.raw\nResolution: 2 2 2\nFormat: UCHAR\n", "ObjectFileName"),
    "v.nhdr": ("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
               "data file: d.raw\n", "data file"),
    "v.mhd": ("NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = d.raw\n",
              "ElementDataFile"),
}


@pytest.mark.parametrize("header", HEADERS)
@pytest.mark.parametrize("kind", ["a FIFO", "a directory", "a character device"])
def test_a_data_file_that_is_not_a_regular_file_is_refused(tmp_path, header, kind):
    text, field = HEADERS[header]
    (tmp_path / header).write_text(text)
    data = tmp_path / "d.raw"
    {"a FIFO": os.mkfifo, "a directory": os.mkdir,
     "a character device": lambda p: os.symlink("/dev/zero", p)}[kind](data)
    error_of(tmp_path / header, field, "d.raw", f"is not a regular file ({kind})")


@pytest.mark.parametrize("name", ["zero.nrrd", "zero.nii", "zero.npy", "zero.dat", "zero.slc",
                                  "zero.vti", "zero.dcm", "zero.npz", "zero.mha", "zero"])
def test_a_device_with_a_volume_name_is_refused_before_it_is_opened(tmp_path, name):
    os.symlink("/dev/zero", tmp_path / name)
    error_of(tmp_path / name, None, "is not a regular file (a character device)")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads files whatever their permissions")
def test_an_unreadable_file_says_permission_denied(tmp_path):
    path = tmp_path / "v_2x2x2_uint8.raw"
    path.write_bytes(bytes(8))
    path.chmod(0)
    error_of(path, None, "Permission denied")


# --- exceptions of the libraries and parsers ------------------------------------------------------
def corrupt_npz() -> bytes:
    buffer = io.BytesIO()
    np.savez_compressed(buffer, data=np.arange(1000, dtype=np.float32).reshape(10, 10, 10))
    blob = bytearray(buffer.getvalue())
    blob[200] ^= 0xFF
    blob[300] ^= 0xFF
    return bytes(blob)


def encrypted_npz() -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, data=np.zeros((2, 2, 2), np.uint8))
    blob = bytearray(buffer.getvalue())
    for signature, flags_at in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):  # local, central
        blob[blob.find(signature) + flags_at] |= 1
    return bytes(blob)


def vti(array: str, tail: str = "") -> bytes:
    return (f'<VTKFile type="ImageData" version="1.0"><ImageData WholeExtent="0 1 0 0 0 0">'
            f'<Piece Extent="0 1 0 0 0 0"><PointData Scalars="a">{array}</PointData></Piece>'
            f'</ImageData>{tail}</VTKFile>').encode()


def npy_with_header(header: str) -> bytes:
    text = header.ljust(117) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode() + bytes(8)


DAMAGED = [
    ("bad.npz", corrupt_npz(), "archive", ["Error -3 while decompressing"]),
    ("secret.npz", encrypted_npz(), "data", ["encrypted"]),
    ("a.vti", vti('<DataArray type="Float32" Name="a" format="ascii">1 x</DataArray>'),
     "DataArray", ["not a list of float32 values"]),
    ("c.vti", vti('<DataArray type="UInt8" Name="a" NumberOfComponents="x" format="ascii">1 2'
                  '</DataArray>'), "NumberOfComponents", ["expected an integer"]),
    ("o.vti", vti('<DataArray type="UInt8" Name="a" format="appended" offset="."/>',
                  '<AppendedData encoding="raw">_xx</AppendedData>'), "offset", ["'.'"]),
    ("u.vti", vti('<DataArray type="UInt8" Name="a" format="appended" offset="0"/>',
                  '<AppendedData encoding="raw"></AppendedData>'), "AppendedData", ["'_'"]),
    ("e.mhd", b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile =\n",
     "ElementDataFile", ["no file name"]),
    ("h.npy", npy_with_header("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2,"),
     "header", ["not a readable .npy header"]),
    ("n.slc", b"11111\n2 2 2 8\n1 1 1\n0 0 0 0\n-4 1 X", "icon", ["negative byte count"]),
    ("s.nhdr", b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 x\nencoding: raw\n", "header",
     ["invalid NRRD header"]),
    ("p.nhdr", b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"  # int() limit
               b"data file: q%d " + b"9" * 5000 + b" 1 1\n", "data file", ["out of range"]),
    ("b.nrrd", b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n"  # ssize_t
               b"byte skip: 9223372036854775807\n\n" + gzip.compress(bytes(8)), "sizes",
     ["fewer than"]),
]


@pytest.mark.parametrize("name, content, field, words", DAMAGED, ids=[d[0] for d in DAMAGED])
def test_library_and_parser_exceptions_become_volume_file_errors(tmp_path, name, content, field,
                                                                 words):
    (tmp_path / name).write_bytes(content)
    error_of(tmp_path / name, field, *words)


def dicom_slice(folder: Path, **fields) -> Path:
    """A valid 2 x 2 uint16 slice (explicit VR little endian), with ``fields`` set."""
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID = "1.2.840.10008.5.1.4.1.1.4", "1.2.3.4"
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta, ds.SOPClassUID, ds.SOPInstanceUID = meta, "1.2.840.10008.5.1.4.1.1.4", "1.2.3.4"
    ds.SeriesInstanceUID, ds.Rows, ds.Columns, ds.SamplesPerPixel = "1.2.3", 2, 2, 1
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 0
    ds.PhotometricInterpretation, ds.PixelSpacing = "MONOCHROME2", [1, 1]
    ds.ImageOrientationPatient, ds.ImagePositionPatient = [1, 0, 0, 0, 1, 0], [0, 0, 0]
    ds.PixelData = np.arange(4, dtype="<u2").tobytes()
    for key, value in fields.items():
        setattr(ds, key, value)
    ds.save_as(folder / "1.dcm", enforce_file_format=True)
    return folder / "1.dcm"


def test_dicom_values_pydicom_cannot_decode_name_their_field(tmp_path):
    path = dicom_slice(tmp_path)
    assert read_volume(tmp_path).data.shape == (1, 2, 2)
    blob = path.read_bytes()
    rows = blob.index(b"\x28\x00\x10\x00US\x02\x00")  # (0028,0010) Rows, 2 bytes: make it 3
    path.write_bytes(blob[:rows + 6] + b"\x03\x00" + blob[rows + 8:rows + 10] + b"\x00"
                     + blob[rows + 10:])
    error_of(tmp_path, "Rows", "cannot decode the value", within=tmp_path)


@pytest.mark.parametrize("field, value, words", [
    ("ImagePositionPatient", [0, 0], ["expected 3 finite numbers"]),
    ("ImageOrientationPatient", [1, 0, 0, 0, 1], ["expected 6 finite numbers"]),
    ("PixelSpacing", ["nan", "1"], ["finite numbers"]),
    ("RescaleSlope", "1e400", ["finite numbers"]),
    ("BitsAllocated", 12, ["8, 16 or 32 bits"]),
])
def test_odd_dicom_values_are_refused_with_their_field(tmp_path, field, value, words):
    dicom_slice(tmp_path, **{field: value})
    error = error_of(tmp_path, None, *words, within=tmp_path)
    assert field in error.field


# --- truncated files ------------------------------------------------------------------------------
@pytest.mark.parametrize("target", VOLUME_TARGETS)
def test_truncated_files_are_refused_in_every_format(tmp_path, target):
    case = next(c for c in (SEEDS[target](random.Random(seed)) for seed in range(100))
                if run_case(c, _fresh(tmp_path)) == "ok" and c.raw is None)
    largest = max(case.files, key=lambda name: len(case.files[name]))
    case.files[largest] = case.files[largest][:len(case.files[largest]) // 2]
    folder = _fresh(tmp_path)
    path = write_case(case, folder)
    error = error_of(path, None, within=folder if target == "dicom" else None)
    assert error.field is not None


def _fresh(tmp_path: Path) -> Path:
    folder = tmp_path / str(len(list(tmp_path.iterdir())))
    folder.mkdir()
    return folder


# --- wrong magic ----------------------------------------------------------------------------------
@pytest.mark.parametrize("name, content, field", [
    ("x.nrrd", b"NRRX0004\ntype: uchar\n", "magic"),
    ("x.nii", bytes(range(256)) * 2, "sizeof_hdr"),
    ("x.npy", b"\x93NUMPX\x01\x00" + bytes(120), "header"),
    ("x.slc", b"12345\n2 2 2 8\n", "magic"),
    ("x.vti", b'<VTKFile type="PolyData"></VTKFile>', "VTKFile type"),
    ("x.dcm", b"\x00" * 128 + b"DICX" + bytes(64), "header"),
    ("x.npz", b"PK\x03\x04 not really a zip", "archive"),
    ("x.dat", b"\x89PNG\r\n\x1a\n", "line 1"),
    ("x.mha", b"\x89PNG\r\n\x1a\n", "line 1"),
])
def test_wrong_magic_is_refused(tmp_path, name, content, field):
    (tmp_path / name).write_bytes(content)
    error_of(tmp_path / name, field)


# --- non-UTF-8 headers ----------------------------------------------------------------------------
@pytest.mark.parametrize("name, content, field", [
    ("v.dat", b"ObjectFileName: d.raw\nResolution: 2 2 2\nFormat: UCHAR\xff\n", "Format"),
    ("v.nhdr", b"NRRD0004\ntype: \xffuchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n", "type"),
    ("v.mhd", b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_\xe9\nElementDataFile = d.raw\n",
     "ElementType"),
    ("v.vti", b'<?xml version="1.0" encoding="UTF-8"?><VTKFile type="\xff\xfe"/>', "VTKFile"),
    ("v.nhdr", b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
               b"data file: d\xe9.raw\n", "data file"),
])
def test_non_utf8_headers_are_refused_with_their_field(tmp_path, name, content, field):
    (tmp_path / "d.raw").write_bytes(bytes(8))
    (tmp_path / name).write_bytes(content)
    error_of(tmp_path / name, field)


def test_a_non_utf8_comment_does_not_matter(tmp_path):
    (tmp_path / "d.raw").write_bytes(bytes(8))
    (tmp_path / "v.nhdr").write_bytes(b"NRRD0004\n# \xff\xfe latin-1 \xe9\ntype: uchar\ndimension: 3\n"
                                      b"sizes: 2 2 2\nencoding: raw\ndata file: d.raw\n")
    assert read_volume(tmp_path / "v.nhdr").data.shape == (2, 2, 2)


# --- absurd header numbers ------------------------------------------------------------------------
QVIS = "ObjectFileName: d.raw\nResolution: {res}\nSliceThickness: {thick}\nFormat: UCHAR\n"
NHDR = ("NRRD0004\ntype: uchar\ndimension: 3\nsizes: {sizes}\nencoding: raw\ndata file: d.raw\n"
        "{extra}")
MHD = "NDims = {ndims}\nDimSize = {size}\nElementType = MET_UCHAR\n{extra}ElementDataFile = d.raw\n"
SLC = "11111\n{dims} 8\n{spacing}\n0 0 0 0\n0 0 X"
VTI = ('<VTKFile type="ImageData" version="1.0"><ImageData WholeExtent="{extent}" Spacing="{spacing}">'
       '<Piece><PointData><DataArray type="UInt8" Name="a" format="ascii">0 0 0 0 0 0 0 0'
       '</DataArray></PointData></Piece></ImageData></VTKFile>')
ABSURD = [
    ("v.dat", QVIS.format(res="1e30 1 1", thick="1 1 1"), "Resolution"),
    ("v.dat", QVIS.format(res="-4 3 2", thick="1 1 1"), "Resolution"),
    ("v.dat", QVIS.format(res="99999999999 99999999999 99999999999", thick="1 1 1"), "Resolution"),
    ("v.dat", QVIS.format(res="2 2 2", thick="nan 1 1"), "SliceThickness"),
    ("v.nhdr", NHDR.format(sizes="1e30 2 2", extra=""), "sizes"),  # pynrrd wraps it negative
    ("v.nhdr", NHDR.format(sizes="-5 2 2", extra=""), "sizes"),
    ("v.nhdr", NHDR.format(sizes="2 2 2", extra="spacings: -1 1 1\n"), "spacings"),
    ("v.nhdr", NHDR.format(sizes="2 2 2", extra="byte skip: 1000000000000000000\n"), "sizes"),
    ("v.nhdr", NHDR.format(sizes="2 2 2", extra="line skip: 1000000000000000000\n"), "line skip"),
    ("v.nhdr", NHDR.format(sizes="2 2 2", extra="space dimension: 3\nspace origin: (nan,0,0)\n"),
     "space origin"),
    ("v.mhd", MHD.format(ndims=3, size="1e30 2 2", extra=""), "DimSize"),
    ("v.mhd", MHD.format(ndims=1000000000, size="2 2 2", extra=""), "NDims"),
    ("v.mhd", MHD.format(ndims=3, size="2 2 2", extra="HeaderSize = 1000000000000000000\n"),
     "DimSize"),
    ("v.mhd", MHD.format(ndims=3, size="2 2 2", extra="ElementSpacing = nan 1 1\n"),
     "ElementSpacing"),
    ("v.slc", SLC.format(dims="1e30 2 2", spacing="1 1 1"), "dimensions"),
    ("v.slc", SLC.format(dims="2 2 2", spacing="nan 1 1"), "spacing"),
    ("v.vti", VTI.format(extent="0 1e30 0 1 0 1", spacing="1 1 1"), "WholeExtent"),
    ("v.vti", VTI.format(extent="0 -5 0 1 0 1", spacing="1 1 1"), "WholeExtent"),
    ("v.vti", VTI.format(extent="0 1 0 1 0 1", spacing="nan 1 1"), "Spacing"),
    ("v.npy", npy_with_header("{'descr': '<f4', 'fortran_order': False, "
                              "'shape': (1000000000000, 1000000000000, 3), }"), "shape"),
    ("v.npy", npy_with_header("{'descr': '<f4', 'fortran_order': False, 'shape': (-2, 2, 2), }"),
     "shape"),
]


@pytest.mark.parametrize("name, content, field", ABSURD, ids=[f"{a[0]}-{a[2]}-{i}"
                                                              for i, a in enumerate(ABSURD)])
def test_absurd_header_numbers_are_refused_with_their_field(tmp_path, name, content, field):
    (tmp_path / "d.raw").write_bytes(bytes(8))
    (tmp_path / name).write_bytes(content.encode() if isinstance(content, str) else content)
    error_of(tmp_path / name, field)


@pytest.mark.parametrize("description, field", [
    ({"dims": (10**12, 10**12, 10**12), "dtype": "uint8"}, "dims"),
    ({"dims": (2, 2, 2), "dtype": "uint8", "offset": 10**18}, "dims"),
    ({"dims": (float("nan"), 2, 2), "dtype": "uint8"}, "raw"),
    ({"dims": (2, 2, 2), "dtype": "uint8", "spacing": (float("nan"), 1, 1)}, "spacing"),
    ({"dims": (2, 2, 2), "dtype": {"not": "a dtype"}}, "dtype"),
])
def test_absurd_raw_descriptions_are_refused(tmp_path, description, field):
    (tmp_path / "v.bin").write_bytes(bytes(8))
    error_of(tmp_path / "v.bin", field, raw=description)


@pytest.mark.parametrize("change, field", [
    (lambda h: h.__setitem__("pixdim", [1, float("nan"), 1, 1, 1, 1, 1, 1]), "pixdim"),
    (lambda h: h.__setitem__("dim", [3, 32767, 32767, 32767, 1, 1, 1, 1]), "dim"),
    (lambda h: h.__setitem__("vox_offset", -5), "vox_offset"),
])
def test_absurd_nifti_header_numbers_are_refused(tmp_path, change, field):
    image = nib.Nifti1Image(np.zeros((2, 2, 2), np.float64), np.eye(4))
    blob = bytearray(image.to_bytes())
    header = nib.Nifti1Header.from_fileobj(io.BytesIO(bytes(blob)), check=False)
    change(header)
    blob[:348] = header.binaryblock
    (tmp_path / "v.nii").write_bytes(bytes(blob))
    error_of(tmp_path / "v.nii", field)
