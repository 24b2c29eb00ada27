"""VTK XML ImageData (.vti), single piece, one scalar point-data array.

Attributes read:
  VTKFile    byte_order (LittleEndian | BigEndian), header_type (UInt32 | UInt64),
             compressor (none, vtkZLibDataCompressor, vtkLZMADataCompressor)
  ImageData  WholeExtent, Origin, Spacing, Direction (VTK 9: 9 numbers, the 3x3 matrix row by
             row, its columns the index axes' directions; default identity; refused by name
             when not a rotation, possibly mirrored)
  PointData  Scalars = name of the array to load (else the first DataArray)
  DataArray  type (Int8 ... Float64), NumberOfComponents (must be 1), format (ascii | binary |
             appended), offset
Binary data are base64 with the block header encoded separately from the data (what VTK
writes); appended data may be raw or base64. Compressed data: header = [number of blocks, block
size, last block size, compressed size of each block], then the zlib/LZMA blocks. The header's
sizes must add up to what WholeExtent needs before any block is inflated, and each block must
inflate to exactly its declared size (a few bytes of zlib can stand for gigabytes).

Frame: VTK has no patient frame; a .vti's world is taken as vgraph's (RAS) as it stands.

Writing: one Float/Int/UInt DataArray "values", zlib blocks appended raw (UInt64 headers), with
WholeExtent, Origin, Spacing and Direction; the value range is not kept (VTK has no field for it).
"""

from __future__ import annotations

import base64
import binascii
import math
import zlib
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from vgraph.byte_order import to_native
from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_dims, check_origin, check_spacing, make_volume, parse_numbers,
                               regular_file)
from vgraph.io._inflate import inflate_into, memory_pieces
from vgraph.io._values import ascii_values
from vgraph.io.label_hints import vti_says_labels
from vgraph.io.orientation import file_direction
from vgraph.memory import check_memory
from vgraph.volume import Volume

_TYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4",
          "UInt32": "u4", "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8"}
_COMPRESSORS = {None: None, "vtkZLibDataCompressor": "zlib", "vtkLZMADataCompressor": "lzma"}


def read_vti(path) -> Volume:
    path = regular_file(path)
    blob = _file_bytes(path)
    xml_text, appended = _split_appended(blob, path)
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
    direction = file_direction(np.array(parse_numbers(image.get("Direction", "1 0 0 0 1 0 0 0 1"),
                                                      path, "Direction", 9)).reshape(3, 3),
                               path, "Direction")
    array = _scalar_array(pieces[0], path)
    dtype = _dtype(root, array, path)
    count = dims[0] * dims[1] * dims[2]
    check_memory(path, count * dtype.itemsize, "WholeExtent")
    flat = _array_values(root, array, appended, dtype, count, path)
    return make_volume(flat.reshape(dims[::-1]), path, spacing=spacing, origin=origin,
                       direction=direction, holds_labels=vti_says_labels(image, array))


def _file_bytes(path: Path) -> bytes:
    check_memory(path, path.stat().st_size, "VTKFile")  # the XML is parsed from memory
    try:
        return path.read_bytes()
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read file: {exc.strerror}", "VTKFile") from exc


def _split_appended(blob: bytes, path: Path) -> tuple[bytes, bytes | None]:
    """Appended raw data are not XML: cut them out (the part after '_' up to the closing tag)."""
    start = blob.find(b"<AppendedData")
    if start < 0:
        return blob, None
    close = blob.find(b">", start)
    underscore = blob.find(b"_", close + 1) if close >= 0 else -1
    end = blob.rfind(b"</AppendedData>")
    if underscore < 0 or end < underscore:
        raise VolumeFileError(path, "no '_' before the data or no closing tag", "AppendedData")
    return blob[:close + 1] + blob[end:], blob[underscore + 1:end]


def _scalar_array(piece, path: Path):
    point_data = piece.find("PointData")
    arrays = point_data.findall("DataArray") if point_data is not None else []
    if not arrays:
        raise VolumeFileError(path, "no point-data array", "PointData")
    name = point_data.get("Scalars")
    array = next((a for a in arrays if a.get("Name") == name), arrays[0])
    components = _attribute_int(array, "NumberOfComponents", 1, path)
    if components != 1:
        raise VolumeFileError(path, f"array {array.get('Name')!r} has {components} components; "
                                    f"only scalars are supported", "NumberOfComponents")
    return array


def _attribute_int(element, name: str, default: int, path: Path) -> int:
    text = element.get(name)
    if text is None:
        return default
    try:
        value = int(text)
    except ValueError:
        raise VolumeFileError(path, f"expected an integer, got {text!r}", name) from None
    if value < 0:
        raise VolumeFileError(path, f"must not be negative, got {value}", name)
    return value


def _dtype(root, array, path: Path) -> np.dtype:
    name = array.get("type")
    if name not in _TYPES:
        raise VolumeFileError(path, f"unsupported DataArray type {name!r}", "type")
    order = ">" if root.get("byte_order") == "BigEndian" else "<"
    return np.dtype(order + _TYPES[name])


def _array_values(root, array, appended: bytes | None, dtype: np.dtype, count: int,
                  path: Path) -> np.ndarray:
    fmt = array.get("format", "ascii")
    if fmt == "ascii":
        return ascii_values([array.text or ""], dtype, count, path, "DataArray")
    compressor = root.get("compressor")
    if compressor not in _COMPRESSORS:
        raise VolumeFileError(path, f"unsupported compressor {compressor!r}", "compressor")
    header_dtype = np.dtype(("<" if root.get("byte_order") != "BigEndian" else ">")
                            + ("u8" if root.get("header_type") == "UInt64" else "u4"))
    stream = _stream(fmt, root, array, appended, path)
    out = np.empty(count, dtype=dtype)
    try:
        if _COMPRESSORS[compressor] is None:
            _read_plain(stream, header_dtype, out.view(np.uint8), path)
        else:
            _read_blocks(stream, header_dtype, _COMPRESSORS[compressor], out.view(np.uint8), path)
    except (binascii.Error, ValueError) as exc:  # bad base64
        raise VolumeFileError(path, f"cannot decode array data: {exc}", "DataArray") from exc
    return to_native(out, copy=False)


def _stream(fmt: str, root, array, appended: bytes | None, path: Path):
    if fmt == "binary":
        return _Base64Stream((array.text or "").strip().encode())
    if fmt == "appended" and appended is not None:
        encoding = root.find("AppendedData")
        encoded = encoding is not None and encoding.get("encoding") == "base64"
        offset = _attribute_int(array, "offset", 0, path)
        return _Base64Stream(appended[offset:].strip()) if encoded else _RawStream(appended[offset:])
    raise VolumeFileError(path, f"unsupported DataArray format {fmt!r}", "format")


def _read_plain(stream, header_dtype: np.dtype, target: np.ndarray, path: Path) -> None:
    """Uncompressed: [byte count][data]; the count must be what the extent needs."""
    head = np.frombuffer(stream.peek_header(header_dtype.itemsize), header_dtype)
    declared = int(head[0]) if len(head) else None
    if declared != len(target):
        raise VolumeFileError(path, f"the array declares {declared} bytes, the extent needs "
                                    f"{len(target)}", "DataArray")
    raw = stream.read_joint(header_dtype.itemsize, len(target))
    if len(raw) != len(target):
        raise VolumeFileError(path, f"the array holds {len(raw)} bytes, expected {len(target)}: "
                                    f"truncated", "DataArray")
    target[:] = np.frombuffer(raw, np.uint8)


def _read_blocks(stream, header_dtype: np.dtype, method: str, target: np.ndarray,
                 path: Path) -> None:
    """Compressed: [blocks, block size, last block size, compressed size of each block], then
    the blocks. The uncompressed sizes must add up to what the extent needs before anything is
    inflated, and each block must inflate to exactly its size."""
    size = header_dtype.itemsize
    first = [int(v) for v in np.frombuffer(stream.peek_header(3 * size), header_dtype)]
    if len(first) < 3:
        raise VolumeFileError(path, "the compression header is truncated", "DataArray")
    blocks, block_size, last_size = first
    sizes = _block_sizes(blocks, block_size, last_size, len(target), path)
    header = np.frombuffer(stream.read_header((3 + blocks) * size), header_dtype)
    compressed = [int(v) for v in header[3:]]
    if len(compressed) != blocks:
        raise VolumeFileError(path, "the compression header is truncated", "DataArray")
    data = stream.read_data(sum(compressed))
    if len(data) < sum(compressed):
        raise VolumeFileError(path, f"the compressed blocks hold {len(data)} bytes, the header "
                                    f"declares {sum(compressed)}: truncated", "DataArray")
    source = target_pos = 0
    for index, (packed, unpacked) in enumerate(zip(compressed, sizes)):
        inflate_into(target[target_pos:target_pos + unpacked],
                     memory_pieces(data[source:source + packed]), method, path, "DataArray",
                     what=f"block {index}", codec_field="compressor")
        source, target_pos = source + packed, target_pos + unpacked


def _block_sizes(blocks: int, block_size: int, last_size: int, needed: int, path: Path):
    """The uncompressed size of each block, checked against the bytes the extent needs."""
    if block_size <= 0 or blocks != math.ceil(needed / block_size):
        raise VolumeFileError(path, f"the compression header declares {blocks} blocks of "
                                    f"{block_size} bytes; the extent needs {needed} bytes",
                              "DataArray")
    last = needed - (blocks - 1) * block_size
    if last_size != last and not (last_size == 0 and last == block_size):
        raise VolumeFileError(path, f"the last block declares {last_size} bytes; the extent "
                                    f"leaves {last}", "DataArray")
    return [block_size] * (blocks - 1) + [last]


class _Base64Stream:
    """Compressed data: VTK encodes the block header and the blocks as two separate base64
    strings, back to back. Uncompressed data: the byte count and the data are one string."""

    def __init__(self, text: bytes):
        self.text, self.header_chars = b"".join(text.split()), 0

    def peek_header(self, nbytes: int) -> bytes:
        return base64.b64decode(self.text[:4 * math.ceil(nbytes / 3)])[:nbytes]

    def read_header(self, nbytes: int) -> bytes:
        self.header_chars = 4 * math.ceil(nbytes / 3)
        return base64.b64decode(self.text[:self.header_chars])[:nbytes]

    def read_data(self, nbytes: int) -> bytes:
        chars = self.text[self.header_chars:self.header_chars + 4 * math.ceil(nbytes / 3)]
        return base64.b64decode(chars)[:nbytes]

    def read_joint(self, size: int, nbytes: int) -> bytes:
        decoded = base64.b64decode(self.text[:4 * math.ceil((size + nbytes) / 3)])
        return decoded[size:size + nbytes]


class _RawStream:
    def __init__(self, blob: bytes):
        self.blob, self.pos = blob, 0

    def peek_header(self, nbytes: int) -> bytes:
        return self.blob[:nbytes]

    def read_header(self, nbytes: int) -> bytes:
        self.pos = nbytes
        return self.blob[:nbytes]

    def read_data(self, nbytes: int) -> bytes:
        return self.blob[self.pos:self.pos + nbytes]

    def read_joint(self, size: int, nbytes: int) -> bytes:
        return self.blob[size:size + nbytes]


# --- writing -------------------------------------------------------------------------------------
_TYPE_NAMES = {code: name for name, code in _TYPES.items()}
_BLOCK_BYTES = 2**20  # uncompressed bytes per zlib block (VTK's own default is 32 KiB)


def write_vti(volume: Volume, file: Path) -> None:
    """VTK XML ImageData that VTK 9 (and vgraph) read onto the same points (module docstring)."""
    flat = np.ascontiguousarray(volume.data).reshape(-1)
    little = flat.dtype.newbyteorder("<")
    blocks = []
    step = max(1, _BLOCK_BYTES // flat.dtype.itemsize)
    for start in range(0, flat.size, step):
        piece = np.ascontiguousarray(flat[start:start + step], dtype=little)  # no copy when native
        blocks.append(zlib.compress(memoryview(piece).cast("B"), 1))
    nbytes = flat.size * flat.dtype.itemsize
    last = nbytes - (len(blocks) - 1) * _BLOCK_BYTES
    # [blocks, block size, size of a partial last block (0: it is whole), compressed sizes]
    header = np.array([len(blocks), _BLOCK_BYTES, 0 if last == _BLOCK_BYTES else last,
                       *map(len, blocks)], dtype="<u8")
    with open(file, "wb") as fh:
        fh.write(_xml_head(volume, _TYPE_NAMES[little.str[1:]]).encode("ascii"))
        fh.write(header.tobytes())
        for block in blocks:
            fh.write(block)
        fh.write(b"\n  </AppendedData>\n</VTKFile>\n")


def _xml_head(volume: Volume, type_name: str) -> str:
    extent = " ".join(f"0 {n - 1}" for n in volume.dims)
    numbers = lambda values: " ".join(repr(float(v)) for v in values)  # noqa: E731
    return (f'<?xml version="1.0"?>\n'
            f'<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
            f'header_type="UInt64" compressor="vtkZLibDataCompressor">\n'
            f'  <ImageData WholeExtent="{extent}" Origin="{numbers(volume.origin)}" '
            f'Spacing="{numbers(volume.spacing)}" '
            f'Direction="{numbers(np.asarray(volume.direction).reshape(-1))}">\n'
            f'    <Piece Extent="{extent}">\n'
            f'      <PointData Scalars="values">\n'
            f'        <DataArray type="{type_name}" Name="values" format="appended" offset="0"/>\n'
            f'      </PointData>\n'
            f'    </Piece>\n'
            f'  </ImageData>\n'
            f'  <AppendedData encoding="raw">\n   _')
