"""Valid volume files built from scratch with random parameters, the starting points of the
fuzzing in tests/test_fuzz.py and bench/fuzz.py (fuzz_cases.py mutates them).

Each builder takes a ``random.Random`` (hypothesis's ``st.randoms()`` in the tests, a seeded one
in the bench, so a case is reproducible from its seed) and returns a ``Case``: the files to write
into an empty folder, the file to open, and for headerless raw data the description. Volumes are
tiny (at most 5 voxels per axis) so that a case costs milliseconds.
"""

from __future__ import annotations

import base64
import bz2
import gzip
import io
import lzma
import zlib
from dataclasses import dataclass, field

import numpy as np

DTYPES = ("uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64")


@dataclass
class Case:
    target: str
    files: dict[str, bytes]            # relative name ('/'-separated, folders made) -> content
    entry: str                         # the file to open; "" opens the folder (DICOM)
    raw: dict | None = None            # the description for read_volume(path, raw=...)
    header: str | None = None          # the text header among the files, for line edits
    gzipped: set[str] = field(default_factory=set)  # files whose content is one gzip member
    links: dict[str, str] = field(default_factory=dict)  # relative name -> symbolic link target
    fifos: set[str] = field(default_factory=set)         # relative names made FIFOs


def volume_values(rng, dtype: str | None = None) -> np.ndarray:
    """A small [z, y, x] array; floats sometimes hold NaN, Inf or values beyond float32."""
    dtype = np.dtype(dtype or rng.choice(DTYPES))
    shape = tuple(rng.choice((1, 2, 3, 5)) for _ in range(3))
    numbers = np.random.default_rng(rng.getrandbits(32))
    if dtype.kind == "f":
        values = numbers.normal(0, 100, size=shape)
        if rng.random() < 0.3:
            values.flat[0] = rng.choice((np.nan, np.inf, -np.inf, 1e300 if dtype.itemsize == 8 else 3e38))
        return values.astype(dtype)
    info = np.iinfo(dtype)
    return numbers.integers(info.min, info.max, size=shape, endpoint=True, dtype=dtype)


def _order(rng) -> str:
    return rng.choice("<>")


# --- text-header formats -------------------------------------------------------------------------
def qvis(rng) -> Case:
    words = {"uint8": "UCHAR", "int8": "CHAR", "uint16": rng.choice(("USHORT", "USHORT_12")),
             "int16": "SHORT", "uint32": "UINT", "int32": "INT", "float32": "FLOAT",
             "float64": "DOUBLE"}
    values = volume_values(rng)
    order = _order(rng)
    lines = ["ObjectFileName: v.raw", "TaggedFileName: ---",
             "Resolution: {} {} {}".format(*values.shape[::-1]),
             f"SliceThickness: {rng.uniform(0.1, 3):.3f} 1 {rng.uniform(0.1, 3):.3f}",
             f"Format: {words[values.dtype.name]}", "ObjectModel: I"]
    if order == ">" or rng.random() < 0.3:
        lines.append(f"Endianness: {'BIG' if order == '>' else 'LITTLE'}")
    rng.shuffle(lines)
    raw = values.astype(values.dtype.newbyteorder(order)).tobytes()
    return Case("qvis", {"v.dat": "\n".join(lines).encode() + b"\n", "v.raw": raw}, "v.dat",
                header="v.dat")


def raw(rng) -> Case:
    values = volume_values(rng)
    order = _order(rng)
    dims = values.shape[::-1]
    data = values.astype(values.dtype.newbyteorder(order)).tobytes()
    if rng.random() < 0.3:  # described by its name alone
        name = "v_{}x{}x{}_{}.raw".format(*dims, values.dtype.name)
        return Case("raw", {name: values.astype("<" + values.dtype.str[1:]).tobytes()}, name)
    description = {"dims": dims, "dtype": values.dtype.name,
                   "endianness": "big" if order == ">" else "little"}
    if rng.random() < 0.5:
        description["spacing"] = (rng.uniform(0.1, 2), 1.0, 2.0)
        description["origin"] = (rng.uniform(-10, 10), 0.0, 1.0)
    if rng.random() < 0.4:  # a header to skip: 7 bytes, or unknown (-1: the data are at the end)
        description["offset"] = rng.choice((0, 7, -1))
        data = {0: b"", 7: b"header:", -1: b"any"}[description["offset"]] + data
    return Case("raw", {"v.bin": data}, "v.bin", raw=description)


_NRRD_TYPES = {"uint8": "uchar", "int8": "signed char", "uint16": "ushort", "int16": "short",
               "uint32": "uint", "int32": "int", "float32": "float", "float64": "double"}


def _nrrd_lines(rng, values: np.ndarray, order: str, encoding: str) -> list[str]:
    lines = [f"type: {_NRRD_TYPES[values.dtype.name]}", "dimension: 3",
             "sizes: {} {} {}".format(*values.shape[::-1]), f"encoding: {encoding}"]
    if values.itemsize > 1:
        lines.append(f"endian: {'big' if order == '>' else 'little'}")
    if rng.random() < 0.5:
        lines.append(f"spacings: {rng.uniform(0.1, 3):.4g} 1 2")
    else:
        lines += ["space dimension: 3", f"space directions: ({rng.uniform(0.1, 3):.4g},0,0) "
                  "(0,1,0) (0,0,2)", f"space origin: ({rng.uniform(-5, 5):.4g},0,1)"]
    if rng.random() < 0.2:
        lines += ["min: 0", "max: 100"]
    rng.shuffle(lines)
    return ["NRRD0004", "# written by the vgraph fuzzer"] + lines


def _nrrd_payload(rng, values: np.ndarray, order: str, encoding: str) -> bytes:
    if encoding == "ascii":
        return (" ".join(repr(v.item()) for v in values.ravel()) + "\n").encode()
    data = values.astype(values.dtype.newbyteorder(order)).tobytes()
    if encoding == "gzip":
        return gzip.compress(data, mtime=0)
    return bz2.compress(data) if encoding == "bzip2" else data


def nrrd(rng) -> Case:
    values = volume_values(rng)
    order, encoding = _order(rng), rng.choice(("raw", "gzip", "bzip2", "ascii"))
    lines = _nrrd_lines(rng, values, order, encoding)
    payload = _nrrd_payload(rng, values, order, encoding)
    if encoding != "ascii" and rng.random() < 0.3:
        lines.append("line skip: 1")
        payload = b"a skipped line\n" + payload
    text = ("\n".join(lines) + "\n\n").encode()
    return Case("nrrd", {"v.nrrd": text + payload}, "v.nrrd", header="v.nrrd")


def nhdr(rng) -> Case:
    values = volume_values(rng)
    order, encoding = _order(rng), rng.choice(("raw", "gzip", "raw", "ascii"))
    lines = _nrrd_lines(rng, values, order, encoding)
    layout = rng.choice(("one", "pattern", "list"))
    suffix = ".gz" if encoding == "gzip" else ".raw"
    files = {}
    if layout == "one":
        files["v" + suffix] = _nrrd_payload(rng, values, order, encoding)
        lines.append(f"data file: v{suffix}")
    else:
        names = [f"s{k:03d}{suffix}" for k in range(values.shape[0])]
        for name, plane in zip(names, values):
            files[name] = _nrrd_payload(rng, plane, order, encoding)
        lines.append(f"data file: s%03d{suffix} 0 {len(names) - 1} 1 2" if layout == "pattern"
                     else "data file: LIST 2\n" + "\n".join(names))
    files["v.nhdr"] = ("\n".join(lines) + "\n").encode()
    return Case("nhdr", files, "v.nhdr", header="v.nhdr",
                gzipped={n for n in files if n.endswith(".gz")})


_MET_TYPES = {"uint8": "MET_UCHAR", "int8": "MET_CHAR", "uint16": "MET_USHORT",
              "int16": "MET_SHORT", "uint32": "MET_UINT", "int32": "MET_INT",
              "float32": "MET_FLOAT", "float64": "MET_DOUBLE"}


def metaimage(rng) -> Case:
    values = volume_values(rng)
    order = _order(rng)
    data = values.astype(values.dtype.newbyteorder(order)).tobytes()
    compressed = rng.random() < 0.4
    if compressed:
        data = zlib.compress(data)
    local = rng.random() < 0.5
    lines = ["ObjectType = Image", "NDims = 3", "DimSize = {} {} {}".format(*values.shape[::-1]),
             f"ElementType = {_MET_TYPES[values.dtype.name]}",
             f"ElementSpacing = {rng.uniform(0.1, 3):.4g} 1 2", "Offset = 0 -1 2.5",
             f"ElementByteOrderMSB = {order == '>'}", f"CompressedData = {compressed}"]
    if compressed:
        lines.append(f"CompressedDataSize = {len(data)}")
    rng.shuffle(lines)
    lines.append(f"ElementDataFile = {'LOCAL' if local else 'v.raw'}")
    header = ("\n".join(lines) + "\n").encode()
    if local:
        return Case("metaimage", {"v.mha": header + data}, "v.mha", header="v.mha")
    return Case("metaimage", {"v.mhd": header, "v.raw": data}, "v.mhd", header="v.mhd")


def slc(rng) -> Case:
    values = volume_values(rng, "uint8")
    z, y, x = values.shape
    compressed = rng.random() < 0.6
    out = [f"11111\n{x} {y} {z} 8\n1.0 {rng.uniform(0.1, 3):.3f} 1.0\n0 0 0 {int(compressed)}\n"
           f"2 1 X".encode(), bytes(6)]
    for plane in values:
        data = _run_length(plane.tobytes()) if compressed else plane.tobytes()
        out.append(f"\n{len(data)} X".encode() + data)
    return Case("slc", {"v.slc": b"".join(out)}, "v.slc", header="v.slc")


def _run_length(data: bytes) -> bytes:
    """SLC run-length code: literal runs of up to 127 bytes, a zero byte at the end."""
    out = bytearray()
    for start in range(0, len(data), 127):
        chunk = data[start:start + 127]
        out += bytes([0x80 | len(chunk)]) + chunk
    return bytes(out + b"\x00")


# --- XML -----------------------------------------------------------------------------------------
_VTK_TYPES = {"uint8": "UInt8", "int8": "Int8", "uint16": "UInt16", "int16": "Int16",
              "uint32": "UInt32", "int32": "Int32", "float32": "Float32", "float64": "Float64"}


def vti(rng) -> Case:
    values = volume_values(rng)
    order, fmt = _order(rng), rng.choice(("ascii", "binary", "appended"))
    compressor = rng.choice((None, "vtkZLibDataCompressor", "vtkLZMADataCompressor"))
    header_type = rng.choice(("UInt32", "UInt64"))
    header_dtype = np.dtype(order + ("u8" if header_type == "UInt64" else "u4"))
    data = values.astype(values.dtype.newbyteorder(order)).tobytes()
    head, body = _vtk_blocks(rng, data, header_dtype, compressor) if fmt != "ascii" else (b"", b"")
    appended = b""
    if fmt == "ascii":
        text = " ".join(repr(v.item()) for v in values.ravel())
        array = f'<DataArray type="{_VTK_TYPES[values.dtype.name]}" Name="s" format="ascii">{text}</DataArray>'
    elif fmt == "binary":
        text = _vtk_base64(head, body, compressor)
        array = f'<DataArray type="{_VTK_TYPES[values.dtype.name]}" Name="s" format="binary">{text}</DataArray>'
    else:
        array = f'<DataArray type="{_VTK_TYPES[values.dtype.name]}" Name="s" format="appended" offset="0"/>'
        encoded = rng.random() < 0.5
        payload = _vtk_base64(head, body, compressor).encode() if encoded else head + body
        appended = (f'<AppendedData encoding="{"base64" if encoded else "raw"}">\n_'.encode()
                    + payload + b"\n</AppendedData>\n")
    extent = "0 {} 0 {} 0 {}".format(*(n - 1 for n in values.shape[::-1]))
    attributes = f' compressor="{compressor}"' if compressor else ""
    xml = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order='
           f'"{"BigEndian" if order == ">" else "LittleEndian"}" header_type="{header_type}"'
           f'{attributes}>\n<ImageData WholeExtent="{extent}" Origin="0 1 2" Spacing="1 0.5 2">\n'
           f'<Piece Extent="{extent}">\n<PointData Scalars="s">\n{array}\n</PointData>\n</Piece>\n'
           f'</ImageData>\n').encode()
    return Case("vti", {"v.vti": xml + appended + b"</VTKFile>\n"}, "v.vti", header="v.vti")


def _vtk_blocks(rng, data: bytes, header_dtype: np.dtype, compressor) -> tuple[bytes, bytes]:
    if compressor is None:
        return np.array([len(data)], header_dtype).tobytes(), data
    compress = zlib.compress if compressor == "vtkZLibDataCompressor" else lzma.compress
    block = rng.choice((8, 32, 1 << 15))
    pieces = [compress(data[i:i + block]) for i in range(0, len(data), block)]
    last = len(data) - (len(pieces) - 1) * block
    head = np.array([len(pieces), block, last, *map(len, pieces)], header_dtype).tobytes()
    return head, b"".join(pieces)


def _vtk_base64(head: bytes, body: bytes, compressor) -> str:
    if compressor is None:  # VTK encodes the count and the data as one string
        return base64.b64encode(head + body).decode()
    return base64.b64encode(head).decode() + base64.b64encode(body).decode()


# --- binary formats ------------------------------------------------------------------------------
def npy(rng) -> Case:
    values = volume_values(rng)
    if rng.random() < 0.3:
        values = np.asfortranarray(values)
    if rng.random() < 0.3:
        values = values.astype(values.dtype.newbyteorder(">"))
    buffer = io.BytesIO()
    np.save(buffer, values[0] if rng.random() < 0.2 else values)
    return Case("npy", {"v.npy": buffer.getvalue()}, "v.npy")


def npz(rng) -> Case:
    values = volume_values(rng)
    buffer = io.BytesIO()
    save = np.savez_compressed if rng.random() < 0.6 else np.savez
    if rng.random() < 0.3:
        save(buffer, values)
    else:
        extra = {"value_range": np.array([-1.0, 200.0])} if rng.random() < 0.3 else {}
        save(buffer, data=values, spacing=np.array([1.0, 0.5, 2.0]), origin=np.zeros(3), **extra)
    return Case("npz", {"v.npz": buffer.getvalue()}, "v.npz")


def nifti(rng) -> Case:
    import nibabel as nib
    values = volume_values(rng)
    if values.dtype == np.int8:  # NIfTI-1 has int8, but nibabel's default image refuses it
        values = values.astype(np.int16)
    klass = nib.Nifti1Image if rng.random() < 0.7 else nib.Nifti2Image
    header = klass.header_class(endianness=_order(rng))
    header.set_data_dtype(values.dtype)
    image = klass(values.T, np.diag([rng.uniform(0.1, 3), 1, 2, 1]), header=header)
    if rng.random() < 0.3:
        image.header.set_slope_inter(rng.choice((2.0, 0.5, 1e30)), rng.choice((0.0, -1024.0)))
    blob = image.to_bytes()
    if rng.random() < 0.5:
        return Case("nifti", {"v.nii": blob}, "v.nii")
    return Case("nifti", {"v.nii.gz": gzip.compress(blob, mtime=0)}, "v.nii.gz",
                gzipped={"v.nii.gz"})
