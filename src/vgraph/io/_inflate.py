"""Bounded decompression for the readers: gzip, bzip2, zlib, raw deflate and LZMA streams are
inflated piece by piece into a buffer of exactly the size the header declares, reporting how
far they are to a ``vgraph.progress`` listener (the GUI's status bar).

A few compressed bytes can stand for gigabytes (deflate reaches 1032:1, bzip2 millions to one),
so a reader must never inflate a whole stream and compare sizes afterwards. Here every call to
the decompressor asks for at most one byte more than is still missing: the data are refused as
soon as they exceed what the header declares, and refused if they end short of it. Memory is the
declared size (checked against the available memory by the caller beforehand) plus one input
chunk; time is bounded by the declared size too.
"""

from __future__ import annotations

import bz2
import lzma
import os
import sys
import zlib
from collections.abc import Iterable, Iterator
from pathlib import Path

from vgraph.errors import VolumeFileError
from vgraph.progress import report

INPUT_CHUNK_BYTES = 1 * 2**20

# method -> (new decompressor, magic bytes that start another member, or None: one stream only).
# gzip and bzip2 files may hold several members back to back (as gzip -d and bzip2 -d accept);
# what follows the last member is ignored, as pynrrd and gzip -d do.
_METHODS = {
    "gzip": (lambda: zlib.decompressobj(16 + zlib.MAX_WBITS), b"\x1f\x8b"),
    "bzip2": (bz2.BZ2Decompressor, b"BZh"),
    "zlib": (zlib.decompressobj, None),
    "deflate": (lambda: zlib.decompressobj(-zlib.MAX_WBITS), None),
    "lzma": (lzma.LZMADecompressor, None),
}
_ERRORS = (zlib.error, OSError, EOFError, lzma.LZMAError, ValueError)


class _TooLong(Exception):
    """The stream holds more than the limit (internal; turned into a VolumeFileError)."""


def inflate_into(target, pieces: Iterable[bytes], method: str, file, field: str, *, skip: int = 0,
                 what: str = "the data", codec_field: str | None = None,
                 partial: bool = False) -> None:
    """Fill ``target`` (a writable buffer, e.g. a uint8 array) with the stream ``pieces``
    decompress to, after discarding its first ``skip`` bytes; the stream must hold exactly
    ``skip + len(target)`` bytes. With ``partial`` it holds more (the later time points of a 4D
    file): inflating stops once ``target`` is full, so reading time point 0 of a long series
    costs one volume. Size errors name ``field`` (the header field declaring the size), a
    corrupt stream ``codec_field`` (default: the same)."""
    view = memoryview(target).cast("B")
    expected = skip + len(view)
    done = 0
    step = f"decompressing {Path(file).name}"  # for a progress listener (the GUI's status bar)
    try:
        for data in _inflated(pieces, method, expected, file, codec_field or field, what,
                              partial=partial):
            if done + len(data) > expected:
                if not partial:
                    raise _TooLong
                data = data[:expected - done]
            start = max(skip - done, 0)
            if start < len(data):
                view[done + start - skip:done + len(data) - skip] = data[start:]
            done += len(data)
            report(min(done, expected), expected, step)
            if partial and done >= expected:
                return
    except _TooLong:
        raise VolumeFileError(file, f"{what} decompress to more than the {expected} bytes the "
                                    f"header declares", field) from None
    if done < expected:
        raise VolumeFileError(file, f"{what} decompress to {done} bytes, fewer than the {expected} "
                                    f"bytes the header declares", field)


def inflated_prefix(pieces: Iterable[bytes], method: str, size: int, file, field: str,
                    what: str = "the header") -> bytes:
    """The first ``size`` bytes the stream decompresses to (fewer if it is shorter); the rest of
    the stream is not touched."""
    out = bytearray()
    for data in _inflated(pieces, method, size, file, field, what):
        out += data
        if len(out) >= size:
            break
    return bytes(out[:size])


def check_inflates_within(pieces: Iterable[bytes], method: str, limit: int, file, field: str,
                          what: str = "the data") -> None:
    """Refuse a stream that decompresses to more than ``limit`` bytes, before a library that
    inflates it whole in one call (pydicom with deflated DICOM) gets to it. Output is discarded."""
    try:
        for _ in _inflated(pieces, method, limit, file, field, what):
            pass
    except _TooLong:
        raise VolumeFileError(file, f"{what} decompress to more than {limit} bytes, the limit "
                                    f"for this kind of file", field) from None


def file_pieces(path, start: int, blame, field: str) -> Iterator[bytes]:
    """The bytes of ``path`` from ``start`` on, in chunks."""
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if start > size:  # a header offset beyond the file (seek would overflow past 2**63)
                raise VolumeFileError(blame, f"the data would start at byte {start}, after the "
                                             f"end of {str(path)!r} ({size} bytes)", field)
            fh.seek(start)
            while chunk := fh.read(INPUT_CHUNK_BYTES):
                yield chunk
    except OSError as exc:
        raise VolumeFileError(blame, f"cannot read {str(path)!r}: {exc.strerror}", field) from exc


def memory_pieces(blob) -> Iterator[bytes]:
    """A bytes object in chunks (slices of a memoryview: no copies)."""
    view = memoryview(blob)
    for start in range(0, len(view), INPUT_CHUNK_BYTES):
        yield view[start:start + INPUT_CHUNK_BYTES]


def _inflated(pieces, method: str, limit: int, file, field: str, what: str,
              partial: bool = False) -> Iterator[bytes]:
    """Decompressed output, piece by piece; raises _TooLong once it has passed ``limit`` bytes
    (with ``partial`` the caller stops reading at ``limit`` instead)."""
    new, magic = _METHODS[method]
    decompressor, ended, produced = new(), False, 0
    try:
        for data in pieces:
            data = bytes(data)
            while data:
                if ended:
                    if magic is None or data[:len(magic)] != magic[:len(data[:len(magic)])]:
                        return  # trailing bytes that start no new member
                    decompressor, ended = new(), False
                # a C ssize_t: a limit beyond it (a huge skip) cannot be reached anyway
                out = decompressor.decompress(data, min(limit - produced + 1, sys.maxsize))
                produced += len(out)
                if out:
                    yield out  # even the piece that passes the limit: a prefix reader wants it
                if produced > limit or (partial and produced >= limit):
                    if partial:  # never ask for more: max_length 0 would mean 'unlimited'
                        return
                    raise _TooLong
                ended = decompressor.eof
                data = decompressor.unused_data if ended else b""
    except _ERRORS as exc:
        raise VolumeFileError(file, f"cannot decompress {what} ({method}): {exc}", field) from exc
    if not ended:
        raise VolumeFileError(file, f"cannot decompress {what} ({method}): the compressed stream "
                                    f"is truncated", field)
