"""Fullscreen passes: run a fragment shader once per pixel of a target Image.

Conventions:
- The vertex stage is ``fullscreen.vert.glsl``: one triangle generated from gl_VertexID (no vertex
  buffer), giving ``in vec2 uv`` in [0, 1] with v = 0 at the bottom row (GL convention).
- Textures are bound to units 0, 1, ... in the order given and their sampler uniforms set to those
  units. Uniforms the program does not have (unused ones are optimised away by the compiler) are
  skipped.
- numpy uniform values are written in the uniform's own type; a 2D array for a matrix uniform is in
  mathematical (row-major) layout and is transposed to GL's column-major order.
- The pass uses the context's current enable flags (by default no depth test and no blending).
"""

from __future__ import annotations

import moderngl
import numpy as np

from vgraph.gl import context as gl_context
from vgraph.image import Image

FULLSCREEN_VERTEX_SHADER = "fullscreen.vert.glsl"

# One attribute-less vertex array per program; programs are compared by identity.
_vertex_arrays: dict[moderngl.Program, moderngl.VertexArray] = {}


def fullscreen_pass(ctx: moderngl.Context, program: moderngl.Program, target: Image,
                    textures: dict[str, object] | None = None,
                    uniforms: dict[str, object] | None = None) -> None:
    """Draw one fullscreen triangle with ``program`` into ``target``."""
    target.framebuffer.use()
    ctx.viewport = (0, 0, *target.size)
    for unit, (name, texture) in enumerate((textures or {}).items()):
        (texture.texture if isinstance(texture, Image) else texture).use(location=unit)
        set_uniform(program, name, unit)
    for name, value in (uniforms or {}).items():
        set_uniform(program, name, value)
    _vertex_array(ctx, program).render(moderngl.TRIANGLES, vertices=3)


def set_uniform(program: moderngl.Program, name: str, value) -> bool:
    """Set a uniform if the program has it; return whether it was set."""
    uniform = program.get(name, None)
    if not isinstance(uniform, moderngl.Uniform):
        return False
    if isinstance(value, np.ndarray):
        uniform.write(_uniform_bytes(uniform, value))
    elif isinstance(value, np.generic):
        uniform.value = value.item()
    else:
        uniform.value = value
    return True


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
