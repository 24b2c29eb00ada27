"""Leak checks: live GL textures and resident memory over many evaluations of a network.

A network evaluated again and again (a slider dragged in the GUI, a batch job over parameters) must
hold a constant number of GL objects and a constant amount of memory once every processor has run.
``repeated_evaluations`` re-runs one processor and everything downstream of it per evaluation,
taking the processors in turn, so every processor runs many times whatever its cost; the test suite
runs it on every shipped network and bench/leak_check.py runs it for longer.

Textures are counted by the GL itself (``glIsTexture`` over the names in use), so GL objects whose
Python wrappers are gone, the leaks that matter, are counted too. Memory is sampled once the GL has
finished its queued work and, on glibc, after the free heap pages are handed back
(``malloc_trim``): a driver keeps a deleted texture's storage while queued work still uses it,
and the allocator keeps freed pages, so without this a sample swings by whole volumes with the
timing of the GL work (llvmpipe, 24 Nov 2026: 22 MB steps for a 22 MB volume texture) although
nothing is held.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from dataclasses import dataclass
from pathlib import Path

from OpenGL import GL

from vgraph.gl_context import get_context
from vgraph.network import Network

# Texture names are small integers handed out from 1 and reused; scan well past the newest one.
_NAME_MARGIN = 4096


@dataclass
class LeakSample:
    evaluation: int
    textures: int
    resident_mb: float


def live_gl_textures(ctx) -> int:
    """How many texture names are alive on ``ctx`` (which must be current, as vgraph's is)."""
    ctx.error  # reading clears it: PyOpenGL would blame glIsTexture for an older error
    probe = ctx.texture((1, 1), 4)
    newest = probe.glo
    probe.release()
    return sum(1 for name in range(1, newest + _NAME_MARGIN) if GL.glIsTexture(name))


def resident_mb() -> float:
    """This process's resident memory in MiB (Linux /proc; 0 where unknown)."""
    try:
        with open("/proc/self/statm") as statm:
            pages = int(statm.read().split()[1])
    except (OSError, ValueError, IndexError):
        return 0.0
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def settled_resident_mb(ctx) -> float:
    """resident_mb() once the GL has finished and freed heap pages went back (module docstring)."""
    ctx.finish()
    library = ctypes.util.find_library("c")
    trim = getattr(ctypes.CDLL(library), "malloc_trim", None) if library else None
    if trim is not None:  # glibc only
        trim(0)
    return resident_mb()


def writers_redirected(network: Network, folder) -> Network:
    """The network with every writer writing into ``folder`` instead (same names and suffixes), so
    a leak check does not rewrite the files the network normally writes."""
    for processor in network.processors.values():
        prop = processor.properties.get("path")
        if prop is not None and getattr(prop, "writes", False):
            processor.path = str(Path(folder) / f"{processor.id}{Path(processor.path).suffix}")
    return network


def repeated_evaluations(network: Network, count: int, size=(48, 48), every: int = 50,
                         targets=()) -> list[LeakSample]:
    """Evaluate ``count`` times, re-running processor ``i % n`` and its downstream at the i-th
    evaluation; sample textures and memory every ``every`` evaluations (and after the last)."""
    order = list(network.processors)
    samples = []
    for i in range(count):
        network.invalidate_downstream(order[i % len(order)])
        network.update(*targets, size=size)
        if (i + 1) % every == 0 or i + 1 == count:
            ctx = get_context()
            samples.append(LeakSample(i + 1, live_gl_textures(ctx), settled_resident_mb(ctx)))
    return samples
