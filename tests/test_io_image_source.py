"""ImageSource's file reading (read_image_file, no GL needed): pixel-count limit from the header,
damaged files and files that are not regular files give a VGraphError naming the file."""

import io
import os
import struct
import tracemalloc
import zlib

import numpy as np
import PIL.Image
import pytest

from vgraph.errors import VGraphError
from vgraph.processors.image_source import MAX_PIXELS, read_image_file


def png_chunk(kind: bytes, data: bytes, length: int | None = None) -> bytes:
    crc = zlib.crc32(kind + data) & 0xFFFFFFFF
    return struct.pack(">I", len(data) if length is None else length) + kind + data \
        + struct.pack(">I", crc)


def png(width: int, height: int, idat: bytes = b"", idat_length: int | None = None) -> bytes:
    """An 8-bit grey PNG with the given size in its header and whatever image data."""
    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", header)
            + png_chunk(b"IDAT", idat, idat_length) + png_chunk(b"IEND", b""))


def read_with_peak(path):
    """The pixels or the VGraphError, and the peak of traced memory while reading."""
    tracemalloc.start()
    try:
        try:
            result = read_image_file("img", path.name, path)
        except VGraphError as error:
            result = error
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def error_of(path) -> VGraphError:
    error, peak = read_with_peak(path)
    assert isinstance(error, VGraphError), "no error"
    assert str(error).startswith(f"{path}: ") and "(img.path)" in str(error)
    assert peak < 16 * 2**20, f"peak {peak / 2**20:.0f} MiB"
    return error


@pytest.mark.parametrize("width, height", [(20000, 20000), (9000, 9000)])
def test_pictures_above_the_pixel_limit_are_refused_from_their_header(tmp_path, width, height):
    path = tmp_path / "big.png"
    path.write_bytes(png(width, height, zlib.compress(bytes(1000))))
    error = error_of(path)
    assert f"{width} x {height}" in str(error) or "exceeds limit" in str(error)
    assert "too large" in str(error)
    assert width * height > MAX_PIXELS


def test_a_chunk_length_beyond_the_file_costs_nothing(tmp_path):
    path = tmp_path / "chunk.png"
    path.write_bytes(png(4, 4, zlib.compress(bytes(20)), idat_length=2**31 - 16))
    result, peak = read_with_peak(path)  # PIL reads what is there; it must not reserve 2 GiB
    assert isinstance(result, (np.ndarray, VGraphError)) and peak < 16 * 2**20


def test_damaged_pictures_are_refused(tmp_path):
    noise = np.random.default_rng(1).integers(0, 255, (64, 64), dtype=np.uint8)
    buffer = io.BytesIO()
    PIL.Image.fromarray(noise).save(buffer, format="PNG")
    path = tmp_path / "cut.png"
    path.write_bytes(buffer.getvalue()[:2000])
    assert "not a readable PNG or JPEG" in str(error_of(path))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    assert "not a readable PNG or JPEG" in str(error_of(path))


@pytest.mark.parametrize("kind", ["a FIFO", "a directory", "a character device"])
def test_a_fifo_folder_or_device_is_refused_before_opening(tmp_path, kind):
    path = tmp_path / "p.png"
    {"a FIFO": os.mkfifo, "a directory": os.mkdir,
     "a character device": lambda p: os.symlink("/dev/zero", p)}[kind](path)
    assert f"is not a regular file ({kind})" in str(error_of(path))
