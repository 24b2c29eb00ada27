"""VTK XML ImageData (.vti), single piece, one scalar point-data array.

Attributes read:
  VTKFile    byte_order (LittleEndian | BigEndian), header_type (UInt32 | UInt64),
             compressor (none, vtkZLibDataCompressor, vtkLZMADataCompressor)
  ImageData  WholeExtent, Origin, Spacing (Direction is ignored: file axis order is kept)
  PointData  Scalars = name of the array to load (else the first DataArray)
  DataArray  type (Int8 ... Float64), NumberOfComponents (must be 1), format (ascii | binary |
             appended), offset
Binary data are base64 with the block header encoded separately from the data (what VTK
writes); appended data may be raw or base64. Compressed data: header = [number of blocks, block
size, last block size, compressed size of each block], then the zlib/LZMA blocks.
"""

from __future__ import annotations

import base64
import binascii
import lzma
import math
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_dims, check_memory, check_origin, check_spacing,
                               make_volume, parse_numbers, to_native)
from vgraph.volume import Volume

_TYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4",
          "UInt32": "u4", "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8"}
_DECOMPRESSORS = {None: None, "vtkZLibDataCompressor": zlib.decompress,
                  "vtkLZMADataCompressor": lzma.decompress}


def read_vti(path) -> Volume:
    path = Path(path)
    try:
        blob = path.read_bytes()
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read file: {exc.strerror}") from exc
    xml_text, appended = _split_appended(blob)
    try:
        root = ET.fromstring(xml_text)
    except ET.ParseError as exc:
        raise VolumeFileError(path, f"not valid XML: {exc}", "VTKFile") from exc
    if root.tag != "VTKFile" or root.get("type") != "ImageData":
        raise VolumeFileError(path, "not a VTK ImageData file", "VTKFile type")
    image = root.find("ImageData")
    pieces = image.findall("Piece") if image is not None else []
    if len(pieces) != 1:
        raise VolumeFileError(path, f"expected one Piece, found {len(pieces)}", "Piece")
    extent = parse_numbers(image.get("WholeExtent", ""), path, "WholeExtent", 6, int)
    dims = check_dims([extent[1] - extent[0] + 1, extent[3] - extent[2] + 1,
                       extent[5] - extent[4] + 1], path, "WholeExtent")
    spacing = check_spacing(parse_numbers(image.get("Spacing", "1 1 1"), path, "Spacing"), path,
                            "Spacing")
    origin = check_origin(parse_numbers(image.get("Origin", "0 0 0"), path, "Origin"), path,
                          "Origin")
    array = _scalar_array(pieces[0], path)
    dtype = _dtype(root, array, path)
    count = dims[0] * dims[1] * dims[2]
    check_memory(path, 2 * count * dtype.itemsize, "WholeExtent")
    raw = _array_bytes(root, array, appended, path)
    if len(raw) != count * dtype.itemsize:
        raise VolumeFileError(path, f"array {array.get('Name')!r} holds {len(raw)} bytes, "
                                    f"expected {count * dtype.itemsize} for extent {extent}",
                              "DataArray")
    flat = to_native(np.frombuffer(raw, dtype=dtype).copy())
    return make_volume(flat.reshape(dims[::-1]), path, spacing=spacing, origin=origin)


def _split_appended(blob: bytes) -> tuple[bytes, bytes | None]:
    """Appended raw data are not XML: cut them out (the part after '_' up to the closing tag)."""
    start = blob.find(b"<AppendedData")
    if start < 0:
        return blob, None
    underscore = blob.index(b"_", blob.index(b">", start)) + 1
    end = blob.rfind(b"</AppendedData>")
    return blob[:blob.index(b">", start) + 1] + blob[end:], blob[underscore:end]


def _scalar_array(piece, path: Path):
    point_data = piece.find("PointData")
    arrays = point_data.findall("DataArray") if point_data is not None else []
    if not arrays:
        raise VolumeFileError(path, "no point-data array", "PointData")
    name = point_data.get("Scalars")
    array = next((a for a in arrays if a.get("Name") == name), arrays[0])
    if int(array.get("NumberOfComponents", "1")) != 1:
        raise VolumeFileError(path, f"array {array.get('Name')!r} has "
                                    f"{array.get('NumberOfComponents')} components; only scalars "
                                    f"are supported", "NumberOfComponents")
    return array


def _dtype(root, array, path: Path) -> np.dtype:
    name = array.get("type")
    if name not in _TYPES:
        raise VolumeFileError(path, f"unsupported DataArray type {name!r}", "type")
    order = ">" if root.get("byte_order") == "BigEndian" else "<"
    return np.dtype(order + _TYPES[name])


def _array_bytes(root, array, appended: bytes | None, path: Path) -> bytes:
    fmt = array.get("format", "ascii")
    if fmt == "ascii":
        dtype = _dtype(root, array, path)
        return np.array((array.text or "").split(), dtype=dtype).tobytes()
    header_dtype = np.dtype(("<" if root.get("byte_order") != "BigEndian" else ">")
                            + ("u8" if root.get("header_type") == "UInt64" else "u4"))
    compressor = root.get("compressor")
    if compressor not in _DECOMPRESSORS:
        raise VolumeFileError(path, f"unsupported compressor {compressor!r}", "compressor")
    if fmt == "binary":
        stream = _Base64Stream((array.text or "").strip().encode(), path)
    elif fmt == "appended" and appended is not None:
        encoding = root.find("AppendedData")
        encoded = encoding is not None and encoding.get("encoding") == "base64"
        offset = int(array.get("offset", "0"))
        stream = _Base64Stream(appended[offset:].strip(), path) if encoded \
            else _RawStream(appended[offset:], path)
    else:
        raise VolumeFileError(path, f"unsupported DataArray format {fmt!r}", "format")
    try:
        return _decode(stream, header_dtype, _DECOMPRESSORS[compressor])
    except (zlib.error, lzma.LZMAError, binascii.Error, ValueError) as exc:
        raise VolumeFileError(path, f"cannot decode array data: {exc}", "DataArray") from exc


def _decode(stream, header_dtype: np.dtype, decompress) -> bytes:
    size = header_dtype.itemsize
    if decompress is None:  # one stream: [byte count][data]
        return stream.read_joint(size, header_dtype)
    first = np.frombuffer(stream.peek_header(3 * size), header_dtype)
    blocks = int(first[0])
    header = np.frombuffer(stream.read_header((3 + blocks) * size), header_dtype)
    data = stream.read_data(int(header[3:].sum()))
    out, pos = [], 0
    for compressed in header[3:]:
        out.append(decompress(data[pos:pos + int(compressed)]))
        pos += int(compressed)
    return b"".join(out)


class _Base64Stream:
    """Compressed data: VTK encodes the block header and the blocks as two separate base64
    strings, back to back. Uncompressed data: the byte count and the data are one string."""

    def __init__(self, text: bytes, path: Path):
        self.text, self.header_chars = b"".join(text.split()), 0

    def peek_header(self, nbytes: int) -> bytes:
        return base64.b64decode(self.text[:4 * math.ceil(nbytes / 3)])[:nbytes]

    def read_header(self, nbytes: int) -> bytes:
        self.header_chars = 4 * math.ceil(nbytes / 3)
        return base64.b64decode(self.text[:self.header_chars])[:nbytes]

    def read_data(self, nbytes: int) -> bytes:
        chars = self.text[self.header_chars:self.header_chars + 4 * math.ceil(nbytes / 3)]
        return base64.b64decode(chars)[:nbytes]

    def read_joint(self, size: int, header_dtype: np.dtype) -> bytes:
        head = base64.b64decode(self.text[:4 * math.ceil(size / 3)])[:size]
        nbytes = int(np.frombuffer(head, header_dtype)[0])
        decoded = base64.b64decode(self.text[:4 * math.ceil((size + nbytes) / 3)])
        return decoded[size:size + nbytes]


class _RawStream:
    def __init__(self, blob: bytes, path: Path):
        self.blob, self.pos = blob, 0

    def peek_header(self, nbytes: int) -> bytes:
        return self.blob[:nbytes]

    def read_header(self, nbytes: int) -> bytes:
        self.pos = nbytes
        return self.blob[:nbytes]

    def read_data(self, nbytes: int) -> bytes:
        return self.blob[self.pos:self.pos + nbytes]

    def read_joint(self, size: int, header_dtype: np.dtype) -> bytes:
        nbytes = int(np.frombuffer(self.blob[:size], header_dtype)[0])
        return self.blob[size:size + nbytes]
