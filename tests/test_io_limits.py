"""Sizes are checked before they are trusted: tiny files that declare (or inflate to) huge data
are refused at once, with little memory, and the error names the file and the header field.

Memory is measured with tracemalloc (numpy, zlib and Python objects are all traced): every bomb
here inflates to 64 MiB or more, and a reader that inflates it before checking peaks far above
the limits asserted.
"""

import bz2
import gzip
import io
import lzma
import resource
import struct
import tracemalloc
import zipfile
import zlib

import nibabel as nib
import numpy as np
import pytest

from vgraph.errors import VolumeFileError
from vgraph import memory
from vgraph.io import read_volume

BOMB_BYTES = 64 * 2**20
SMALL_PEAK = 16 * 2**20


def deflated_zeros(nbytes: int, wbits: int) -> bytes:
    compressor = zlib.compressobj(9, zlib.DEFLATED, wbits)
    chunk = bytes(2**20)
    return b"".join(compressor.compress(chunk) for _ in range(nbytes // len(chunk))) + compressor.flush()


@pytest.fixture(scope="module")
def gzip_bomb() -> bytes:
    return deflated_zeros(BOMB_BYTES, 31)


@pytest.fixture(scope="module")
def zlib_bomb() -> bytes:
    return deflated_zeros(BOMB_BYTES, 15)


def refused(path, field: str, *words, **kwargs) -> VolumeFileError:
    """The error read_volume raises; checks the file, the field, the words and the peak memory."""
    tracemalloc.start()
    try:
        with pytest.raises(VolumeFileError) as info:
            read_volume(path, **kwargs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    error = info.value
    assert (error.file, error.field) == (str(path), field), str(error)
    assert str(error).startswith(f"{path} [{field}]: ")
    for word in words:
        assert word in str(error)
    assert peak < SMALL_PEAK, f"peak {peak / 2**20:.0f} MiB before: {error}"
    return error


NRRD_HEAD = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: {}\n"


# --- compressed data must decompress to exactly the declared bytes --------------------------------
@pytest.mark.parametrize("encoding", ["gzip", "bzip2"])
def test_attached_nrrd_inflating_past_its_sizes_is_refused_at_once(tmp_path, gzip_bomb, encoding):
    bomb = gzip_bomb if encoding == "gzip" else bz2.compress(bytes(BOMB_BYTES))
    path = tmp_path / "bomb.nrrd"
    path.write_bytes(NRRD_HEAD.format(encoding).encode() + b"\n" + bomb)
    refused(path, "sizes", "decompress to more than the 512 bytes the header declares")


def test_detached_and_multi_file_nrrd_bombs_are_refused(tmp_path, gzip_bomb):
    (tmp_path / "bomb.gz").write_bytes(gzip_bomb)
    path = tmp_path / "one.nhdr"
    path.write_text(NRRD_HEAD.format("gzip") + "data file: bomb.gz\n")
    refused(path, "sizes", "data file", "bomb.gz", "more than the 512 bytes")
    for k in range(8):
        (tmp_path / f"s{k}.gz").write_bytes(gzip.compress(bytes(64)) if k else gzip_bomb)
    path = tmp_path / "many.nhdr"
    path.write_text(NRRD_HEAD.format("gzip") + "data file: s%d.gz 0 7 1 2\n")
    refused(path, "sizes", "s0.gz", "more than the 64 bytes")


def test_compressed_data_short_of_the_sizes_are_refused(tmp_path):
    path = tmp_path / "short.nrrd"
    path.write_bytes(NRRD_HEAD.format("gzip").encode() + b"\n" + gzip.compress(bytes(500)))
    refused(path, "sizes", "decompress to 500 bytes, fewer than the 512 bytes")
    path.write_bytes(NRRD_HEAD.format("gzip").encode() + b"\n" + gzip.compress(bytes(512))[:-12])
    refused(path, "encoding", "truncated")


def test_metaimage_zlib_bomb_is_refused(tmp_path, zlib_bomb):
    path = tmp_path / "bomb.mha"
    path.write_bytes(b"NDims = 3\nDimSize = 8 8 8\nElementType = MET_UCHAR\nCompressedData = True\n"
                     b"ElementDataFile = LOCAL\n" + zlib_bomb)
    refused(path, "DimSize", "more than the 512 bytes the header declares")


def vti_with_block(block: bytes, blocks_declared: int = 1, block_size: int = 512,
                   compressor: str = "vtkZLibDataCompressor") -> bytes:
    header = np.array([blocks_declared, block_size, block_size, len(block)], "<u8").tobytes()
    return (b'<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt64" '
            b'compressor="' + compressor.encode() + b'"><ImageData WholeExtent="0 7 0 7 0 7">'
            b'<Piece Extent="0 7 0 7 0 7"><PointData><DataArray type="UInt8" Name="s" '
            b'format="appended" offset="0"/></PointData></Piece></ImageData>'
            b'<AppendedData encoding="raw">_' + header + block + b"</AppendedData></VTKFile>")


@pytest.mark.parametrize("compressor", ["vtkZLibDataCompressor", "vtkLZMADataCompressor"])
def test_vti_block_inflating_past_its_declared_size_is_refused(tmp_path, zlib_bomb, compressor):
    block = zlib_bomb if compressor.startswith("vtkZLib") else lzma.compress(bytes(BOMB_BYTES))
    path = tmp_path / "bomb.vti"
    path.write_bytes(vti_with_block(block, compressor=compressor))
    refused(path, "DataArray", "block 0 decompress to more than the 512 bytes")


def test_vti_block_header_must_match_the_extent_before_inflating(tmp_path, zlib_bomb):
    path = tmp_path / "blocks.vti"
    path.write_bytes(vti_with_block(zlib_bomb, blocks_declared=2**40))
    refused(path, "DataArray", "declares 1099511627776 blocks of 512 bytes; the extent needs 512")


def nifti_bytes(shape=(8, 8, 8), extension_size: int | None = None) -> bytes:
    image = nib.Nifti1Image(np.zeros(shape, np.uint8), np.eye(4))
    blob = bytearray(image.to_bytes())
    if extension_size is not None:  # an extension header claiming extension_size bytes
        blob[348:352] = b"\x01\x00\x00\x00"
        blob[352:352] = struct.pack("<ii", extension_size, 0)
        blob[108:112] = struct.pack("<f", 368.0)
    return bytes(blob)


def test_nii_gz_holding_more_than_its_dim_is_refused(tmp_path):
    path = tmp_path / "bomb.nii.gz"
    compressor = zlib.compressobj(9, zlib.DEFLATED, 31)
    path.write_bytes(compressor.compress(nifti_bytes())
                     + b"".join(compressor.compress(bytes(2**20)) for _ in range(64))
                     + compressor.flush())
    refused(path, "dim", "decompress to more than the 864 bytes the header declares")


def test_nii_gz_extension_size_cannot_make_nibabel_inflate_the_stream(tmp_path):
    path = tmp_path / "extension.nii.gz"
    compressor = zlib.compressobj(9, zlib.DEFLATED, 31)
    path.write_bytes(compressor.compress(nifti_bytes(extension_size=2**31 - 16))
                     + b"".join(compressor.compress(bytes(2**20)) for _ in range(64))
                     + compressor.flush())
    refused(path, "header", "extension")


def test_nifti_data_offset_beyond_any_header_is_refused(tmp_path):
    blob = bytearray(nifti_bytes())
    blob[108:112] = struct.pack("<f", 1e30)
    (tmp_path / "far.nii").write_bytes(bytes(blob))
    refused(tmp_path / "far.nii", "vox_offset", "beyond the")


def npz_with_member(name: str, header_shape, content: bytes, method=zipfile.ZIP_DEFLATED) -> bytes:
    npy = io.BytesIO()
    np.lib.format.write_array_header_1_0(npy, {"descr": "|u1", "fortran_order": False,
                                               "shape": header_shape})
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=method) as archive, \
            archive.open(name, "w", force_zip64=True) as member:
        member.write(npy.getvalue())
        for start in range(0, len(content), 2**20):
            member.write(content[start:start + 2**20])
    return buffer.getvalue()


def test_npz_member_larger_than_its_npy_header_is_refused(tmp_path):
    path = tmp_path / "bomb.npz"
    path.write_bytes(npz_with_member("data.npy", (8, 8, 8), bytes(BOMB_BYTES)))
    refused(path, "data", "the member holds 67108864 data bytes but its header declares 512")


def test_npz_bzip2_member_is_refused_before_inflating(tmp_path):
    path = tmp_path / "bz.npz"
    path.write_bytes(npz_with_member("data.npy", (8, 8, 8), bytes(512), zipfile.ZIP_BZIP2))
    refused(path, "data", "compression method 12 is not supported")


def test_npy_header_length_cannot_make_numpy_reserve_gigabytes(tmp_path):
    path = tmp_path / "h.npy"  # a version 2 header claiming to be 4 GiB long
    path.write_bytes(b"\x93NUMPY\x02\x00" + struct.pack("<I", 2**32 - 16) + b"{}" + bytes(100))
    refused(path, "header", "not a readable .npy header")


def test_deflated_dicom_inflating_past_the_limit_is_refused(tmp_path, monkeypatch):
    import pydicom
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import DeflatedExplicitVRLittleEndian
    monkeypatch.setattr("vgraph.io.dicom_series.MAX_DEFLATED_BYTES", 2**20)
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID = "1.2.3", "1.2.3.4"
    meta.TransferSyntaxUID = DeflatedExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta, ds.Rows, ds.Columns, ds.BitsAllocated = meta, 2, 2, 8
    ds.PixelData = bytes(BOMB_BYTES // 8)  # 8 MiB, deflated to a few kilobytes
    path = tmp_path / "bomb.dcm"
    ds.save_as(path, enforce_file_format=True)
    assert path.stat().st_size < 2**20
    refused(path, "TransferSyntaxUID", "deflated data set decompress to more than 1048576")
    assert pydicom.dcmread(path).Rows == 2  # a valid file: only the limit refuses it


# --- counts checked before lists are built --------------------------------------------------------
@pytest.mark.parametrize("sizes, data_file, words", [
    ("8 8 8", "q.%d 1 1000000000 1", ["names 1000000000 data files", "need 8 files"]),
    ("1 1 1000000", "q.%d 1 1000000 1", ["names 1000000 data files; at most 65536"]),
    ("8 8 8", "q.%.1000000000d 1 8 1", ["must hold one integer conversion"]),
    ("8 8 8", "LIST\n" + "q\n" * 9, ["names 9 data files", "need 8 files"]),
])
def test_nrrd_data_files_are_counted_before_they_are_listed(tmp_path, sizes, data_file, words):
    path = tmp_path / "q.nhdr"
    path.write_text(f"NRRD0004\ntype: uchar\ndimension: 3\nsizes: {sizes}\nencoding: raw\n"
                    f"data file: {data_file}\n")
    refused(path, "data file", *words)


# --- headers are headers --------------------------------------------------------------------------
@pytest.mark.parametrize("name, start, field", [
    ("big.dat", b"ObjectFileName: x.raw\n", "header"),
    ("big.nhdr", b"NRRD0004\n", "header"),
    ("big.mhd", b"NDims = 3\n", "header"),
])
def test_a_header_without_end_is_refused_after_a_few_megabytes(tmp_path, name, start, field):
    path = tmp_path / name
    with open(path, "wb") as fh:  # 64 MiB, sparse: one endless line of NUL bytes
        fh.write(start)
        fh.truncate(BOMB_BYTES)
    refused(path, field, "header")


# --- the memory check knows the address-space limit -----------------------------------------------
def test_available_memory_counts_the_address_space_limit(tmp_path, monkeypatch):
    with open("/proc/self/status") as status:
        used = next(int(l.split()[1]) * 1024 for l in status if l.startswith("VmSize:"))
    monkeypatch.setattr(resource, "getrlimit", lambda which: (used + 10**6, resource.RLIM_INFINITY)
                        if which == resource.RLIMIT_AS else (resource.RLIM_INFINITY,) * 2)
    assert memory.available_memory() <= 10**6
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(2 * 10**6))
    refused(path, "dims", "too large for memory", raw={"dims": (1000, 1000, 2), "dtype": "uint8"})


def test_a_dicom_element_longer_than_its_file_reserves_nothing(tmp_path):
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID = "1.2.3", "1.2.3.4"
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta, ds.Rows, ds.Columns, ds.BitsAllocated = meta, 2, 2, 8
    ds.add_new(0x00291010, "OB", b"12345678")  # a private element after Rows and Columns
    ds.PixelData = bytes(4)
    path = tmp_path / "long.dcm"
    ds.save_as(path, enforce_file_format=True)
    blob = path.read_bytes()
    at = blob.index(b"\x29\x00\x10\x10OB\x00\x00") + 8  # its 4-byte length: claim ~4 GiB
    path.write_bytes(blob[:at] + struct.pack("<I", 2**32 - 16) + blob[at + 4:])
    refused(path, "PixelData", "cannot decode pixel data")
