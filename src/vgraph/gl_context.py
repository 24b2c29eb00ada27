"""The one OpenGL context of a vgraph process.

Conventions:
- Exactly one ``moderngl.Context`` is current for vgraph per process. Code that renders receives it
  (or asks ``get_context()``) and never creates a context of its own, so textures, programs and
  framebuffers made by different processors can be used together.
- By default the context is created lazily as a *standalone* (headless) context: EGL first, because it
  needs no X server (on a machine without a GPU Mesa's llvmpipe provides GL 4.5 core through it), then
  moderngl's default standalone backend (GLX/WGL/CGL). OpenGL 3.3 core is the minimum.
- An owner that already has a context (a Qt widget, a render process) installs it with
  ``set_context``. vgraph never releases a context it did not create.
- Caches keyed by context (compiled programs) register a callback with ``on_release`` so they
  forget a context when it is released or replaced; the cache of derived data (vgraph.derived:
  textures, buffers, vertex arrays) is told first.
- GL objects are freed when nothing references them any more: the context runs in moderngl's
  "context_gc" mode (objects whose Python wrapper dies are queued) and the scheduler calls
  ``collect_garbage()`` after every evaluation, so an output replaced by a new one (a plug-in that
  makes a new Image in each process()) costs no memory. (moderngl's default mode never frees them;
  its "auto" mode frees them from ``__del__``, at moments when a context may not be current.)
"""

from __future__ import annotations

import threading
from typing import Callable

import moderngl

from vgraph import derived
from vgraph.errors import VGraphError

REQUIRED_GL_VERSION = 330
# Tried in this order; None means moderngl's platform default for standalone contexts.
_BACKENDS: tuple[str | None, ...] = ("egl", None)
_SYSTEM_PACKAGES = "libegl1 libgl1 libgl1-mesa-dri libegl-mesa0 (Debian/Ubuntu package names)"

_lock = threading.RLock()
_context: moderngl.Context | None = None
_owned = False  # True when vgraph created the context and must release it
_release_callbacks: list[Callable[[moderngl.Context], None]] = [derived.forget_context]


def get_context() -> moderngl.Context:
    """The process's shared context, creating a standalone one on first use."""
    global _context, _owned
    with _lock:
        if _context is None:
            _context = _collecting(_create_standalone_context())
            _owned = True
        return _context


def set_context(ctx: moderngl.Context | None) -> None:
    """Install ``ctx`` (owned by the caller) as the shared context; ``None`` uninstalls.

    A context vgraph created itself is released when it is replaced."""
    global _context, _owned
    with _lock:
        if ctx is _context:
            return
        _drop_current_context()
        _context, _owned = (_collecting(ctx) if ctx is not None else None), False


def collect_garbage() -> int:
    """Free the GL objects of the shared context whose Python wrappers are gone; returns how many."""
    with _lock:
        ctx = _context
        if ctx is None or ctx.gc_mode != "context_gc":
            return 0
        freed = 0
        if ctx.objects:
            bind_default_framebuffer(ctx)  # a queued framebuffer may be the bound one
        while ctx.objects:
            handle = ctx.objects.popleft()
            if hasattr(handle, "release"):  # objects released explicitly are queued as invalid ones
                handle.release()
                freed += 1
        return freed


def bind_default_framebuffer(ctx: moderngl.Context) -> None:
    """Bind framebuffer 0 before a framebuffer is released: moderngl restores the binding it last
    made after creating the next one, and binding a deleted name is GL_INVALID_OPERATION."""
    ctx.detect_framebuffer(0).use()


def _collecting(ctx: moderngl.Context) -> moderngl.Context:
    if ctx.gc_mode is None:  # an owner that chose a mode keeps it
        ctx.gc_mode = "context_gc"
    return ctx


def release_context() -> None:
    """Forget the shared context; release it if vgraph created it. The next ``get_context()``
    creates a new one."""
    with _lock:
        _drop_current_context()


def has_context() -> bool:
    """Whether a context is installed (without creating one)."""
    return _context is not None


def on_release(callback: Callable[[moderngl.Context], None]) -> None:
    """Call ``callback(ctx)`` whenever a context stops being the shared one (released or replaced),
    before a vgraph-owned context is actually released."""
    with _lock:
        if callback not in _release_callbacks:
            _release_callbacks.append(callback)


def _drop_current_context() -> None:
    global _context, _owned
    old, owned = _context, _owned
    _context, _owned = None, False
    if old is None:
        return
    for callback in list(_release_callbacks):
        callback(old)
    if owned:
        old.release()


def _create_standalone_context() -> moderngl.Context:
    failures = []
    for backend in _BACKENDS:
        kwargs = {"backend": backend} if backend else {}
        try:
            return moderngl.create_context(standalone=True, require=REQUIRED_GL_VERSION, **kwargs)
        except Exception as exc:  # moderngl raises plain Exception subclasses per backend
            failures.append(f"  standalone backend {backend or 'default'!r}: {_first_line(exc)}")
    tried = "\n".join(failures)
    raise VGraphError(
        f"no OpenGL {REQUIRED_GL_VERSION // 100}.{REQUIRED_GL_VERSION % 100 // 10} context could be "
        f"created. Tried:\n{tried}\n"
        f"Headless rendering needs EGL and a Mesa driver; install the system packages "
        f"{_SYSTEM_PACKAGES}, or install a context of your own with vgraph.gl_context.set_context().")


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0]


def release_quietly(objects: dict) -> None:
    """Release the GL objects that are the values of ``objects`` (dicts of them too) and empty it;
    for finalizers of data types that cache GL objects per context, which may run at interpreter
    exit when the context is already gone."""
    for value in objects.values():
        for gl_object in value.values() if isinstance(value, dict) else (value,):
            try:
                gl_object.release()
            except Exception:  # the context may already be gone
                pass
    objects.clear()
