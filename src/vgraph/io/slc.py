"""VolVis SLC volumes (.slc), e.g. VTK's neghip.slc.

Layout: text lines
  magic 11111
  x y z bits        voxel counts and bits per voxel (only 8 is defined)
  sx sy sz          spacing
  unit origin modality compression   compression 1 = run-length encoded, 0 = none
  ix iy X           icon size, followed by 3 * ix * iy icon bytes (skipped)
then per slice ``<n> X`` and n bytes of slice data (x fastest). Run-length code: a byte c with
count = c & 0x7f (0 ends the slice); if c & 0x80 the next ``count`` bytes are literal, otherwise
the next byte is repeated ``count`` times. Slices are stored in z order, so the array is [z, y, x].
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import check_dims, check_spacing, make_volume, regular_file
from vgraph.memory import check_memory
from vgraph.volume import Volume

_NUMBER = re.compile(rb"\s*([-+0-9.eE]+)")


class _Cursor:
    """Reads whitespace-separated numbers and the literal 'X' out of a bytes buffer."""

    def __init__(self, blob: bytes, path: Path):
        self.blob, self.pos, self.path = blob, 0, path

    def number(self, kind, field: str):
        match = _NUMBER.match(self.blob, self.pos)
        if match is None:
            raise VolumeFileError(self.path, f"expected a number at byte {self.pos}", field)
        self.pos = match.end()
        try:
            return kind(match.group(1))
        except ValueError:
            raise VolumeFileError(self.path, f"bad number {match.group(1)!r}", field) from None

    def marker(self, field: str) -> None:
        while self.pos < len(self.blob) and self.blob[self.pos:self.pos + 1].isspace():
            self.pos += 1
        if self.blob[self.pos:self.pos + 1] != b"X":
            raise VolumeFileError(self.path, f"expected 'X' at byte {self.pos}", field)
        self.pos += 1

    def take(self, n: int, field: str) -> bytes:
        if n < 0:
            raise VolumeFileError(self.path, f"a negative byte count {n} at byte {self.pos}", field)
        if self.pos + n > len(self.blob):
            raise VolumeFileError(self.path, f"file is truncated: needs {n} bytes at byte "
                                             f"{self.pos}, {len(self.blob) - self.pos} left", field)
        chunk = self.blob[self.pos:self.pos + n]
        self.pos += n
        return chunk


def read_slc(path) -> Volume:
    path = regular_file(path)
    check_memory(path, path.stat().st_size, "header")  # the file is read whole
    try:
        cursor = _Cursor(path.read_bytes(), path)
    except OSError as exc:
        raise VolumeFileError(path, f"cannot read file: {exc.strerror}", "header") from exc
    if cursor.number(int, "magic") != 11111:
        raise VolumeFileError(path, "not an SLC file (magic number 11111 missing)", "magic")
    dims = check_dims([cursor.number(int, "dimensions") for _ in range(3)], path, "dimensions")
    bits = cursor.number(int, "bits")
    if bits != 8:
        raise VolumeFileError(path, f"only 8-bit SLC data are supported, got {bits}", "bits")
    spacing = check_spacing([cursor.number(float, "spacing") for _ in range(3)], path, "spacing")
    _unit, _origin, _modality, compression = (cursor.number(int, "compression") for _ in range(4))
    if compression not in (0, 1):
        raise VolumeFileError(path, f"unknown compression {compression}", "compression")
    icon_x, icon_y = cursor.number(int, "icon"), cursor.number(int, "icon")
    cursor.marker("icon")
    cursor.take(3 * icon_x * icon_y, "icon")
    check_memory(path, dims[0] * dims[1] * dims[2], "dimensions")
    plane = dims[0] * dims[1]
    data = np.empty((dims[2], dims[1], dims[0]), dtype=np.uint8)
    for z in range(dims[2]):
        size = cursor.number(int, f"slice {z}")
        cursor.marker(f"slice {z}")
        payload = cursor.take(size, f"slice {z}")
        decoded = _run_length_decode(payload, plane, path, z) if compression else payload
        if len(decoded) != plane:
            raise VolumeFileError(path, f"slice {z} holds {len(decoded)} voxels, expected {plane}",
                                  f"slice {z}")
        data[z] = np.frombuffer(decoded, dtype=np.uint8).reshape(dims[1], dims[0])
    return make_volume(data, path, spacing=spacing)


def _run_length_decode(payload: bytes, expected: int, path: Path, z: int) -> bytes:
    out = bytearray()
    pos = 0
    while pos < len(payload):
        code = payload[pos]
        count = code & 0x7F
        pos += 1
        if count == 0:
            break
        if code & 0x80:
            out += payload[pos:pos + count]
            pos += count
        else:
            out += payload[pos:pos + 1] * count
            pos += 1
        if len(out) > expected:
            break
    return bytes(out)
