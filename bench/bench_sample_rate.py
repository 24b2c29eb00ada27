"""How close the RayCaster comes to what this machine's GL can do: samples per second of our
ray-casting loop against trivial shaders that only sample.

    .venv/bin/python bench/bench_sample_rate.py [--size 512] [--samples 256] [--repeat 5] [--formats]
                                                [--branches]

The machine's limit is measured with full-screen passes whose every pixel takes --samples
trilinear samples of the same 256^3 volume texture along an oblique line (one pixel, one line),
keeping nothing but a sum (so the compiler cannot drop the fetches):

- "fetch only": one trilinear fetch and an add per sample: the bare texture-sampling rate.
- "fetch + TF": the fetch, the 1D TF look-up and front-to-back compositing without early
  termination: the least work a DVR sample can be.

"ours" is the RayCaster (dvr, dense fog TF: opacity everywhere, so nothing is skipped and no ray
ends early; and the four rows of bench_vtk) on the same volume and image size: the samples it
evaluated (the depth output's sample counter, summed over the image) over the seconds of its pass
(EntryExitPoints cached, until glFinish). For the scenes with empty space the rate counts only the
samples evaluated, so it says how much work is left per second, not the frame rate.

--formats adds the "fetch only" rate of 256^3 textures of random values in the formats a volume
or a gradient volume could use (R16, R32F, RGBA8, RGBA16, RGBA16F): what one fetch costs by format.

--branches adds what code that no pixel needs costs: a full-screen pass with a chain of 40
dependent fetches, run always, inside an `if` that no pixel takes, after a `return` or a `discard`
that every pixel takes first, and inside a `while` whose condition no pixel meets, against a pass
that only writes a constant; and the RayCaster's pass (bonsai, composite) with a crop box that
leaves nothing, so that every ray misses. On a GPU the skipped forms cost about as little as the constant; on
llvmpipe (8 pixels per SIMD group, masks instead of jumps) they cost as much as running the code.

Both volumes of bench_vtk, with its settings for ours (derivatives = precomputed, volume_precision
= 16bit): the CT bonsai (uint8, uploaded as R16 unorm) and the signed-distance torus (float32,
sampled from its 16-bit copy, R16); the trivial passes sample the same R16 textures. Timings vary up to 2x on shared machines,
compare within one run: every table's passes are timed in alternation (bench/interleave.py: one
warm-up frame each, then --repeat rounds of one frame per pass), with min / median / max beside
each time. Prints a markdown table (also to --out if given).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_vtk import TORUS_MIP_TF, load_volume, scenes  # noqa: E402
from interleave import interleaved, spread  # noqa: E402
from raycaster_speed import FOG_TF, network  # noqa: E402

from vgraph.camera import Camera  # noqa: E402
from vgraph.gl_context import get_context  # noqa: E402
from vgraph.numerics.reference_raycast import volume_box  # noqa: E402
from vgraph.volume import Volume  # noqa: E402

VERTEX = """#version 330
in vec2 position;
void main() { gl_Position = vec4(position, 0.0, 1.0); }
"""
TRIVIAL = """#version 330
uniform sampler3D volume;
uniform sampler1D lut;
uniform int samples;
uniform vec2 viewport;
out vec4 color;
void main() {
    // An oblique line through the box per pixel, as a ray would run.
    vec2 p = gl_FragCoord.xy / viewport;
    vec3 start = vec3(p, 0.0);
    vec3 step = vec3(0.13, 0.07, 1.0) / float(samples);
    vec4 sum = vec4(0.0);
    for (int i = 0; i < samples; ++i) {
        float v = texture(volume, start + float(i) * step).r;
#ifdef CLASSIFY
        vec4 c = texture(lut, v);
        sum += (1.0 - sum.a) * vec4(c.rgb * c.a, c.a);
#else
        sum.r += v;
#endif
    }
    color = sum;
}
"""


class TrivialPass:
    """The trivial full-screen pass (module docstring) on ``volume``'s texture; calling it draws
    one frame and returns its seconds (until glFinish)."""

    def __init__(self, ctx, volume, size: int, samples: int, classify: bool):
        source = TRIVIAL.replace("#version 330", "#version 330\n#define CLASSIFY" if classify else "#version 330")
        self.ctx = ctx
        self.program = ctx.program(vertex_shader=VERTEX, fragment_shader=source)
        self.texture = volume.texture(ctx)
        self.texture.filter = (ctx.LINEAR, ctx.LINEAR)
        self.lut = ctx.texture((4096, 1), 4, np.linspace(0.0, 0.01, 4096 * 4, dtype=np.float32).tobytes(), dtype="f4")
        self.lut.filter = (ctx.LINEAR, ctx.LINEAR)
        self.target = ctx.texture((size, size), 4, dtype="f4")
        self.framebuffer = ctx.framebuffer(color_attachments=[self.target])
        self.quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], dtype="f4").tobytes())
        self.vao = ctx.vertex_array(self.program, [(self.quad, "2f", "position")])
        self.program["samples"].value = samples
        self.program["viewport"].value = (float(size), float(size))
        self.program["volume"].value = 0
        if "lut" in self.program:
            self.program["lut"].value = 1
        self.samples_per_frame = size * size * samples

    def __call__(self, _=None) -> float:
        self.texture.use(0)  # the passes alternate: bind this pass's own textures and target
        self.lut.use(1)
        self.framebuffer.use()
        start = time.perf_counter()
        self.vao.render(mode=self.ctx.TRIANGLE_STRIP)
        self.ctx.finish()
        return time.perf_counter() - start

    def release(self) -> None:
        for obj in (self.vao, self.quad, self.framebuffer, self.target, self.lut, self.program):
            obj.release()


FORMATS = {"R16": (1, "nu2", np.uint16), "R32F": (1, "f4", np.float32), "RGBA8": (4, "nu1", np.uint8),
           "RGBA16": (4, "nu2", np.uint16), "RGBA16F": (4, "f2", np.float16)}


class _RandomTexture:
    """Stands in for a Volume in TrivialPass: a 256^3 texture of random values in one format."""

    def __init__(self, components, dtype, numpy_type, size=256):
        rng = np.random.default_rng(0)
        values = rng.random(size ** 3 * components)
        if np.issubdtype(numpy_type, np.integer):
            values = values * np.iinfo(numpy_type).max
        self.data = values.astype(numpy_type)
        self.shape = (size, size, size, components, dtype)

    def texture(self, ctx):
        size, _, _, components, dtype = self.shape
        self.made = ctx.texture3d((size, size, size), components, self.data.tobytes(), dtype=dtype)
        self.data = None  # on the GL side now; five formats at once would hold 0.4 GB twice
        return self.made


def format_rows(ctx, args) -> list[str]:
    """The fetch-only pass on a random texture per format, the formats' frames interleaved."""
    textures = {name: _RandomTexture(*spec) for name, spec in FORMATS.items()}
    passes = {name: TrivialPass(ctx, texture, args.size, args.samples, classify=False)
              for name, texture in textures.items()}
    seconds, _ = interleaved(passes, [None] * args.repeat, None)
    rows = []
    for name, trivial in passes.items():
        rate = trivial.samples_per_frame / float(np.median(seconds[name]))
        rows.append(f"| random 256^3 ({name}) | fetch only | {spread(seconds[name])} | "
                    f"{args.samples} | {rate / 1e6:.0f} | |")
        trivial.release()
        textures[name].made.release()
    return rows


class OurPass:
    """The RayCaster's pass on ``volume`` in ``scene`` (EntryExitPoints cached); calling it draws
    one frame and returns its seconds (until glFinish)."""

    def __init__(self, volume: Volume, size: int, scene: dict, crop_box: tuple | None = None):
        camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.45, -0.35, -1.0))
        self.net = net = network(volume, camera)
        net.set("eep.crop_box", crop_box)
        net.set("rc.derivatives", "precomputed")  # bench_vtk's settings
        net.set("rc.volume_precision", "16bit")
        net.set("rc.compositing", scene["compositing"])
        net.set("rc.transfer_function", scene["tf"])
        net.set("rc.shading", "blinn_phong" if scene["shading"] else "none")
        self.ctx = get_context()
        self.shape = (size, size)

    def __call__(self, _=None) -> float:
        self.net.processors["rc"].invalidate()
        start = time.perf_counter()
        self.net.update("rc.image", size=self.shape)
        self.ctx.finish()
        return time.perf_counter() - start

    def samples(self) -> tuple[float, float]:
        """(samples the pass evaluated over the image, samples per covered pixel)."""
        depth = self.net.evaluate("rc.depth", size=self.shape)
        covered = self.net.evaluate("eep.entry", size=self.shape)[..., 3] > 0
        taken = float(depth[..., 2].sum())
        return taken, taken / max(int(covered.sum()), 1)


DEPENDENT_FETCHES = "\n".join(
    f"    sum += textureLod(volume, vec3(gl_FragCoord.xy / viewport, {i / 40:.3f}) + sum.xyz * 0.01, 0.0);"
    for i in range(40))
BRANCHES = {  # name -> main()'s body around the fetches (FETCHES); `never` is false for every pixel
    "constant only": "color = vec4(0.1);",
    "fetches, always": "vec4 sum = vec4(0.0);\nFETCHES\ncolor = sum;",
    "fetches in an if no pixel takes": "vec4 sum = vec4(0.0);\nif (never) {\nFETCHES\n}\ncolor = sum;",
    "fetches after a return every pixel takes": "vec4 sum = vec4(0.0);\nif (!never) { color = sum; return; }\n"
                                                "FETCHES\ncolor = sum;",
    "fetches after a discard every pixel takes": "vec4 sum = vec4(0.0);\nif (!never) discard;\nFETCHES\n"
                                                 "color = sum;",
    "fetches in a while no pixel enters": "vec4 sum = vec4(0.0);\nwhile (never) {\nFETCHES\nbreak;\n}\n"
                                          "color = sum;",
}


def branch_pass(ctx, quad, body: str, size: int):
    """(frame() -> seconds, program, vao) of one full-screen pass of BRANCHES."""
    source = ("#version 330\nuniform sampler3D volume;\nuniform vec2 viewport;\n"
              "uniform float threshold;\nout vec4 color;\nvoid main() {\n"
              "bool never = gl_FragCoord.x < threshold;\n"
              + body.replace("FETCHES", DEPENDENT_FETCHES) + "\n}\n")
    program = ctx.program(vertex_shader=VERTEX, fragment_shader=source)
    for uniform, value in (("viewport", (float(size),) * 2), ("threshold", -1.0), ("volume", 0)):
        if uniform in program:
            program[uniform].value = value
    vao = ctx.vertex_array(program, [(quad, "2f", "position")])

    def frame(_=None) -> float:
        start = time.perf_counter()
        vao.render(mode=ctx.TRIANGLE_STRIP)
        ctx.finish()
        return time.perf_counter() - start
    return frame, program, vao


def branch_rows(ctx, args, volume: Volume) -> list[str]:
    """Milliseconds of each pass of BRANCHES (module docstring) and of the RayCaster's pass
    (composite, on ``volume``) where every ray misses the box, all passes' frames interleaved."""
    data = np.random.default_rng(0).integers(0, 65535, 64 ** 3, dtype=np.uint16)
    texture = ctx.texture3d((64, 64, 64), 1, data.tobytes(), dtype="nu2")
    target = ctx.texture((args.size, args.size), 4, dtype="f4")
    framebuffer = ctx.framebuffer(color_attachments=[target])
    quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], dtype="f4").tobytes())
    made = {name: branch_pass(ctx, quad, body, args.size) for name, body in BRANCHES.items()}
    nowhere = (-2e9, -2e9, -2e9, -1e9, -1e9, -1e9)  # a crop box outside the volume: every ray misses
    missing = OurPass(volume, args.size, scenes("bonsai")["composite"], nowhere)

    def bound(frame):  # the RayCaster binds its own targets: rebind ours before each branch pass
        def run(_=None):
            texture.use(0)
            framebuffer.use()
            return frame()
        return run
    passes = {name: bound(frame) for name, (frame, _, _) in made.items()}
    passes["RayCaster, composite, every ray misses the box"] = missing
    seconds, _ = interleaved(passes, [None] * args.repeat, None)
    rows = ["", f"Code no pixel needs ({args.size}^2, {args.repeat} rounds, passes interleaved; "
            "min / median / max):", "", "| pass | ms |", "|---|---|"]
    rows += [f"| {name} | {spread([t * 1e3 for t in values], 2)} |" for name, values in seconds.items()]
    for _, program, vao in made.values():
        vao.release()
        program.release()
    for obj in (quad, framebuffer, target, texture):
        obj.release()
    return rows


def volume_rows(ctx, args, name: str, label: str) -> list[str]:
    """The trivial passes and our scenes on one volume, their frames interleaved round by round;
    rates from the median frame."""
    volume = load_volume(name, 256)
    sampled = volume.at_precision("16bit")  # what ours samples (bench_vtk's settings)
    scenes_of = {"ours, dense fog": dict(compositing="dvr", shading=False, tf=FOG_TF)}
    scenes_of.update({f"ours, {mode}": scene for mode, scene in scenes(name).items() if "fog" not in mode})
    if name == "torus":
        scenes_of["ours, MIP"] = dict(scenes_of["ours, MIP"], tf=TORUS_MIP_TF)
    trivial = {"fetch only": TrivialPass(ctx, sampled, args.size, args.samples, classify=False),
               "fetch + TF": TrivialPass(ctx, sampled, args.size, args.samples, classify=True)}
    ours = {row: OurPass(volume, args.size, scene) for row, scene in scenes_of.items()}
    seconds, _ = interleaved({**trivial, **ours}, [None] * args.repeat, None)
    median = {key: float(np.median(values)) for key, values in seconds.items()}
    limit = trivial["fetch only"].samples_per_frame / median["fetch only"]
    lines = []
    for key, pass_ in trivial.items():
        rate = pass_.samples_per_frame / median[key]
        lines.append(f"| {label} | {key} | {spread(seconds[key])} | {args.samples} | {rate / 1e6:.0f} | "
                     f"{rate / limit:.2f} |")
        pass_.release()
    for key, pass_ in ours.items():
        taken, per_pixel = pass_.samples()
        rate = taken / median[key]
        lines.append(f"| {label} | {key} | {spread(seconds[key])} | {per_pixel:.0f} | {rate / 1e6:.0f} | "
                     f"{rate / limit:.2f} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=256, help="samples per pixel of the trivial passes")
    parser.add_argument("--repeat", type=int, default=5, help="rounds of one frame per pass")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--formats", action="store_true", help="also the fetch rate of each texture format")
    parser.add_argument("--branches", action="store_true", help="also what code no pixel needs costs")
    args = parser.parse_args()
    ctx = get_context()
    lines = [f"{args.size}^2 image; trivial passes take {args.samples} samples per pixel; per volume one "
             f"warm-up frame per pass, then {args.repeat} rounds of one frame per pass in turn; seconds "
             "min / median / max, rates from the median",
             "", "| volume (texture) | pass | seconds | samples per pixel | million samples/s | share of fetch only |",
             "|---|---|---|---|---|---|"]
    for name, label in (("bonsai", "bonsai 256^3 uint8 (R16)"), ("torus", "torus 256^3 float32 (R16 copy)")):
        rows = volume_rows(ctx, args, name, label)
        lines.extend(rows)
        print("\n".join(rows), flush=True)
    if args.formats:
        lines.extend(format_rows(ctx, args))
    if args.branches:
        lines.extend(branch_rows(ctx, args, load_volume("bonsai", 256)))
    text = "\n".join(lines) + "\n"
    print("\n" + text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
