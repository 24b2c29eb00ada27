"""ProjectedTetrahedra (Shirley & Tuchman 1990, Monsalve 2016): projection classes, visibility
order, both integrations against closed forms and a CPU reference, the shared mesh, and the
geometry stage of the program cache it needs."""

from __future__ import annotations

import pytest

from vgraph.errors import ShaderError
from vgraph.gl.shaders import ProgramCache

# --- the program cache's optional geometry stage ---------------------------------------------------
_VERT = "#version 330\nvoid main() { gl_Position = vec4(0.0, 0.0, 0.0, 1.0); }\n"
_GEOM = ("#version 330\nlayout(points) in;\nlayout(triangle_strip, max_vertices = 3) out;\n"
         "uniform float size;\n"
         "void main() {\n  gl_Position = vec4(-size, -size, 0.0, 1.0); EmitVertex();\n"
         "  gl_Position = vec4(size, -size, 0.0, 1.0); EmitVertex();\n"
         "  gl_Position = vec4(0.0, size, 0.0, 1.0); EmitVertex();\n  EndPrimitive();\n}\n")
_FRAG = "#version 330\nout vec4 color;\nvoid main() { color = vec4(COLOR); }\n"


def test_program_cache_compiles_a_geometry_stage_once_per_define_set(gl, tmp_path):
    for name, text in (("a.vert.glsl", _VERT), ("a.geom.glsl", _GEOM), ("a.frag.glsl", _FRAG),
                       ("bad.geom.glsl", _GEOM.replace("EndPrimitive();", "EndPrimitive()"))):
        (tmp_path / name).write_text(text)
    vert, geom, frag = (str(tmp_path / n) for n in ("a.vert.glsl", "a.geom.glsl", "a.frag.glsl"))
    cache = ProgramCache()
    try:
        with_geometry = cache.program(gl, vert, frag, {"COLOR": "1.0"}, geometry=geom)
        assert cache.program(gl, vert, frag, {"COLOR": "1.0"}, geometry=geom) is with_geometry
        assert cache.compile_count == 1
        without = cache.program(gl, vert, frag, {"COLOR": "1.0"})  # another program: no geometry
        assert without is not with_geometry and cache.compile_count == 2
        assert "size" in cache.source_of(with_geometry).declared  # the geometry stage's uniforms count
        assert cache.source_of(with_geometry).files[1].endswith("a.geom.glsl")
        with pytest.raises(ShaderError) as error:
            cache.program(gl, vert, frag, {"COLOR": "1.0"}, geometry=str(tmp_path / "bad.geom.glsl"),
                          processor="P")
        assert error.value.file.endswith("bad.geom.glsl") and "geometry" in str(error.value)
        # It draws: the triangle covers the centre of a small target.
        target = gl.simple_framebuffer((8, 8))
        target.use()
        target.clear()
        with_geometry["size"].value = 0.9
        gl.vertex_array(with_geometry, []).render(mode=0, vertices=1)  # GL_POINTS
        assert target.read(components=4)[4 * (4 * 8 + 4)] == 255
    finally:
        cache.clear()
