"""The files of an OME-Zarr store on disk, read under the rule of every volume reader
(docs/guide/volumes.md): regular files only, sizes checked before reading (docs/guide/large-data.md).

``CheckedStore`` is zarr's LocalStore with its reads replaced; zarr opens metadata and chunks
through it, so every key zarr asks for is checked, whatever the array layout:
- a key is a path inside the store (no empty, '.' or '..' component);
- its file is opened without blocking (O_NONBLOCK: a FIFO does not wait for a writer) and the open
  descriptor must be a regular file. Symbolic links are followed, as for every volume file, and
  judged by what they lead to: /dev/zero, a FIFO or a folder is refused, a loop cannot be opened;
- its size must be within the limit of its kind: a metadata document (zarr.json, .zarray, ...)
  MAX_METADATA_BYTES, a chunk of an array whose limit was set (``limit_chunks``) that limit, and
  every read within the memory available;
- a chunk must not decode to more than its chunk holds, as far as its codec says so before
  decoding (chunk_codecs.py: zstd, blosc, gzip, zlib);
- a key with no file is what zarr calls absent (the chunk reads as the fill value); ``run``
  collects those keys, so that the caller can hold them against the store's own statistics.
A refused key raises ``StoreFileError`` (a VolumeFileError naming the key).

``run`` runs one of zarr's coroutines on zarr's event loop. When it fails, the tasks it started
(the other chunks of the read) are awaited before the error is raised: left pending, they are
destroyed when the interpreter exits, with "Task was destroyed but it is pending!" and "Event loop
is closed" tracebacks after vgraph's own message.
"""

from __future__ import annotations

import asyncio
import contextvars
import os
import stat
from pathlib import Path

from zarr.abc.store import OffsetByteRequest, RangeByteRequest, SuffixByteRequest
from zarr.core.buffer.core import default_buffer_prototype
from zarr.core.sync import sync
from zarr.storage import LocalStore

from vgraph.bricks.chunk_codecs import decoded_size_problem, outer_codec
from vgraph.errors import VolumeFileError
from vgraph.memory import available_memory, format_bytes

METADATA_NAMES = frozenset({"zarr.json", ".zarray", ".zattrs", ".zgroup", ".zmetadata"})
# Metadata documents are small JSON; one beyond this is not metadata, and zarr would parse it whole
# (the same bound as the volume readers' text headers, vgraph.io).
MAX_METADATA_BYTES = 8 * 2**20
SETTLE_SECONDS = 30.0  # how long a failed read waits for the rest of its chunks (local files)
_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
_missing: contextvars.ContextVar[list | None] = contextvars.ContextVar("vgraph_missing_keys", default=None)


class StoreFileError(VolumeFileError):
    """A file of a store that is refused before it is read; ``key`` is its path in the store."""

    def __init__(self, root, key: str, reason: str):
        self.key = key
        super().__init__(root, reason, key)


def chunk_limit(decoded_bytes: int) -> int:
    """The largest file a chunk of ``decoded_bytes`` can be: compression, shuffling and sharding
    indices add a fraction of a percent and a few bytes; twice the size and 64 KiB is far beyond
    what any codec adds, and far below what a runaway file would cost."""
    return 2 * int(decoded_bytes) + 64 * 1024


class CheckedStore(LocalStore):
    """A read-only LocalStore that checks each file before reading it (see the module docstring)."""

    def __init__(self, root, *, read_only: bool = True, limits: dict | None = None):
        super().__init__(root, read_only=True)
        self.limits = {} if limits is None else limits  # array path -> ChunkLimit

    def with_read_only(self, read_only: bool = False):
        return type(self)(self.root, limits=self.limits)  # shares the limits; never writable

    def limit_chunks(self, array, decoded_bytes: int) -> None:
        """Chunks of ``array`` (a zarr array of this store) hold ``decoded_bytes``: their files may
        be at most chunk_limit of that, and must not decode to more."""
        self.limits[array.path.strip("/")] = (chunk_limit(decoded_bytes), int(decoded_bytes),
                                              outer_codec(array))

    # --- reads ----------------------------------------------------------------------------------
    async def get(self, key, prototype=None, byte_range=None):
        if not self._is_open:
            await self._open()
        return await asyncio.to_thread(self._read, key, prototype, byte_range)

    def get_sync(self, key, *, prototype=None, byte_range=None):
        self._ensure_open_sync()
        return self._read(key, prototype, byte_range)

    async def get_partial_values(self, prototype, key_ranges):
        return await asyncio.gather(*(self.get(key, prototype, byte_range) for key, byte_range in key_ranges))

    def _read(self, key: str, prototype, byte_range):
        prototype = prototype or default_buffer_prototype()
        path = self._path_of(key)
        max_file, decoded, codec = self._limit(key)
        data = _read_regular_file(path, self, key, byte_range, max_file)
        if data is None:
            missing = _missing.get()
            if missing is not None:
                missing.append(key)
            return None
        problem = decoded_size_problem(codec, data, decoded) if codec and byte_range is None else None
        if problem:
            raise StoreFileError(self.root, key, problem)
        return prototype.buffer.from_bytes(data)

    def _path_of(self, key: str) -> Path:
        parts = key.split("/")
        if not key or any(part in ("", ".", "..") for part in parts) or "\x00" in key:
            raise StoreFileError(self.root, key, "is not a path inside the store")
        return self.root.joinpath(*parts)

    def _limit(self, key: str) -> tuple[int, int | None, str | None]:
        """(largest file, decoded bytes, codec checked before decoding) of ``key``."""
        folder, _, name = key.rpartition("/")
        if name in METADATA_NAMES:
            return MAX_METADATA_BYTES, None, None
        while folder:  # the innermost array the key lies in
            if folder in self.limits:
                return self.limits[folder]
            folder = folder.rpartition("/")[0]
        return MAX_METADATA_BYTES, None, None  # nothing but metadata is read before an array's limit is set


def _read_regular_file(path: Path, store: CheckedStore, key: str, byte_range, limit: int) -> bytes | None:
    """The bytes of ``path`` (a byte range of them), None when there is no such file."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as error:  # a loop of links, no permission, a name too long
        raise StoreFileError(store.root, key, f"cannot be read: {error.strerror}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            kind = next((name for test, name in _KINDS if test(info.st_mode)), "not a file")
            raise StoreFileError(store.root, key, f"is not a regular file ({kind})")
        start, stop = byte_span(byte_range, info.st_size)
        if info.st_size > limit:
            what = "metadata document" if key.rpartition("/")[2] in METADATA_NAMES else "chunk"
            raise StoreFileError(store.root, key, f"is {format_bytes(info.st_size)}, more than a {what} "
                                                  f"of this store can be ({format_bytes(limit)})")
        available = available_memory()
        if available is not None and stop - start > available:
            raise StoreFileError(store.root, key, f"too large for memory: reading it needs "
                                                  f"{format_bytes(stop - start)} but only "
                                                  f"{format_bytes(available)} is available")
        return _read_span(fd, start, stop)
    except OSError as error:
        raise StoreFileError(store.root, key, f"cannot be read: {error.strerror}") from None
    finally:
        os.close(fd)


def byte_span(byte_range, size: int) -> tuple[int, int]:
    """The [start, stop) of a zarr byte request (None: all) within ``size`` bytes."""
    if byte_range is None:
        return 0, size
    if isinstance(byte_range, RangeByteRequest):
        return min(byte_range.start, size), min(max(byte_range.end, byte_range.start), size)
    if isinstance(byte_range, OffsetByteRequest):
        return min(byte_range.offset, size), size
    if isinstance(byte_range, SuffixByteRequest):
        return max(0, size - byte_range.suffix), size
    raise TypeError(f"unexpected byte range {byte_range!r}")


def _read_span(fd: int, start: int, stop: int) -> bytes:
    pieces, at = [], start
    while at < stop:
        piece = os.pread(fd, min(stop - at, 16 * 2**20), at)
        if not piece:  # the file shrank since fstat: what is there is what the codecs get
            break
        pieces.append(piece)
        at += len(piece)
    return b"".join(pieces)


# --- running zarr's coroutines ----------------------------------------------------------------------
def run(coroutine, missing: list | None = None):
    """The result of one of zarr's coroutines, run on zarr's event loop; ``missing`` (a list)
    receives the keys found absent meanwhile. A failure is raised once the tasks the coroutine
    started have finished."""
    return sync(_settled(coroutine, missing))


async def _settled(coroutine, missing: list | None):
    _missing.set(missing)  # this task's context: the tasks it starts copy it
    before = {task for task in asyncio.all_tasks() if task is not asyncio.current_task()}
    try:
        return await coroutine
    except BaseException:
        started = [task for task in asyncio.all_tasks()
                   if task is not asyncio.current_task() and task not in before]
        if started:
            await asyncio.wait(started, timeout=SETTLE_SECONDS)
            for task in started:  # their errors are this one's consequences: retrieved, not logged
                if task.done() and not task.cancelled():
                    task.exception()
        raise
