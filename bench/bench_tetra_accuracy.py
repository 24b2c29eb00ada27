"""ProjectedTetrahedra: error against frame time for every integration x visibility order (issue 30).

    .venv/bin/python bench/bench_tetra_accuracy.py [--size 256] [--repeat 3] [--meshes post disk grid c]
        [--out bench/results/tetra_accuracy.md] [--plot docs/images/tetra_error_time.png]

For each mesh and transfer function, every integration (averaged, preintegrated, partial) with
every visibility order (centroid, mpvo, mpvonc) is compared with the exact CPU reference
(vgraph.numerics.reference_tetra.render, same camera and size): PSNR over RGB in float (10 log10
(1 / mse), no 8-bit rounding) and the max error of any channel. The frame time is the best of
--repeat frames, each with the camera turned 0.01 rad from the last (so every frame sorts
again), including the sort, the draw and glFinish, not the read-back. Meshes:

- post: tet_lox_post/post.vtk, Pressure (shared data; 8,750 tetrahedra split from wedges);
- disk: hex_disk_out_ref/disk_out_ref.vtu, Temp (shared data; 44,832 tetrahedra from hexahedra);
- grid: a 6^3 blob as 625 tetrahedra, its scalar 0..100 (tests/test_projected_tetrahedra.py's
  stiff_mesh);
- c: the non-convex C of vgraph.mesh_shapes.c_shape (675 tetrahedra), seen through both arms.

Transfer functions: "ramp", the ray casters' default (TransferFunctionLut.DEFAULT); "spike", an
opacity spike to 0.9 whose base is 1 % of the value range wide (one data unit on the 0..100
grid), at the field's median, the colour turning across it. Prints the settings and a table;
--out also writes them as markdown, --plot PSNR against frame time, a panel per mesh and TF.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
INTEGRATIONS = ("averaged", "preintegrated", "partial")
ORDERS = ("centroid", "mpvo", "mpvonc")


def meshes(names):
    from vgraph.io.meshes import read_mesh
    from vgraph.mesh import TetMesh
    from vgraph.mesh_shapes import c_shape
    from vgraph.tetrahedralize import volume_tetrahedra
    from vgraph.camera import Camera
    from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
    for name in names:
        if name == "post":
            mesh = read_mesh(DATA / "tet_lox_post" / "post.vtk", array="Pressure")
            yield "post.vtk (Pressure)", mesh, DEFAULT_CAMERA
        elif name == "disk":
            mesh = read_mesh(DATA / "hex_disk_out_ref" / "disk_out_ref.vtu", array="Temp")
            yield "disk_out_ref.vtu (Temp)", mesh, DEFAULT_CAMERA
        elif name == "grid":
            n = 6
            z, y, x = np.mgrid[0:n, 0:n, 0:n] / (n - 1)
            data = np.exp(-((x - 0.45) ** 2 + (y - 0.5) ** 2 + (z - 0.55) ** 2) / 0.12).astype(np.float32)
            points, tets, voxels = volume_tetrahedra(data, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), None)
            yield "6^3 grid, 0..100", TetMesh(points, tets, data.reshape(-1)[voxels] * 100.0,
                                              reference_length=1.0), DEFAULT_CAMERA
        elif name == "c":
            mesh = c_shape()
            yield "C (non-convex)", mesh, Camera.looking_at_box(*mesh.box, direction=(-1.0, 0.2, -0.3))
        else:
            raise SystemExit(f"unknown mesh {name!r}: post, disk, grid or c")


def transfer_functions(mesh):
    from vgraph.gl.raycasting.components import TransferFunctionLut
    from vgraph.transfer_function import TransferFunction
    low, high = (float(v) for v in mesh.value_range)
    centre, half = float(np.median(mesh.scalars)), 0.005 * (high - low)
    spike = TransferFunction(space="data", points=[(centre - half, 1.0, 0.5, 0.2, 0.0), (centre, 1.0, 0.9, 0.3, 0.9),
                                                   (centre + half, 0.2, 0.5, 1.0, 0.0)])
    return {"ramp": TransferFunctionLut.DEFAULT, "spike": spike}


def psnr(image, reference) -> float:
    mse = float(np.mean((image[..., :3].astype(np.float64) - reference[..., :3]) ** 2))
    return math.inf if mse == 0.0 else 10.0 * math.log10(1.0 / mse)


def measure(mesh, camera, tf, reference, size, repeat, integration, order):
    from vgraph.processors.projected_tetrahedra import ProjectedTetrahedra
    from vgraph.gl_context import get_context
    ctx = get_context()
    processor = ProjectedTetrahedra(camera=camera, transfer_function=tf, integration=integration,
                                    visibility_order=order)
    processor.render_size = size
    image = processor.process(mesh)["image"].to_numpy()
    times = []
    for k in range(repeat):
        processor.camera = camera.rotate(0.01 * (k + 1), 0.0)
        start = time.perf_counter()
        processor.process(mesh)
        ctx.finish()
        times.append(time.perf_counter() - start)
    error = np.abs(image - reference)[..., :3]
    return psnr(image, reference), float(error.max()), min(times)


def plot(results, path: Path) -> None:
    """PSNR against frame time, a panel per (mesh, TF): colour = integration, marker = order."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    panels = list(dict.fromkeys((mesh, tf) for mesh, tf, *_ in results))
    columns = min(4, len(panels))
    rows = -(-len(panels) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 2.8 * rows), squeeze=False)
    colours = dict(zip(INTEGRATIONS, ("tab:orange", "tab:blue", "tab:green")))
    markers = dict(zip(ORDERS, ("o", "s", "^")))
    for axis, (mesh, tf) in zip(axes.ravel(), panels):
        for _, _, integration, order, db, seconds in (r for r in results if r[:2] == (mesh, tf)):
            axis.scatter(seconds * 1000, min(db, 130.0), color=colours[integration], marker=markers[order],
                         label=f"{integration}, {order}")
        axis.set_xscale("log")
        axis.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        axis.set_title(f"{mesh}, {tf}", fontsize=8)
        axis.set_xlabel("frame (ms)", fontsize=7)
        axis.set_ylabel("PSNR (dB)", fontsize=7)
        axis.tick_params(labelsize=7)
    for axis in axes.ravel()[len(panels):]:
        axis.axis("off")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="lower center", ncol=5, fontsize=7)
    figure.tight_layout(rect=(0, 0.08, 1, 1))
    from vgraph.atomic import atomic_path
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=100)
    plt.close(figure)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--meshes", nargs="+", default=["post", "disk", "grid", "c"])
    parser.add_argument("--out", type=Path)
    parser.add_argument("--plot", type=Path)
    args = parser.parse_args(argv)
    from vgraph.gl_context import get_context
    from vgraph.numerics import reference_tetra
    ctx = get_context()
    size = (args.size, args.size)
    lines = [f"settings: {args.size} x {args.size} pixels, best of {args.repeat} frames (each turned "
             f"0.01 rad: a new sort), GL: {ctx.info['GL_RENDERER']}; PSNR over RGB in float, max over "
             f"channels; exact reference vgraph.numerics.reference_tetra", "",
             "| mesh | tetrahedra | TF | integration | order | PSNR (dB) | max error | frame (ms) |",
             "|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    results = []  # (mesh, TF, integration, order, PSNR, seconds)
    for label, mesh, camera in meshes(args.meshes):
        for tf_name, tf in transfer_functions(mesh).items():
            reference = reference_tetra.render(mesh, camera, tf, size)
            for integration in INTEGRATIONS:
                for order in ORDERS:
                    db, worst, seconds = measure(mesh, camera, tf, reference, size, args.repeat,
                                                 integration, order)
                    line = (f"| {label} | {len(mesh.tets):,} | {tf_name} | {integration} | {order} | "
                            f"{db:.1f} | {worst:.2g} | {seconds * 1000:.0f} |")
                    lines.append(line)
                    results.append((label, tf_name, integration, order, db, seconds))
                    print(line, flush=True)
    if args.plot:
        plot(results, args.plot)
    if args.out:
        from vgraph.atomic import atomic_path
        with atomic_path(args.out) as temporary:
            temporary.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
