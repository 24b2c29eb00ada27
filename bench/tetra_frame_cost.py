"""Where a ProjectedTetrahedra frame's time goes (issue #31, item 2): each stage timed by itself.

    .venv/bin/python bench/tetra_frame_cost.py [--sizes 64 128x128x58 256x128x64] [--size 512]
        [--repeat 5] [--variants "cells averaged" ...] [--with-depth] [--baseline COMMIT ...]

The meshes, transfer function, cameras and variants are bench_tetra.py's (the culled bonsai
meshes: 111 k, 354 k and 820 k tetrahedra at the default sizes; "cells averaged", "cells
preintegrated", "tets preintegrated"). A frame is bench_tetra's (camera set, network update,
glFinish) and then a read-back of the image, which bench_tetra's frame does not include. The GL
calls a frame makes are wrapped so that each stage is timed alone: glFinish before and after it, so
no stage's work spills into the next (which makes the stages add up to a little more than a frame
without the wrapping). Stages:

- clear: the two render targets cleared (image, depth);
- order: the visibility order (numpy sweep or sort; the GL sort for centroid_gl);
- upload: index or vertex buffers written or created;
- draw: the draw call (vertex, geometry and fragment stages, blending);
- tables: the transfer function's LUT or pre-integrated table (rebuilt only when it changes);
- Python in process: the rest of ProjectedTetrahedra.process (camera, uniforms, program lookup);
- scheduler: the network's update around process;
- read-back: the image read to numpy.

Variants alternate frame by frame (bench/interleave.py: a warm-up frame each, then one frame per
variant per round, each round a new camera); min / median over the rounds per stage.

--with-depth adds, per variant, the same processor's frames with its depth output read as well
(the on-demand depth drawn: a second render target). --baseline COMMIT ... adds, per variant and
commit, the same frames drawn by vgraph as it was at COMMIT (``git archive`` of src/vgraph,
processors and shaders into a temporary folder, run in a spawned worker process driven frame by frame, so the codes alternate
in the same rounds): before / after of a change, measured as every comparison in the benches is.
A worker times whole frames only (with the read-back). The last column is, for those rows, their
frame over the plain variant's in the same round: median (min-max).

--draw-parts splits the cells path's draw (the one GL pass, image only) by drawing the same cells
with cut-down fragment shaders, alternating with the real one: "geometry + raster" (the fragment
stage writes a constant: vertex and geometry stages, rasterising the cells' rectangles, blending),
"+ ray set-up" (the pixel's ray against the cell and its central tetrahedron, then a constant), and
the full shader (+ the pieces' integration).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
STAGES = ("clear", "order", "upload", "draw", "tables", "Python in process", "scheduler", "read-back")


class StageClock:
    """Wraps the GL and order calls a frame makes so that each is timed alone (glFinish around it);
    ``seconds`` holds the current frame's total per stage."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.seconds = dict.fromkeys(STAGES, 0.0)
        self._depth = 0
        self.made = {}  # id(program) -> (vertex, fragment, geometry, defines) it was composed from

    def timed(self, stage: str, function):
        clock = self

        def wrapper(*args, **kwargs):
            if clock._depth:  # inside another timed call: counted there
                return function(*args, **kwargs)
            clock.ctx.finish()
            clock._depth += 1
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                clock.ctx.finish()
                clock.seconds[stage] += time.perf_counter() - start
                clock._depth -= 1
        return wrapper

    def install(self) -> None:
        import moderngl

        from vgraph.gl.tetrahedra import order
        from vgraph.gl.tetrahedra.gl_sort import GLCentroidSort
        from vgraph.processors import projected_tetrahedra as pt
        patches = [(moderngl.Framebuffer, "clear", "clear"), (order.VisibilityOrder, "update", "order"),
                   (GLCentroidSort, "sort", "order"), (moderngl.Buffer, "write", "upload"),
                   (moderngl.Context, "buffer", "upload"), (moderngl.VertexArray, "render", "draw"),
                   (pt.PreintegrationTable, "update", "tables"),
                   (pt.PartialPreintegrationTables, "update", "tables"),
                   (pt.TransferFunctionTexture, "update", "tables")]
        for owner, name, stage in patches:
            setattr(owner, name, self.timed(stage, getattr(owner, name)))
        from vgraph.gl.shaders import programs
        program = programs.program

        def remembered(ctx, vertex, fragment, defines=None, processor=None, geometry=None, includes=()):
            made = program(ctx, vertex, fragment, defines, processor, geometry, includes)
            self.made[id(made)] = (vertex, fragment, geometry, dict(defines or {}))
            return made
        programs.program = remembered
        process = pt.ProjectedTetrahedra.process

        def timed_process(processor, *args, **kwargs):
            start = time.perf_counter()
            try:
                return process(processor, *args, **kwargs)
            finally:
                self.process_seconds = time.perf_counter() - start
        pt.ProjectedTetrahedra.process = timed_process

    def frame(self, network, pid: str, size: int, with_depth: bool = False):
        """A frame of processor ``pid`` with its stages: camera -> (seconds, stage seconds)."""
        targets = [f"{pid}.image", f"{pid}.depth"] if with_depth else [f"{pid}.image"]

        def frame(camera):
            self.seconds = dict.fromkeys(STAGES, 0.0)
            network.set(f"{pid}.camera", camera)
            network.invalidate_downstream(pid)
            self.ctx.finish()
            start = time.perf_counter()
            network.update(*targets, size=(size, size))
            self.ctx.finish()
            updated = time.perf_counter()
            network.output(f"{pid}.image").to_numpy()
            end = time.perf_counter()
            stages = dict(self.seconds)
            inside = sum(stages.values())
            stages["Python in process"] = max(self.process_seconds - inside, 0.0)
            stages["scheduler"] = max(updated - start - self.process_seconds, 0.0)
            stages["read-back"] = end - updated
            return end - start, stages
        return frame


# --- the code as it was at a commit, in a worker process --------------------------------------------
def baseline_worker(connection, source: str, dims, size: int):
    """Worker: vgraph from ``source`` (a src folder); answers a camera tuple and a variant with the
    seconds of a whole frame (update, glFinish, read-back); None ends it."""
    sys.path.insert(0, source)
    import vgraph
    import vgraph.processors.projected_tetrahedra as drawn
    from vgraph.gl.shaders import find_shader
    for path in (vgraph.__file__, drawn.__file__, find_shader("tetrahedra/cells.frag.glsl")):
        assert str(Path(path).resolve()).startswith(str(Path(source).parent)), path
    import bench_tetra as bt
    from vgraph.camera import Camera
    from vgraph.gl_context import get_context
    ctx = get_context()
    network = bt.speed_network(bt.bonsai_volume(dims))
    connection.send("ready")
    while (message := connection.recv()) is not None:
        fields, variant = message
        pid = variant.replace(" ", "_")
        network.set(f"{pid}.camera", Camera.model_validate(fields))
        network.invalidate_downstream(pid)
        ctx.finish()
        start = time.perf_counter()
        network.update(f"{pid}.image", size=(size, size))
        ctx.finish()
        network.output(f"{pid}.image").to_numpy()
        connection.send(time.perf_counter() - start)


class Baseline:
    """vgraph at ``commit`` drawing the same frames in a spawned process."""

    def __init__(self, commit: str, dims, size: int):
        self.folder = tempfile.TemporaryDirectory(prefix="vgraph-baseline-")
        # src/vgraph/processors and src/vgraph/shaders are links to the top-level folders: without
        # them the links dangle and vgraph's editable install finds the working tree's instead
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "src/vgraph", "processors", "shaders"],
                                 check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", self.folder.name], input=archive, check=True)
        context = multiprocessing.get_context("spawn")
        self.connection, theirs = context.Pipe()
        self.process = context.Process(target=baseline_worker, daemon=True, args=(
            theirs, str(Path(self.folder.name) / "src"), dims, size))
        self.process.start()
        if not self.connection.poll(600) or self.connection.recv() != "ready":
            raise RuntimeError("the baseline's worker did not start")

    def frame(self, variant: str):
        def frame(camera):
            self.connection.send((camera.model_dump(), variant))
            return self.connection.recv(), {}
        return frame

    def close(self) -> None:
        self.connection.send(None)
        self.process.join(60)
        self.folder.cleanup()


def measure(clock: StageClock, dims, args) -> tuple[int, dict]:
    """(culled tetrahedra, variant -> list of (seconds, stages) per round)."""
    import bench_tetra as bt
    from interleave import interleaved
    network = bt.speed_network(bt.bonsai_volume(dims))
    mesh = network.output("tets.mesh")
    cams = bt.cameras(mesh, args.repeat)
    frames, records = {}, {}
    baselines = [Baseline(commit, dims, args.size) for commit in args.baseline or ()]
    for variant in args.variants:
        frames[variant] = clock.frame(network, variant.replace(" ", "_"), args.size)
        if args.with_depth:  # its own processor: switching one would reallocate its targets each frame
            pid = with_depth_copy(network, variant.replace(" ", "_"))
            frames[f"{variant} + depth"] = clock.frame(network, pid, args.size, True)
        for commit, baseline in zip(args.baseline or (), baselines):
            frames[f"{variant} @ {commit}"] = baseline.frame(variant)
    try:
        recorded = {name: (lambda f, n: lambda camera: _record(records, n, f(camera)))(f, name)
                    for name, f in frames.items()}
        interleaved(recorded, cams, cams[0].rotate(1.0, 0.0))
    finally:
        for baseline in baselines:
            baseline.close()
    if args.draw_parts:
        for variant in (v for v in args.variants if v.startswith("cells")):
            for part, seconds in draw_parts(clock, network, variant, args.size, args.repeat).items():
                records[f"{variant}: {part}"] = [(0.0, {})] + [(t, {}) for t in seconds]
    return len(mesh.tets), {name: rows[1:] for name, rows in records.items()}  # without the warm-up


DRAW_PARTS = {"geometry + raster": ("void main() {", "void main() {\n    color = vec4(1e-3); return;"),
              "+ ray set-up": ("    color = vec4(0.0);\n", "    color = vec4(1e-3); return;\n"),
              "full draw": ("", "")}


def draw_parts(clock: StageClock, network, variant: str, size: int, rounds: int) -> dict:
    """Seconds of the cells draw of ``variant`` (after a frame) with each of DRAW_PARTS' fragment
    shaders, alternating: part -> list of seconds."""
    import moderngl

    from vgraph.gl.passes import bind_textures, set_uniform
    from vgraph.gl.shaders import compose
    ctx = clock.ctx
    processor = network.processors[variant.replace(" ", "_")]
    (program, vertex_array), = processor._draw_state["arrays"].items()
    vertex, fragment, geometry, defines = clock.made[id(program)]
    texts = {"vertex": compose(vertex, defines).text, "fragment": compose(fragment, defines).text,
             "geometry": compose(geometry, defines).text}
    mesh = network.output("tets.mesh")
    textures = processor._table.textures if processor.integration == "preintegrated" else \
        {"transfer_function": processor._lut.update(ctx, processor.transfer_function, mesh)}
    draws = {}
    for part, (old, new) in DRAW_PARTS.items():
        fragment = texts["fragment"]
        assert old in fragment, (part, old)
        cut = ctx.program(vertex_shader=texts["vertex"], geometry_shader=texts["geometry"],
                          fragment_shader=fragment.replace(old, new, 1) if old else fragment)
        for name in program:
            if isinstance(program[name], moderngl.Uniform) and name in cut and program[name].array_length == 1 \
                    and program[name].dimension > 0 and name not in ("transfer_function", "preintegrated",
                                                                    "mean_extinction"):
                set_uniform(cut, name, program[name].value)
        draws[part] = (cut, ctx.vertex_array(cut, vertex_array._content, index_buffer=vertex_array._index_buffer,
                                             index_element_size=4, skip_errors=True))
    framebuffer = processor._targets[False].framebuffer
    seconds = {part: [] for part in draws}
    for _ in range(rounds + 1):
        for part, (cut, array) in draws.items():
            bind_textures(cut, textures)
            framebuffer.use()
            framebuffer.clear(0.0, 0.0, 0.0, 0.0)
            ctx.viewport = (0, 0, size, size)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA
            ctx.finish()
            start = time.perf_counter()
            array.render(moderngl.POINTS)
            ctx.finish()
            seconds[part].append(time.perf_counter() - start)
            ctx.blend_func = moderngl.DEFAULT_BLENDING
            ctx.disable(moderngl.BLEND)
    return {part: values[1:] for part, values in seconds.items()}  # without the warm-up round


def with_depth_copy(network, pid: str) -> str:
    """A second ProjectedTetrahedra with the settings of ``pid`` on the same mesh; its id."""
    copy = f"{pid}_depth"
    original = network.processors[pid]
    network.add("ProjectedTetrahedra", id=copy, **{name: getattr(original, name) for name in
                                                   ("transfer_function", "integration", "grid_cells")})
    network.connect("tets.mesh", f"{copy}.mesh")
    return copy


def _record(records: dict, name: str, result) -> float:
    records.setdefault(name, []).append(result)
    return result[0]


def table(results) -> list[str]:
    lines = ["| mesh | tetrahedra | variant | frame (ms) | " + " | ".join(STAGES) + " | frame / plain variant's |",
             "|---|---|---|---|" + "---|" * len(STAGES) + "---|"]
    for dims, tets, records in results:
        for name, rows in records.items():
            seconds = np.array([r[0] for r in rows])
            cells = [_pair(np.array([r[1].get(s, np.nan) for r in rows])) for s in STAGES]
            plain = name.split(" @ ")[0].split(": ")[0].removesuffix(" + depth")
            ratios = seconds / np.array([r[0] for r in records[plain]])
            ratio = "" if plain == name else f"{np.median(ratios):.2f} ({ratios.min():.2f}-{ratios.max():.2f})"
            lines.append(f"| {'x'.join(map(str, dims))} | {tets:,} | {name} | {_pair(seconds)} | "
                         + " | ".join(cells) + f" | {ratio} |")
    return lines


def _pair(values: np.ndarray) -> str:
    """'min / median' in milliseconds."""
    if np.all(np.isnan(values)):
        return "-"
    return f"{np.nanmin(values) * 1e3:.1f} / {np.nanmedian(values) * 1e3:.1f}"


def main() -> None:
    import bench_tetra as bt
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["64", "128x128x58", "256x128x64"])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--variants", nargs="+", default=list(bt.OURS), choices=list(bt.OURS))
    parser.add_argument("--draw-parts", action="store_true", help="split the cells draw by cut-down shaders")
    parser.add_argument("--with-depth", action="store_true", help="also each variant with its depth output read")
    parser.add_argument("--baseline", nargs="+", help="commits whose vgraph draws the same frames, alternating")
    args = parser.parse_args()
    from vgraph.gl_context import get_context
    clock = StageClock(get_context())
    clock.install()
    results = []
    for text in args.sizes:
        dims = bt.parse_dims(text)
        tets, records = measure(clock, dims, args)
        results.append((dims, tets, records))
    print(f"# ProjectedTetrahedra frame cost ({' '.join(sys.argv[1:]) or 'defaults'}), {args.size}^2, "
          f"{args.repeat} rounds; min / median ms; stages timed alone (glFinish around each); "
          f"load average before: {os.getloadavg()[0]:.1f}\n")
    print("\n".join(table(results)))


if __name__ == "__main__":
    main()
