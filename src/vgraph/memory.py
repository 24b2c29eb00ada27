"""Memory: how much a new allocation can use, and a failed allocation told as a user can act on it.

``available_memory()`` is what the readers check a load against before reading a byte. When an
allocation fails all the same (a copy nobody checked, a library's own buffer, the GL), Python
raises a bare ``MemoryError``; ``out_of_memory_reason`` says instead what failed, its size where
known (numpy's errors carry it) and the memory that would do: under an address-space limit
(``ulimit -v``, RLIMIT_AS) the limit that would hold what the process holds plus the allocation,
otherwise how much memory was available. ``OutOfMemoryError`` carries that sentence as a
VGraphError (exit 2): the input is too large for the machine as it is set up, not a bug.
"""

from __future__ import annotations

import os
import resource

from vgraph.errors import VGraphError, VolumeFileError


class OutOfMemoryError(VGraphError):
    """An allocation failed; the message names what it was for, its size and what would do."""

    def __init__(self, reason: str, size: int | None = None):
        self.reason, self.size = reason, size
        super().__init__(reason)


def available_memory() -> int | None:
    """Bytes of memory a new allocation can use: MemAvailable from /proc/meminfo (else the free
    physical pages), lowered to the address space left under RLIMIT_AS when the process has
    one; None when unknown (the check is then skipped)."""
    limits = [n for n in (_physical_memory_available(), address_space_left()) if n is not None]
    return min(limits) if limits else None


def check_memory(file, needed_bytes: int, field: str | None = None) -> None:
    """Refuse a load of ``file`` that cannot fit before any byte of it is read."""
    available = available_memory()
    if available is not None and needed_bytes > available:
        raise VolumeFileError(file, f"too large for memory: loading needs {format_bytes(needed_bytes)} "
                                    f"({needed_bytes} bytes) but only {format_bytes(available)} "
                                    f"is available", field)


def _physical_memory_available() -> int | None:
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def address_space() -> tuple[int, int] | None:
    """(bytes of address space the process holds, its RLIMIT_AS), or None without a limit."""
    soft, _hard = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return None
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024, soft
    except (OSError, ValueError, IndexError):
        pass
    return None


def address_space_left() -> int | None:
    """Under RLIMIT_AS an allocation beyond the limit fails with MemoryError however much
    physical memory is free, so the headroom below the limit counts as the available memory."""
    held = address_space()
    return None if held is None else max(0, held[1] - held[0])


def format_bytes(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n} bytes"  # unreachable


def allocation_size(error: BaseException) -> int | None:
    """The bytes a MemoryError failed to allocate, where the error says (numpy's do)."""
    size = getattr(error, "_total_size", None)
    return int(size) if isinstance(size, int) and size > 0 else None


def out_of_memory_reason(doing: str | None = None, size: int | None = None) -> str:
    """'out of memory: allocating 2.0 GiB failed while <doing>: <what there was; what would do>'."""
    what = f"allocating {format_bytes(size)} failed" if size else "an allocation of unknown size failed"
    while_doing = f" while {doing}" if doing else ""
    return f"out of memory: {what}{while_doing}: {_budget(size)}"


def _budget(size: int | None) -> str:
    held = address_space()
    if held is not None:
        used, limit = held
        there = (f"the process holds {format_bytes(used)} of its {format_bytes(limit)} address-space "
                 f"limit (ulimit -v)")
        if size:
            return f"{there}; a limit of at least {format_bytes(_rounded_up(used + size))} would do"
        return f"{there}; raise the limit, or give it less data at once"
    available = available_memory()
    there = "" if available is None else f"{format_bytes(available)} of memory was available"
    if size and available is not None:
        return f"{there}; it needs {format_bytes(_rounded_up(size - available))} more: free memory or " \
               f"give it less data at once"
    return (there or "the available memory is unknown") + "; free memory or give it less data at once"


def _rounded_up(n: int) -> float:
    """Up to the next tenth of a GiB (or MiB), as format_bytes shows it: never below ``n``."""
    unit = 2**30 if n >= 2**30 else 2**20
    return -(-n * 10 // unit) * unit / 10  # integer ceiling: 5 GiB stays 5.0, not 5.1


def out_of_memory(error: BaseException, doing: str | None = None, size: int | None = None) -> OutOfMemoryError:
    """The OutOfMemoryError to raise ``from`` a caught MemoryError (``size`` when the caller knows
    better than the error)."""
    size = size or allocation_size(error)
    return OutOfMemoryError(out_of_memory_reason(doing, size), size)
