"""Fullscreen passes: run a fragment shader once per pixel of a target Image.

Conventions:
- The vertex stage is ``fullscreen.vert.glsl``: one triangle generated from gl_VertexID (no vertex
  buffer), giving ``in vec2 uv`` in [0, 1] with v = 0 at the bottom row (GL convention).
- Textures are bound by name: ``bind_textures`` gives each sampler uniform of the program a unit
  (0, 1, ... in the order given) and returns the units by name, so nothing depends on where a
  texture sits in a dict; ``samplers`` of a pass (e.g. the volume's trilinear sampler) are bound to
  the unit of the texture they are named after for that pass only.
- Uniforms are set strictly (``set_uniform``): a name that the program's sources do not declare
  (a misspelt uniform) raises ShaderError naming it and the shader files, unless the caller marks
  it optional; a declared uniform that the compiler optimised away (not used by this define set)
  is skipped. Programs not made by ``vgraph.gl.shaders.programs`` are set leniently.
- numpy uniform values are written in the uniform's own type; a 2D array for a matrix uniform is in
  mathematical (row-major) layout and is transposed to GL's column-major order.
- A uniform keeps the bytes last written through ``set_uniform`` and is not written again with the
  same bytes (a program keeps its uniforms; a frame sets some 80, most of them unchanged): set a
  uniform either always through ``set_uniform`` or never. What was written is kept per program
  in the cache of derived data (vgraph.derived, kind "uniform values"), not on moderngl's objects.
- The attribute-less vertex array of a program is derived data too ("fullscreen vertex array"),
  released with the program or its context.
- The pass uses the context's current enable flags (by default no depth test and no blending).
"""

from __future__ import annotations

import struct

import moderngl
import numpy as np

from vgraph import derived
from vgraph.errors import ShaderError
from vgraph.gl.shaders import programs
from vgraph.image import Image

FULLSCREEN_VERTEX_SHADER = "fullscreen.vert.glsl"


def fullscreen_pass(ctx: moderngl.Context, program: moderngl.Program, target: Image,
                    textures: dict[str, object] | None = None,
                    uniforms: dict[str, object] | None = None, *,
                    samplers: dict[str, moderngl.Sampler] | None = None,
                    optional: frozenset[str] | set[str] = frozenset()) -> None:
    """Draw one fullscreen triangle with ``program`` into ``target`` (an Image, or RenderTargets for
    several outputs). ``samplers``: a sampler object per texture name; ``optional``: uniform names
    the program need not declare."""
    target.framebuffer.use()
    ctx.viewport = (0, 0, *target.size)
    units = bind_textures(program, textures or {})
    set_uniforms(program, uniforms or {}, optional)
    for name, sampler in (samplers or {}).items():
        sampler.use(units[name])
    try:
        _vertex_array(ctx, program).render(moderngl.TRIANGLES, vertices=3)
    finally:
        for name, sampler in (samplers or {}).items():
            sampler.clear(units[name])


def bind_textures(program: moderngl.Program, textures: dict[str, object]) -> dict[str, int]:
    """Bind each texture (or Image) to its own unit and point the sampler uniform of that name at
    it; returns the unit of each name."""
    units = {}
    for unit, (name, texture) in enumerate(textures.items()):
        (texture.texture if isinstance(texture, Image) else texture).use(location=unit)
        set_uniform(program, name, unit)
        units[name] = unit
    return units


# Values compared as they are: numbers and tuples of numbers (as vec() makes); numpy arrays are
# compared by their packed bytes.
_PLAIN = (float, int, bool, tuple)


class UniformValues:
    """What set_uniform knows of one program: its uniforms by name (None where the program has
    none of that name), and the value and the bytes last written to each. It holds no reference
    to the program, which owns it (vgraph.derived drops it when the program goes)."""

    __slots__ = ("members", "values", "written")

    def __init__(self):
        self.members: dict = {}
        self.values: dict = {}   # name -> the plain value last written (None: compare the bytes)
        self.written: dict = {}  # name -> the bytes last written

    def member(self, program: moderngl.Program, name: str):
        try:
            return self.members[name]
        except KeyError:
            member = self.members[name] = program.get(name, None)
            return member


def uniform_values(program: moderngl.Program) -> UniformValues:
    """The program's UniformValues, kept while the program and its context live."""
    return derived.value(program, "uniform values", UniformValues, ctx=program.ctx)


def set_uniform(program: moderngl.Program, name: str, value, optional: bool = False) -> bool:
    """Set a uniform; return whether the program uses it. ShaderError if the program's sources do
    not declare ``name`` at all, unless ``optional`` (see the module docstring)."""
    return _set_uniform(program, uniform_values(program), name, value, optional)


def _set_uniform(program: moderngl.Program, known: UniformValues, name: str, value, optional: bool) -> bool:
    uniform = known.member(program, name)
    if type(value) in _PLAIN and _same(known.values.get(name), value):
        return True  # the value last written (most uniforms of a frame): no packing, no write
    if not isinstance(uniform, moderngl.Uniform):
        source = programs.source_of(program)
        if source is not None and name not in source.declared and not optional:
            raise ShaderError(f"{source.describe()}: no uniform '{name}' is declared; misspelt, or "
                              f"set for a shader that does not have it?")
        return False
    if isinstance(value, np.ndarray):
        data = _uniform_bytes(uniform, value)
    else:
        data = _packed(uniform, value.item() if isinstance(value, np.generic) else value)
    if known.written.get(name) != data:
        uniform.write(data)
        known.written[name] = data
    known.values[name] = value if type(value) in _PLAIN else None
    return True


def set_uniforms(program: moderngl.Program, uniforms, optional=frozenset()) -> None:
    """set_uniform for each (name, value), in one loop: a frame sets some 90 uniforms, most of them
    unchanged, and a call apiece was the larger part of their cost."""
    known = uniform_values(program)
    values = known.values
    for name, value in uniforms.items():
        if type(value) in _PLAIN:
            try:
                if values.get(name) == value:
                    continue
            except ValueError:  # a tuple holding arrays: set_uniform compares the bytes
                pass
        _set_uniform(program, known, name, value, name in optional)


def _same(last, value) -> bool:
    try:
        return bool(last == value)
    except ValueError:  # a tuple holding arrays: leave it to the bytes
        return False


def _packed(uniform: moderngl.Uniform, value) -> bytes:
    """The bytes ``uniform.value = value`` writes (moderngl's own packing)."""
    if uniform.array_length > 1:
        if uniform.dimension > 1:
            return b"".join(struct.pack(uniform.fmt, *row) for row in value)
        return b"".join(struct.pack(uniform.fmt, item) for item in value)
    if uniform.dimension > 1:
        return struct.pack(uniform.fmt, *value)
    return struct.pack(uniform.fmt, value)


def _uniform_bytes(uniform: moderngl.Uniform, value: np.ndarray) -> bytes:
    dtype = {"f": np.float32, "d": np.float64, "i": np.int32, "I": np.uint32}.get(uniform.fmt[-1],
                                                                               np.float32)
    if uniform.matrix and value.ndim >= 2:
        value = np.swapaxes(value, -1, -2)  # numpy rows -> GL columns
    return np.ascontiguousarray(value, dtype=dtype).tobytes()


def _vertex_array(ctx: moderngl.Context, program: moderngl.Program) -> moderngl.VertexArray:
    return derived.value(program, "fullscreen vertex array", lambda: ctx.vertex_array(program, []), ctx=ctx)
