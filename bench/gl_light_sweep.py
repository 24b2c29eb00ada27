"""The light volume's sweep as a GL pass per slice, the alternative bench_shadows.py times against
vgraph's numpy sweep (vgraph.numerics.light_volume).

Each slice is one fullscreen pass into a float texture: it reads the previous slice's optical
depth (ping-pong 2D textures, linear filter) and the extinction of both slices from a 3D R32F
texture, tau = tau_up + l (sigma + sigma_up) / 2 at the point the light comes from, and writes the
new optical depth, which is read back into the numpy result (the light volume is a Volume, held in
memory); where that point is beyond the slice, the light entered through a side face at d < l:
tau = sigma d. The voxels are classified first (vgraph.numerics.light_volume.extinction). This was
vgraph's first numpy sweep, pass for pass: resampling the optical depth at every slice blurs thin
shadows, which the sheared grids of the library's sweep avoid. Kept in bench/ for the comparison
(docs/reports/performance.md, "Volumetric shadows").
"""

from __future__ import annotations

import numpy as np

from vgraph.gl_context import get_context
from vgraph.numerics.light_volume import Sweep

VERTEX = """#version 330
in vec2 position;
void main() { gl_Position = vec4(position, 0.0, 1.0); }
"""
FRAGMENT = """#version 330
uniform sampler2D depth_before;  // optical depth of the slice before (linear filter)
uniform sampler3D sigma;         // extinction, slices in sweep order along z (linear filter)
uniform int slice;
uniform vec2 offset;             // where the light comes from, in voxels (columns, rows)
uniform float step_length;       // world units between two slices along the light
uniform vec2 size;               // columns, rows
uniform float slices;
out float depth;

float steps_to_side(float p, float move, float n) {
    return move > 0.0 ? (n - 1.0 - p) / move : (move < 0.0 ? p / -move : 1e30);
}

void main() {
    vec2 p = floor(gl_FragCoord.xy);
    float here = texelFetch(sigma, ivec3(p, slice), 0).r;
    float side = min(steps_to_side(p.x, offset.x, size.x), steps_to_side(p.y, offset.y, size.y));
    if (side < 1.0) {  // the light enters through a side face within one step
        depth = side * step_length * here;
        return;
    }
    vec2 up = (p + offset + 0.5) / size;
    float before = texture(depth_before, up).r;
    float sigma_before = texture(sigma, vec3(up, (float(slice) - 0.5) / slices)).r;
    depth = before + step_length * 0.5 * (here + sigma_before);
}
"""


class GlSweep:
    """The sweep on the GL context; ``transmittance`` has the numpy one's arguments and result."""

    def __init__(self):
        self.ctx = get_context()
        self.program = self.ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
        quad = np.array([-1, -1, 3, -1, -1, 3], dtype="f4")
        self.vao = self.ctx.vertex_array(self.program, [(self.ctx.buffer(quad.tobytes()), "2f", "position")])

    def transmittance(self, sigma: np.ndarray, spacing, light: np.ndarray) -> np.ndarray:
        ctx, sweep = self.ctx, Sweep.of(spacing, light)
        stack = np.ascontiguousarray(sweep.stack(sigma), dtype=np.float32)
        slices, rows, columns = stack.shape
        volume = ctx.texture3d((columns, rows, slices), 1, stack.tobytes(), dtype="f4")
        planes = [ctx.texture((columns, rows), 1, dtype="f4") for _ in range(2)]
        for texture in (volume, *planes):
            texture.repeat_x = texture.repeat_y = False
        volume.repeat_z = False
        frames = [ctx.framebuffer(color_attachments=[plane]) for plane in planes]
        out = np.empty_like(stack)
        out[0] = 0.0
        planes[0].write(out[0].tobytes())
        self.program["offset"].value = (sweep.offset[1], sweep.offset[0])
        self.program["step_length"].value = sweep.length
        self.program["size"].value = (columns, rows)
        self.program["slices"].value = slices
        self.program["depth_before"].value = 0
        self.program["sigma"].value = 1
        volume.use(1)
        try:
            for n in range(1, slices):
                before, target = planes[(n - 1) % 2], frames[n % 2]
                before.use(0)
                self.program["slice"].value = n
                target.use()
                ctx.viewport = (0, 0, columns, rows)
                self.vao.render(vertices=3)
                out[n] = np.frombuffer(target.read(components=1, dtype="f4"), dtype=np.float32).reshape(rows, columns)
        finally:
            for thing in (volume, *planes, *frames):
                thing.release()
        np.exp(-out, out=out)
        return sweep.unstack(out)
