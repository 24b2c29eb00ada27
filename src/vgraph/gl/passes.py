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
  uniform either always through ``set_uniform`` or never.
- The pass uses the context's current enable flags (by default no depth test and no blending).
"""

from __future__ import annotations

import struct

import moderngl
import numpy as np

from vgraph.errors import ShaderError
from vgraph.gl import context as gl_context
from vgraph.gl.shaders import programs
from vgraph.image import Image

FULLSCREEN_VERTEX_SHADER = "fullscreen.vert.glsl"

# One attribute-less vertex array per program; programs are compared by identity.
_vertex_arrays: dict[moderngl.Program, moderngl.VertexArray] = {}


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


def set_uniform(program: moderngl.Program, name: str, value, optional: bool = False) -> bool:
    """Set a uniform; return whether the program uses it. ShaderError if the program's sources do
    not declare ``name`` at all, unless ``optional`` (see the module docstring)."""
    uniform = program._members.get(name)  # Program.get, without a Python call per uniform
    if type(value) in _PLAIN and _same(getattr(uniform, "_vgraph_value", None), value):
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
    if getattr(uniform, "_vgraph_written", None) != data:
        uniform.write(data)
        uniform._vgraph_written = data
    uniform._vgraph_value = value if type(value) in _PLAIN else None
    return True


def set_uniforms(program: moderngl.Program, uniforms, optional=frozenset()) -> None:
    """set_uniform for each (name, value), in one loop: a frame sets some 90 uniforms, most of them
    unchanged, and a call apiece was the larger part of their cost."""
    members = program._members
    for name, value in uniforms.items():
        if type(value) in _PLAIN:
            try:
                if getattr(members.get(name), "_vgraph_value", None) == value:
                    continue
            except ValueError:  # a tuple holding arrays: set_uniform compares the bytes
                pass
        set_uniform(program, name, value, optional=name in optional)


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
    vao = _vertex_arrays.get(program)
    if vao is None:
        _forget_released_programs()
        vao = _vertex_arrays[program] = ctx.vertex_array(program, [])
    return vao


def _forget_released_programs() -> None:
    for program in [p for p in _vertex_arrays if isinstance(p.mglo, moderngl.InvalidObject)]:
        _vertex_arrays.pop(program).release()


def _forget_context(ctx: moderngl.Context) -> None:
    for program in [p for p in _vertex_arrays if p.ctx is ctx]:
        _vertex_arrays.pop(program).release()


gl_context.on_release(_forget_context)
