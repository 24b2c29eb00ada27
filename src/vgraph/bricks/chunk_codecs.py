"""How many bytes a compressed chunk file will decode to, known before it is decoded (and, for
blosc, whether the file is whole).

zarr compares a decoded chunk with the chunk's shape only after decoding it, and its codecs
allocate what the compressed bytes ask for: a 32 KiB zstd chunk of an 8^3 uint8 array decoded
to 1 GiB (2.1 GB peak) before it was refused. The codecs that can expand without bound declare
or reveal their decoded size cheaply, so a chunk that would decode to more than its chunk holds is
refused before any codec runs:

- zstd: the frame header's content size (numcodecs allocates exactly that and fails beyond it);
  a frame without one (numcodecs then decodes into a growing buffer) is bounded by walking its
  block headers: a raw or RLE block says what it regenerates, a compressed one regenerates at most
  128 KiB and at most the window. That bound counts every compressed block as full, so it is
  refused only beyond ``UNDECLARED_SLACK`` times the chunk and one block: an encoder would have to
  flush every 16 KiB to reach it with honest data, a bomb (thousands of blocks of a few bytes
  each) passes it at once;
- blosc: the header's ``nbytes`` (what blosc allocates), and its ``cbytes`` must be the file's
  size: blosc trusts it and reads past the end of a cut-short chunk (the fuzzer found a truncated
  chunk reading as different garbage each time);
- gzip and zlib: inflated in pieces with a cap, every member (Python's gzip reads them all).

Other codecs (lz4, bz2, ...) and sharded arrays are left to zarr's check after decoding; their
files are still bounded by CheckedStore's chunk-file limit.
"""

from __future__ import annotations

import zlib

ZSTD_MAGIC = 0xFD2FB528
ZSTD_SKIPPABLE = 0x184D2A50  # ..5F: skippable frames, no content
ZSTD_BLOCK_MAX = 128 * 1024
UNDECLARED_SLACK = 8
INFLATE_PIECE = 1 << 20
BLOSC_HEADER = 16  # version, flags, typesize, nbytes, blocksize, cbytes


def outer_codec(array) -> str | None:
    """The name of the codec that wrote ``array``'s chunk files when it is one checked here."""
    metadata = array.metadata
    if metadata.zarr_format == 2:
        compressor = metadata.compressor
        name = getattr(compressor, "codec_id", None) if compressor is not None else None
    else:
        last = metadata.codecs[-1] if metadata.codecs else None
        name = last.to_dict().get("name") if last is not None else None
        name = name.removeprefix("numcodecs.") if isinstance(name, str) else None
    return name if name in _DECODED_SIZE else None


def decoded_size_problem(codec: str, data: bytes, limit: int) -> str | None:
    """Why ``data`` (a chunk file written by ``codec``) cannot decode to at most ``limit`` bytes,
    or cannot be decoded safely at all; None when it can."""
    if codec == "blosc" and len(data) < BLOSC_HEADER:  # blosc reads a whole header regardless
        return (f"holds {len(data):,} bytes, less than the {BLOSC_HEADER}-byte blosc header: the "
                f"chunk is cut short or damaged")
    if codec == "blosc":
        stored = int.from_bytes(data[12:16], "little")
        if stored != len(data):
            return (f"holds {len(data):,} bytes but its blosc header says {stored:,}: the chunk is cut "
                    f"short or damaged")
    allowed = {"declares": limit, "inflates to": limit,
               "has blocks that regenerate up to": UNDECLARED_SLACK * limit + ZSTD_BLOCK_MAX}
    size, how = _DECODED_SIZE[codec](data, max(allowed.values()))
    if size is None or size <= allowed[how]:
        return None
    said = f"{size:,} decoded bytes" if how == "declares" else f"{size:,} bytes or more"
    return f"{how} {said} ({codec}), but a chunk holds {limit:,}: the chunk is damaged or hostile"


def _blosc(data: bytes, limit: int):
    return (int.from_bytes(data[4:8], "little") if len(data) >= BLOSC_HEADER else None), "declares"


def _inflate(data: bytes, limit: int):
    """(bytes the gzip members or zlib stream of ``data`` inflate to, counted until past
    ``limit``, "inflates to")."""
    total, rest = 0, data
    while rest and total <= limit:
        stream = zlib.decompressobj(wbits=47)  # 32 + 15: gzip or zlib header, found by itself
        try:
            piece = stream.decompress(rest, INFLATE_PIECE)
            total += len(piece)
            while stream.unconsumed_tail and total <= limit:
                total += len(stream.decompress(stream.unconsumed_tail, INFLATE_PIECE))
        except zlib.error:
            break  # damaged: the codec itself will say so
        rest = stream.unused_data if stream.eof else b""
    return total, "inflates to"


def _zstd(data: bytes, limit: int):
    """(the decoded size the first frame declares, "declares"), else (a bound from the block
    headers of the frames, counted until past ``limit``); (None, ...) when ``data`` is no zstd frame
    (the codec will refuse it)."""
    at, total = 0, 0
    while at + 4 <= len(data) and total <= limit:
        magic = int.from_bytes(data[at:at + 4], "little")
        if magic & 0xFFFFFFF0 == ZSTD_SKIPPABLE:
            at += 8 + int.from_bytes(data[at + 4:at + 8], "little")
            continue
        frame = _zstd_frame(data, at + 4) if magic == ZSTD_MAGIC else None
        if frame is None:
            break
        declared, window, checksum, at = frame
        if declared is not None and total == 0:
            return declared, "declares"  # numcodecs allocates this and stops beyond it
        regenerated, at = _zstd_blocks(data, at, declared or window, limit - total)
        total += regenerated
        at += 4 * checksum
    return (total or None), "has blocks that regenerate up to"


def _zstd_frame(data: bytes, at: int):
    """(declared content size or None, window size, content checksum flag, offset of the first
    block) of the frame header at ``at`` (just after the magic number); None when cut short."""
    if at >= len(data):
        return None
    descriptor = data[at]
    size_flag, single_segment = descriptor >> 6, (descriptor >> 5) & 1
    checksum, dictionary = (descriptor >> 2) & 1, descriptor & 3
    at += 1
    window = None
    if not single_segment:
        if at >= len(data):
            return None
        exponent, mantissa = data[at] >> 3, data[at] & 7
        base = 1 << (10 + exponent)
        window = base + base // 8 * mantissa
        at += 1
    at += (0, 1, 2, 4)[dictionary]
    width = (single_segment, 2, 4, 8)[size_flag]
    if at + width > len(data):
        return None
    declared = int.from_bytes(data[at:at + width], "little") + (256 if width == 2 else 0) if width else None
    return declared, window, checksum, at + width


def _zstd_blocks(data: bytes, at: int, window, budget: int) -> tuple[int, int]:
    """(an upper bound of what the blocks from ``at`` regenerate, the offset after the last)."""
    most = min(ZSTD_BLOCK_MAX, window or ZSTD_BLOCK_MAX)
    total = 0
    while at + 3 <= len(data) and total <= budget:
        header = int.from_bytes(data[at:at + 3], "little")
        last, kind, size = header & 1, (header >> 1) & 3, header >> 3
        total += size if kind in (0, 1) else most  # raw, RLE: exactly; compressed: at most
        at += 3 + (1 if kind == 1 else size)
        if last:
            break
    return total, at


_DECODED_SIZE = {"zstd": _zstd, "blosc": _blosc, "gzip": _inflate, "zlib": _inflate}
