"""One cache for derived data: what is worked out from a source object (a volume, a mesh, a
geometry, a program, a context) and kept while the source lives.

    texture = derived.value(volume, "volume texture", make=lambda: upload(ctx, volume), ctx=ctx)

Conventions (docs/explanations/architecture.md, "One cache for derived data"):
- An entry is keyed by the source's identity (held weakly), a ``kind`` (a short name, which the
  counters are kept by) and the GL context it lives on, if any. It holds one value and the
  ``params`` it was derived with: asked with other params, the entry is a miss and is replaced (a
  volume keeps one gradient texture per context, a framed copy for the frame of the last draw).
  Params are compared with ``is`` or ``==``, so they need not be hashable.
- The source owns its entries: when it dies they are dropped, and GL objects among their values
  (a moderngl object, or one inside a tuple, list or dict) are released. An entry made for a
  context is released too when that context is released or replaced (vgraph.gl_context calls
  ``forget_context``), and a context whose object is gone never hits.
- Derived data is what a consumer works out from a source and that the source does not need for
  itself: textures, buffers, vertex arrays, gradient volumes, block ranges, label codes, cell
  attributes, copies in another frame or precision, a program's last uniform values. What a
  data type keeps about itself (a Volume's value range, extremes, percentile ranks and
  histograms, as cached properties) stays on it: it is part of the type and travels with it
  (Volume.with_overrides hands it on).
- ``stats()`` gives hits and misses per kind, for tests and benchmarks; ``reset_stats()`` clears them.
- Thread safety: the table is changed under a lock; ``make`` runs outside it (two threads may
  both make a value, the last one is kept, the other released).
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass
from typing import Any, Callable

import moderngl

_NO_PARAMS = ()


@dataclass
class Counts:
    """Hits and misses of one kind since the last reset_stats(), and its live entries now."""
    hits: int = 0
    misses: int = 0
    entries: int = 0


@dataclass
class _Entry:
    params: Any
    value: Any
    ctx: Any  # a weak reference to the context the value lives on, or None


_lock = threading.RLock()
_entries: dict[int, dict[tuple[str, int | None], _Entry]] = {}  # id(source) -> (kind, id(ctx)) -> entry
_counts: dict[str, Counts] = {}


def value(source, kind: str, make: Callable[[], Any], params=_NO_PARAMS, ctx=None):
    """The value derived from ``source`` as ``kind`` with ``params`` (on ``ctx``), made by
    ``make()`` on a miss and kept while the source (and the context) live."""
    found = _lookup(source, kind, params, ctx)
    if found is not None:
        return found.value
    made = make()
    _store(source, kind, _Entry(params, made, None if ctx is None else weakref.ref(ctx)), ctx)
    return made


def peek(source, kind: str, ctx=None, default=None):
    """The value kept for ``source`` as ``kind`` (on ``ctx``) whatever its params, without
    making one and without counting; ``default`` when there is none."""
    with _lock:
        entry = _entries.get(id(source), {}).get((kind, _ctx_key(ctx)))
    return default if entry is None or not _alive(entry) else entry.value


def holds(source, kind: str) -> bool:
    """Whether ``source`` has a ``kind`` entry on any context."""
    with _lock:
        return any(k == kind and _alive(e) for (k, _), e in _entries.get(id(source), {}).items())


def stats() -> dict[str, Counts]:
    """Hits, misses and live entries per kind (copies)."""
    with _lock:
        live = {}
        for per_source in _entries.values():
            for (kind, _), entry in per_source.items():
                live[kind] = live.get(kind, 0) + 1
        kinds = set(_counts) | set(live)
        return {kind: Counts(_counts.get(kind, Counts()).hits, _counts.get(kind, Counts()).misses,
                             live.get(kind, 0)) for kind in sorted(kinds)}


def reset_stats() -> None:
    with _lock:
        _counts.clear()


def forget(source) -> None:
    """Drop and release every entry of ``source`` now (a program about to be released)."""
    _forget_source(id(source))


def forget_context(ctx) -> None:
    """Drop and release every entry made on ``ctx`` (called when the context is released)."""
    key = id(ctx)
    dropped = []
    with _lock:
        for per_source in _entries.values():
            for entry_key in [k for k in per_source if k[1] == key]:
                dropped.append(per_source.pop(entry_key).value)
    if not dropped:
        return
    try:
        with ctx:  # current while its names are deleted: another context's may be current now
            release(dropped)
    except Exception:  # the context is gone already, and its objects with it
        pass


def release(value_or_values) -> None:
    """Release the GL objects in a value: a moderngl object, or those inside a tuple, list or
    dict (nested). Quietly: at interpreter exit the context may be gone already."""
    if isinstance(value_or_values, dict):
        value_or_values = list(value_or_values.values())
    if isinstance(value_or_values, (tuple, list)):
        for item in value_or_values:
            release(item)
    elif getattr(value_or_values, "mglo", None) is not None:  # what every moderngl object has
        try:
            value_or_values.release()
        except Exception:  # the context may already be gone
            pass


def _lookup(source, kind: str, params, ctx) -> _Entry | None:
    with _lock:
        counts = _counts.get(kind) or _counts.setdefault(kind, Counts())
        entry = _entries.get(id(source), {}).get((kind, _ctx_key(ctx)))
        if entry is not None and _alive(entry) and (entry.params is params or _equal(entry.params, params)):
            counts.hits += 1
            return entry
        counts.misses += 1
        return None


def _store(source, kind: str, entry: _Entry, ctx) -> None:
    key = id(source)
    with _lock:
        per_source = _entries.get(key)
        if per_source is None:
            per_source = _entries[key] = {}
            weakref.finalize(source, _forget_source, key)
        replaced = per_source.get((kind, _ctx_key(ctx)))
        per_source[(kind, _ctx_key(ctx))] = entry
    if replaced is not None and replaced.value is not entry.value:
        release(replaced.value)


def _forget_source(key: int) -> None:
    with _lock:
        per_source = _entries.pop(key, {})
    for entry in per_source.values():
        release(entry.value)


def _ctx_key(ctx) -> int | None:
    return None if ctx is None else id(ctx)


def _alive(entry: _Entry) -> bool:
    """False for an entry of a context that is gone (its id may be another context's now) or a
    GL object released by someone else (a context released by its owner releases them all)."""
    if entry.ctx is not None and entry.ctx() is None:
        return False
    return not isinstance(getattr(entry.value, "mglo", None), moderngl.InvalidObject)


def _equal(a, b) -> bool:
    try:
        return bool(a == b)
    except ValueError:  # numpy arrays among the params: compared by identity only
        return False
