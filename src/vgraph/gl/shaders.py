"""GLSL composition (#include, #define) and a program cache keyed by define set.

Conventions (docs/explanations/shaders.md has the long form):
- Shader files end in ``.glsl``: ``NAME.vert.glsl``, ``NAME.frag.glsl``, ``NAME.geom.glsl``,
  ``NAME.comp.glsl`` for stages, plain ``NAME.glsl`` for included libraries. Names are paths relative
  to a shader directory, with ``/`` separators (``"lib/shading.glsl"``).
- Search path: the directory of the package ``vgraph.shaders`` first, then directories added with
  ``add_shader_dir`` in the order added. The first match wins. ``#include`` looks beside the including
  file first, then along the search path.
- A composed source is: the top file's ``#version`` line (``#version 330`` if it has none), one
  ``#define`` per define (sorted keys), the files named in ``includes`` (the parts a ray caster's
  components bring, vgraph.gl.raycasting.raycaster_base), then the body with ``#include "name"``
  expanded recursively.
  Each file is included at most once per composed source (like ``#pragma once``), which also breaks
  include cycles. Includes are expanded textually, before GLSL's own preprocessor: ``#if`` does not
  guard them.
- Every composed line maps back to (file, line); compiler messages are translated through that map so
  a ``ShaderError`` names the real file and line. Lines of the define block map to ("<defines>", k).
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

import moderngl

from vgraph import derived
from vgraph.errors import ShaderError
from vgraph import gl_context

DEFINES_FILE = "<defines>"
DEFAULT_VERSION_LINE = "#version 330"

_VERSION_RE = re.compile(r"^\s*#\s*version\b")
_INCLUDE_RE = re.compile(r"^\s*#\s*include\b")
_INCLUDE_ARG_RE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*(//.*)?$')
_IDENTIFIER_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

_extra_dirs: list[Path] = []


def builtin_shader_dir() -> Path:
    """The installed directory of ``vgraph.shaders`` (the repository's ``shaders/``)."""
    return Path(str(files("vgraph.shaders")))


def add_shader_dir(path: str | Path) -> None:
    """Append a directory to the search path (plug-ins). Adding the same directory twice is a no-op."""
    directory = Path(path).resolve()
    if not directory.is_dir():
        raise _error(f"shader directory does not exist: {directory}")
    if directory not in _extra_dirs:
        _extra_dirs.append(directory)


def shader_dirs() -> list[Path]:
    """The search path, in lookup order."""
    return [builtin_shader_dir(), *_extra_dirs]


def find_shader(name: str, beside: Path | None = None) -> Path:
    """Resolve a shader name: an absolute path as is; otherwise beside ``beside`` (the including
    file's directory) and then along the search path."""
    if Path(name).is_absolute():
        if Path(name).is_file():
            return Path(name).resolve()
    else:
        candidates = ([beside] if beside is not None else []) + shader_dirs()
        for directory in candidates:
            path = directory / name
            if path.is_file():
                return path.resolve()
    searched = ", ".join(str(d) for d in shader_dirs())
    raise _error(f"shader {name!r} not found (searched {searched})")


# ----------------------------------------------------------------------------------- composition

@dataclass(frozen=True)
class ComposedSource:
    """A shader ready to compile. ``line_map[i]`` is the origin (file, line) of composed line i + 1."""

    name: str
    text: str
    line_map: tuple[tuple[str, int], ...]
    files: tuple[str, ...]  # every file used, top file first

    def origin(self, line: int) -> tuple[str, int | None]:
        """(file, line) of a 1-based composed line; (top file, None) if out of range."""
        if 1 <= line <= len(self.line_map):
            return self.line_map[line - 1]
        return self.files[0], None


def format_define_value(key: str, value: object) -> str | None:
    """The text after ``#define KEY``: '' for True, None (omit the define) for False/None.
    Integers stay integers, floats always read as GLSL floats (``1.0``, ``1e-05``)."""
    if not _IDENTIFIER_RE.match(key):
        raise _error(f"define name {key!r} is not a GLSL identifier")
    if value is None or value is False:
        return None
    if value is True:
        return ""
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        number = float(value)
        if not math.isfinite(number):
            raise _error(f"define {key} = {number}: not a finite number")
        return repr(number)  # Python's repr of a float always has '.' or an exponent
    if isinstance(value, str):
        if "\n" in value or "\r" in value:
            raise _error(f"define {key}: value must be a single line")
        return value.strip()
    raise _error(f"define {key} = {value!r}: use bool, int, float or str")


def define_lines(defines: dict[str, object] | None) -> tuple[str, ...]:
    """The ``#define`` lines for a define set, sorted by key; also the set's cache identity."""
    lines = []
    for key in sorted(defines or {}):
        text = format_define_value(key, defines[key])
        if text is not None:
            lines.append(f"#define {key} {text}".rstrip())
    return tuple(lines)


def compose(name: str, defines: dict[str, object] | None = None, *,
            processor: str | None = None, includes: tuple[str, ...] = ()) -> ComposedSource:
    """Compose shader ``name`` with ``defines``, the files ``includes`` ahead of its body. Errors
    name the file and line (and ``processor``)."""
    try:
        top = find_shader(name)
    except ShaderError as exc:
        raise _error(_reason(exc), None, None, processor) from None
    body: list[tuple[str, str, int]] = []  # (text, file, line)
    included = {top}
    for include in includes:
        _include(f'#include "{include}"', top, 0, body, included, processor)
    version = _expand(top, body, included, is_top=True, processor=processor)

    texts: list[str] = []
    origins: list[tuple[str, int]] = []
    if version is None:
        texts.append(DEFAULT_VERSION_LINE)
        origins.append((str(top), 0))
    else:
        texts.append(version[0])
        origins.append((str(top), version[1]))
    try:
        lines = define_lines(defines)
    except ShaderError as exc:
        raise _error(_reason(exc), str(top), None, processor) from None
    for k, line in enumerate(lines, start=1):
        texts.append(line)
        origins.append((DEFINES_FILE, k))
    for text, file, line in body:
        texts.append(text)
        origins.append((file, line))
    used = dict.fromkeys([str(top)] + [file for _, file, _ in body])  # first-use order
    return ComposedSource(name=name, text="\n".join(texts) + "\n", line_map=tuple(origins),
                          files=tuple(used))


def _expand(path: Path, out: list, included: set, is_top: bool,
            processor: str | None) -> tuple[str, int] | None:
    """Append the lines of ``path`` to ``out`` with includes expanded; return the #version line
    (text, line number) if this is the top file and it has one."""
    version = None
    for number, text in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if _VERSION_RE.match(text):
            if not is_top:
                raise _error("#version belongs only in the top-level shader, not in an include",
                             str(path), number, processor)
            if version is not None:
                raise _error("second #version line", str(path), number, processor)
            version = (text.strip(), number)
            continue
        if _INCLUDE_RE.match(text):
            _include(text, path, number, out, included, processor)
            continue
        out.append((text, str(path), number))
    return version


def _include(text: str, path: Path, number: int, out: list, included: set,
             processor: str | None) -> None:
    match = _INCLUDE_ARG_RE.match(text)
    if not match:
        raise _error('malformed #include: write #include "name.glsl"', str(path), number,
                     processor)
    try:
        target = find_shader(match.group(1), beside=path.parent)
    except ShaderError as exc:
        raise _error(f"#include: {_reason(exc)}", str(path), number, processor) from None
    if target in included:  # once per program; this is also what ends include cycles
        return
    included.add(target)
    _expand(target, out, included, is_top=False, processor=processor)


def _error(message: str, file: str | None = None, line: int | None = None,
           processor: str | None = None) -> ShaderError:
    """A ShaderError that also keeps its bare message, so it can be re-raised with more context."""
    error = ShaderError(message, file, line, processor)
    error.reason = message
    return error


def _reason(exc: ShaderError) -> str:
    return getattr(exc, "reason", None) or str(exc)


# ----------------------------------------------------------------------------- compiler messages

_STAGE_HEADER_RE = re.compile(r"^(vertex|fragment|geometry|tess_control|tess_evaluation|compute)"
                              r"_shader$")
_LOG_LINE_RES = (
    re.compile(r"^\s*\d+:(?P<line>\d+)\(\d+\):\s*(?P<kind>error|warning):\s*(?P<text>.*)$"),  # Mesa
    re.compile(r"^\s*\d+\((?P<line>\d+)\)\s*:\s*(?P<kind>error|warning)\b\s*(?:[A-Z]\d+\s*)?:?"
               r"\s*(?P<text>.*)$"),  # NVIDIA
    re.compile(r"^\s*(?P<kind>ERROR|WARNING):\s*\d+:(?P<line>\d+):\s*(?P<text>.*)$"),  # AMD, Intel
)


def parse_compiler_log(log: str) -> list[tuple[str | None, int, str]]:
    """(stage, line, message) for every error in a moderngl compiler message; stage is e.g.
    'fragment' when the log names it, else None."""
    stage = None
    errors = []
    for raw in log.splitlines():
        header = _STAGE_HEADER_RE.match(raw.strip())
        if header:
            stage = header.group(1)
            continue
        for pattern in _LOG_LINE_RES:
            match = pattern.match(raw)
            if match:
                if match.group("kind").lower() == "error":
                    errors.append((stage, int(match.group("line")), match.group("text").strip()))
                break
    return errors


def shader_error_from_log(log: str, sources: dict[str, ComposedSource],
                          processor: str | None = None) -> ShaderError:
    """Translate a compile/link message into a ShaderError at the original file and line.
    ``sources`` maps stage ('vertex', 'fragment', ...) to its composed source."""
    errors = parse_compiler_log(log)
    if not errors:
        names = " + ".join(s.name for s in sources.values())
        detail = "\n".join(l for l in log.splitlines()
                           if l.strip() and not set(l.strip()) <= {"="}
                           and l.strip() not in ("GLSL Linker failed", "Program"))
        what = "link" if "Linker" in log else "compile"
        return _error(f"{what} error in {names}: {detail.strip()}", None, None, processor)
    located = []
    for stage, line, text in errors:
        source = sources.get(stage) if stage else next(iter(sources.values()))
        file, original = source.origin(line) if source else (None, None)
        located.append((stage, file, original, text))
    stage, file, line, text = located[0]
    message = f"{stage} shader: {text}" if stage else text
    more = [f"{f}:{l}: {t}" for _, f, l, t in located[1:]]
    if more:
        message += "\n  also " + "\n  also ".join(more)
    return _error(message, file, line, processor)


# -------------------------------------------------------------------------------------- the cache

_UNIFORM_RE = re.compile(r"^\s*uniform\s+\w+\s+(\w+)", re.M)


@dataclass(frozen=True)
class ProgramSource:
    """What a compiled program was made from: its shader files (for messages) and the names of the
    uniforms its sources declare, in any #ifdef branch (the compiler drops the unused ones)."""

    files: tuple[str, ...]
    processor: str | None
    declared: frozenset[str]

    def describe(self) -> str:
        """The shader files (the processor, if any, is named by the ProcessorError around)."""
        return " + ".join(self.files)


class ProgramCache:
    """Compiled programs per (context, shader names, define set). A program is compiled the first
    time it is asked for; ``compile_count`` counts compiler invocations (tests use it).
    ``source_of(program)`` says what a cached program was made from."""

    def __init__(self):
        self._programs: dict[tuple, object] = {}
        self._sources: dict[int, ProgramSource] = {}  # by id(program), while it is cached
        # The same programs by the defines exactly as given (values with their types: 1 and 1.0
        # are different define text), so a frame's lookups need not format and check each define.
        self._given: dict[tuple, object] = {}
        self.compile_count = 0

    def source_of(self, program) -> ProgramSource | None:
        """The ProgramSource of a program this cache compiled (None for any other program)."""
        return self._sources.get(id(program))

    def program(self, ctx: moderngl.Context, vertex: str, fragment: str,
                defines: dict[str, object] | None = None,
                processor: str | None = None, geometry: str | None = None,
                includes: tuple[str, ...] = ()) -> moderngl.Program:
        """The program of ``vertex`` (+ optional ``geometry``) + ``fragment`` shader files composed
        with ``defines``; ``includes`` go ahead of the fragment shader's body (compose)."""
        given = (ctx, vertex, geometry, fragment, includes,
                 tuple((name, value.__class__, value) for name, value in (defines or {}).items()))
        try:
            program = self._given.get(given)
        except TypeError:  # an unhashable define value: _define_key below says what is wrong
            given = program = None
        if program is not None:
            return program
        key = (ctx, "program", vertex, geometry, fragment, includes, self._define_key(defines, processor))
        if key not in self._programs:
            sources = {"vertex": compose(vertex, defines, processor=processor)}
            if geometry is not None:
                sources["geometry"] = compose(geometry, defines, processor=processor)
            sources["fragment"] = compose(fragment, defines, processor=processor, includes=includes)
            self._programs[key] = self._compile(
                lambda: ctx.program(vertex_shader=sources["vertex"].text,
                                    geometry_shader=sources["geometry"].text if geometry else None,
                                    fragment_shader=sources["fragment"].text),
                sources, processor)
        if given is not None:
            self._given[given] = self._programs[key]
        return self._programs[key]

    def compute(self, ctx: moderngl.Context, name: str, defines: dict[str, object] | None = None,
                processor: str | None = None) -> moderngl.ComputeShader:
        """The compute shader ``name`` composed with ``defines`` (needs GL 4.3)."""
        key = (ctx, "compute", name, self._define_key(defines, processor))
        if key not in self._programs:
            sources = {"compute": compose(name, defines, processor=processor)}
            self._programs[key] = self._compile(
                lambda: ctx.compute_shader(sources["compute"].text), sources, processor)
        return self._programs[key]

    def clear(self, ctx: moderngl.Context | None = None) -> None:
        """Release and forget the programs of ``ctx`` (all contexts if None)."""
        for key in [k for k in self._programs if ctx is None or k[0] is ctx]:
            program = self._programs.pop(key)
            self._sources.pop(id(program), None)
            derived.forget(program)  # its vertex array and uniform values, before the program
            program.release()
        self._given = {key: program for key, program in self._given.items() if ctx is not None and key[0] is not ctx}

    def forget_context(self, ctx: moderngl.Context) -> None:
        """Drop the programs of a context that is going away."""
        self.clear(ctx)

    def __len__(self) -> int:
        return len(self._programs)

    def _compile(self, build, sources: dict[str, ComposedSource], processor: str | None):
        self.compile_count += 1
        try:
            program = build()
        except moderngl.Error as exc:
            raise shader_error_from_log(str(exc), sources, processor) from None
        declared = frozenset(name for source in sources.values() for name in _UNIFORM_RE.findall(source.text))
        self._sources[id(program)] = ProgramSource(tuple(s.name for s in sources.values()), processor, declared)
        return program

    @staticmethod
    def _define_key(defines, processor) -> tuple[str, ...]:
        try:
            return define_lines(defines)
        except ShaderError as exc:
            raise _error(_reason(exc), None, None, processor) from None


programs = ProgramCache()
gl_context.on_release(programs.forget_context)
