"""Projected tetrahedra: ours against VTK, and error against run time (Monsalve 2016 tables 4-6
redone on this machine; issue #13's benchmarks).

    .venv/bin/python bench/bench_tetra.py [--sizes 64 128x128x58 256x128x64 256] [--size 512]
        [--repeat 3] [--out bench/results] [--accuracy-grid 32] [--skip-vtk] [--max-tetrahedra N]

Meshes are made from the CT bonsai (256^3, shared/data) by taking every k-th voxel (64^3 is the
seed's "fuel" size, 5 tetrahedra per cell: 1.25 M tetrahedra), with and without VolumeToTetMesh's
culling of cells the transfer function leaves transparent (VTK does not cull, so it also gets the
culled mesh, made by us, for the second comparison). Our renderer also skips transparent
tetrahedra by itself (ProjectedTetrahedra.skip_transparent, on by default), so its "none" row is
culled at draw time. Ours draws these meshes cell by cell (grid_cells, the default for meshes cut
from a volume) and, for comparison, tetrahedron by tetrahedron (grid_cells off, centroid sort). For each mesh, image size and integration mode the best of
--repeat frames is timed (a frame: camera set, render, glFinish / WaitForCompletion, no read-back;
each frame turns the camera so no renderer reuses a sort). VTK runs vtkProjectedTetrahedraMapper
and vtkUnstructuredGridVolumeZSweepMapper in a spawned worker process (VTK and our EGL context do
not share a process), with the same points, tetrahedra, scalars, TF (data units, opacity unit
distance = the mesh's reference length), camera and image size.

Accuracy: on a small mesh (--accuracy-grid voxels per axis) every renderer's image is compared with
the exact CPU reference (vgraph.numerics.reference_tetra) by PSNR over RGB in 8 bits and the max
error, and plotted against frame time: averaged and pre-integrated projection, the RayCaster on the
same volume at several sampling rates (which differs from the mesh by trilinear vs linear
interpolation), and VTK's two mappers.

Writes bench/results/tetra.md (tables) and tetra_accuracy.png (error against time).
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
BONSAI = ROOT.parent / "shared" / "data" / "ct_bonsai" / "bonsai.nii.gz"


def parse_dims(text: str) -> tuple[int, int, int]:
    parts = [int(v) for v in text.lower().split("x")]
    return tuple(parts * 3) if len(parts) == 1 else tuple(parts)


def bonsai_volume(dims):
    """Every k-th voxel of the bonsai per axis, cropped about the centre to ``dims`` (x, y, z)."""
    from vgraph.io import read_volume
    volume = read_volume(BONSAI)
    data = volume.data
    steps = [max(1, data.shape[2 - a] // dims[a]) for a in range(3)]
    sub = data[::steps[2], ::steps[1], ::steps[0]]
    starts = [(sub.shape[2 - a] - dims[a]) // 2 for a in range(3)]
    sub = sub[starts[2]:starts[2] + dims[2], starts[1]:starts[1] + dims[1], starts[0]:starts[0] + dims[0]]
    spacing = tuple(float(volume.spacing[a] * steps[a]) for a in range(3))
    return volume.with_data(np.ascontiguousarray(sub), spacing=spacing)


def transfer_function():
    from vgraph.transfer_function import TransferFunction
    return TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 0.0), (0.35, 0.45, 0.3, 0.15, 0.0),
                                    (0.5, 0.75, 0.55, 0.3, 0.15), (0.8, 0.95, 0.9, 0.8, 0.6),
                                    (1.0, 1.0, 1.0, 1.0, 0.9)])


def mesh_network(volume, culling: str, integration: str):
    from vgraph.network import Network
    from vgraph.testing import GivenVolume
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("VolumeToTetMesh", id="tets", culling=culling, transfer_function=transfer_function())
    network.add("ProjectedTetrahedra", id="pt", transfer_function=transfer_function(), integration=integration)
    network.connect("src.volume", "tets.volume")
    network.connect("tets.mesh", "pt.mesh")
    return network


def cameras(mesh, count: int):
    from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
    base = DEFAULT_CAMERA.resolved(*mesh.box, 1.0)
    return [base.rotate(0.05 * k, 0.0).resolved(*mesh.box, 1.0) for k in range(count)]


def time_ours(network, cams, size: int) -> tuple[float, np.ndarray]:
    from vgraph.gl_context import get_context
    ctx = get_context()
    network.set("pt.camera", cams[0].rotate(1.0, 0.0))  # warm up: programs, tables, buffers
    network.update("pt.image", size=(size, size))
    best = np.inf
    for camera in cams:
        network.set("pt.camera", camera)
        network.invalidate_downstream("pt")  # the same camera twice must still render
        start = time.perf_counter()
        network.update("pt.image", size=(size, size))
        ctx.finish()
        best = min(best, time.perf_counter() - start)
    return best, network.output("pt.image").to_numpy()


# --- VTK, in its own process -------------------------------------------------------------------------
def vtk_frames(connection, points, tets, scalars, value_range, reference_length, tf_points, cams, size, kind):
    """Worker: render the mesh with a VTK mapper for each camera; send (best seconds, RGBA image)."""
    import os
    os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"  # headless, before VTK loads
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
    grid = vtk.vtkUnstructuredGrid()
    vtk_points = vtk.vtkPoints()
    vtk_points.SetData(numpy_to_vtk(points.astype(np.float32), deep=True))
    grid.SetPoints(vtk_points)
    cells = np.hstack([np.full((len(tets), 1), 4), tets]).astype(np.int64).ravel()
    cell_array = vtk.vtkCellArray()
    cell_array.SetCells(len(tets), numpy_to_vtkIdTypeArray(cells, deep=True))
    grid.SetCells(vtk.VTK_TETRA, cell_array)
    array = numpy_to_vtk(scalars.astype(np.float32), deep=True)
    array.SetName("s")
    grid.GetPointData().SetScalars(array)
    lo, hi = value_range
    colour, opacity = vtk.vtkColorTransferFunction(), vtk.vtkPiecewiseFunction()
    for position, r, g, b, a in tf_points:
        colour.AddRGBPoint(lo + position * (hi - lo), r, g, b)
        opacity.AddPoint(lo + position * (hi - lo), a)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(colour)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(reference_length)
    prop.SetInterpolationTypeToLinear()
    mapper = (vtk.vtkProjectedTetrahedraMapper() if kind == "pt" else vtk.vtkUnstructuredGridVolumeZSweepMapper())
    mapper.SetInputData(grid)
    actor = vtk.vtkVolume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)
    renderer = vtk.vtkRenderer()
    renderer.AddVolume(actor)
    renderer.SetBackground(0, 0, 0)
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.AddRenderer(renderer)
    window.SetSize(size, size)
    best = np.inf
    for position, focus, up, fov, near, far in cams:
        camera = renderer.GetActiveCamera()
        camera.SetPosition(*position)
        camera.SetFocalPoint(*focus)
        camera.SetViewUp(*up)
        camera.SetViewAngle(fov)
        camera.SetClippingRange(near, far)
        start = time.perf_counter()
        window.Render()
        window.WaitForCompletion()
        best = min(best, time.perf_counter() - start)
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.SetInputBufferTypeToRGBA()
    grab.Update()
    from vtk.util.numpy_support import vtk_to_numpy
    image = vtk_to_numpy(grab.GetOutput().GetPointData().GetScalars()).reshape(size, size, 4)[::-1]
    connection.send((best, image.astype(np.float32) / 255.0))


def time_vtk(kind, mesh, tf, cams, size):
    context = multiprocessing.get_context("spawn")
    ours, theirs = context.Pipe()
    cam_tuples = [(c.position, c.focus, c.up, c.fov, c.near, c.far) for c in cams]
    worker = context.Process(target=vtk_frames, args=(theirs, mesh.points, mesh.tets, mesh.scalars,
                                                      mesh.value_range, mesh.opacity_length,
                                                      tf.for_volume(mesh).points, cam_tuples, size, kind))
    worker.start()
    result = ours.recv() if ours.poll(3600) else (np.nan, None)
    worker.join(60)
    return result


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    a8 = np.round(np.clip(a[..., :3], 0, 1) * 255)
    b8 = np.round(np.clip(b[..., :3], 0, 1) * 255)
    mse = float(np.mean((a8 - b8) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


# --- the runs ---------------------------------------------------------------------------------------
def gl_mebibytes(network) -> float:
    """The GL buffers the renderer draws from: the mesh's points (tetrahedra path) or the cells'
    data (cells path), and the index buffer in visibility order."""
    import moderngl
    pt = network.processors["pt"]
    state = pt._draw_state
    used = [b for b in state.values() if isinstance(b, moderngl.Buffer)]
    if not state.get("by_cells"):
        used.append(network.output("tets.mesh").buffers(state["ctx"])["points"])
    return sum(b.size for b in used) / 2**20


def speed_table(args) -> list[str]:
    lines = ["| mesh (voxels) | culling | tetrahedra | cells, averaged (s) | cells, pre-integrated (s) "
             "| tetrahedra, pre-integrated (s) | GL memory cells / tetrahedra (MiB) | VTK PT (s) "
             "| VTK ZSweep (s) | VTK PT / cells averaged | VTK PT / cells pre-integrated |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for dims in tqdm([parse_dims(s) for s in args.sizes], desc="meshes", file=sys.stderr):
        volume = bonsai_volume(dims)
        for culling in ("none", "transfer_function"):
            times, memory = {}, {}
            network = mesh_network(volume, culling, "averaged")
            network.update("tets.mesh")
            mesh = network.output("tets.mesh")
            cams = cameras(mesh, args.repeat)
            many = len(mesh.tets) > args.max_tetrahedra
            for label, integration, cells in (("cells averaged", "averaged", True),
                                              ("cells preintegrated", "preintegrated", True),
                                              ("tets preintegrated", "preintegrated", False)):
                if many and not cells:
                    times[label] = memory[label] = np.nan
                    continue
                network.set("pt.integration", integration)
                network.set("pt.grid_cells", cells)
                times[label], _ = time_ours(network, cams, args.size)
                memory[label] = gl_mebibytes(network)
            network.remove("pt")  # free its buffers before VTK's process starts
            vtk_pt = vtk_zs = np.nan
            if not args.skip_vtk and not many:
                vtk_pt, _ = time_vtk("pt", mesh, transfer_function(), cams, args.size)
                if len(mesh.tets) <= 2_000_000:  # ZSweep is far slower; only where it finishes
                    vtk_zs, _ = time_vtk("zsweep", mesh, transfer_function(), cams, args.size)
            lines.append(f"| {'x'.join(map(str, dims))} | {culling} | {len(mesh.tets):,} | "
                         f"{times['cells averaged']:.3f} | {times['cells preintegrated']:.3f} | "
                         f"{times['tets preintegrated']:.3f} | {memory['cells preintegrated']:.1f} / "
                         f"{memory['tets preintegrated']:.1f} | {vtk_pt:.3f} | {vtk_zs:.3f} | "
                         f"{vtk_pt / times['cells averaged']:.1f} | {vtk_pt / times['cells preintegrated']:.1f} |")
            del network, mesh
    return lines


def sort_table(args) -> list[str]:
    """The centroid sort with numpy against the same sort on the GL side (compute shaders), best
    of --repeat per camera, on the whole (unculled) meshes."""
    from vgraph.gl_context import get_context
    from vgraph.gl.tetrahedra.gl_sort import GLCentroidSort
    from vgraph.gl.tetrahedra.order import back_to_front
    ctx = get_context()
    lines = ["| mesh (voxels) | tetrahedra | numpy argsort (s) | GL bitonic network (s) | passes |",
             "|---|---|---|---|---|"]
    for dims in [parse_dims(s) for s in args.sort_sizes]:
        network = mesh_network(bonsai_volume(dims), "none", "averaged")
        network.update("tets.mesh")
        mesh = network.output("tets.mesh")
        cams = cameras(mesh, args.repeat)
        sorter = GLCentroidSort(ctx, mesh.buffers(ctx)["points"], mesh.tets)
        sorter.sort(cams[0].rotate(1.0, 0.0))  # compile
        ctx.finish()
        cpu = gpu = np.inf
        for camera in cams:
            start = time.perf_counter()
            back_to_front(mesh.points, mesh.tets, camera)
            cpu = min(cpu, time.perf_counter() - start)
            start = time.perf_counter()
            sorter.sort(camera)
            ctx.finish()
            gpu = min(gpu, time.perf_counter() - start)
        sorter.release()
        lines.append(f"| {'x'.join(map(str, dims))} | {len(mesh.tets):,} | {cpu:.3f} | {gpu:.3f} | {sorter.passes} |")
    return lines


def accuracy_table(args) -> tuple[list[str], list[tuple[str, float, float]]]:
    from vgraph.numerics.reference_tetra import render as reference
    from vgraph.testing import ray_caster_network
    size = args.accuracy_size
    volume = bonsai_volume((args.accuracy_grid,) * 3)
    rows = []
    network = mesh_network(volume, "none", "averaged")
    network.update("tets.mesh")
    mesh = network.output("tets.mesh")
    camera = cameras(mesh, 1)[0]
    exact = reference(mesh, camera, transfer_function(), (size, size))
    for integration in ("averaged", "preintegrated"):
        for cells, order in ((True, "sweep"), (False, "centroid"), (False, "mpvo")):
            network.set("pt.integration", integration)
            network.set("pt.grid_cells", cells)
            network.set("pt.visibility_order", "centroid" if cells else order)
            seconds, image = time_ours(network, [camera] * args.repeat, size)
            name = f"{'cells' if cells else 'tetrahedra'} ({order}), {integration}"
            rows.append((name, seconds, psnr(image, exact), np.abs(image - exact).max()))
    for rate in (0.5, 1.0, 2.0, 4.0):
        rc = ray_caster_network(volume, camera, "RayCaster", transfer_function=transfer_function(),
                                sampling_rate=rate, shading="none")  # as the tetrahedra
        from vgraph.gl_context import get_context
        best = np.inf
        for _ in range(args.repeat):
            rc["rc"].invalidate()
            start = time.perf_counter()
            rc.update("rc.image", size=(size, size))
            get_context().finish()
            best = min(best, time.perf_counter() - start)
        image = rc.output("rc.image").to_numpy()
        rows.append((f"RayCaster, rate {rate:g} (trilinear)", best, psnr(image, exact), np.abs(image - exact).max()))
    if not args.skip_vtk:
        for kind, label in (("pt", "VTK projected tetrahedra"), ("zsweep", "VTK ZSweep")):
            seconds, image = time_vtk(kind, mesh, transfer_function(), [camera] * args.repeat, size)
            if image is not None:
                rows.append((label, seconds, psnr(image, exact), np.abs(image[..., :3] - exact[..., :3]).max()))
    lines = [f"| renderer ({args.accuracy_grid}^3 voxels, {len(mesh.tets):,} tetrahedra, {size}^2) | "
             "frame (s) | PSNR vs exact (dB) | max error |", "|---|---|---|---|"]
    lines += [f"| {name} | {t:.4f} | {p:.1f} | {e:.4f} |" for name, t, p, e in rows]
    return lines, rows


def plot(rows, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, axis = plt.subplots(figsize=(6, 4))
    for name, seconds, value, _ in rows:
        axis.scatter(seconds, value, label=name)
    axis.set_xscale("log")
    axis.set_xlabel("frame time (s)")
    axis.set_ylabel("PSNR against the exact reference (dB)")
    axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["64", "128x128x58", "256x128x64", "256"])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--accuracy-grid", type=int, default=32)
    parser.add_argument("--accuracy-size", type=int, default=128)
    parser.add_argument("--skip-vtk", action="store_true")
    parser.add_argument("--max-tetrahedra", type=int, default=12_000_000,
                        help="larger meshes: only our cells path (VTK and our tetrahedra path "
                             "would take minutes and tens of GB)")
    parser.add_argument("--skip-speed", action="store_true")
    parser.add_argument("--sort-sizes", nargs="*", default=["32", "64"],
                        help="meshes on which the numpy and GL-side centroid sorts are timed")
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    report = [f"# Projected tetrahedra ({' '.join(sys.argv[1:]) or 'defaults'})", ""]
    if not args.skip_speed:
        report += ["## Speed", "", *speed_table(args), ""]
    if args.sort_sizes:
        report += ["## The centroid sort: numpy or GL", "", *sort_table(args), ""]
    lines, rows = accuracy_table(args)
    report += ["## Error against frame time", "", *lines, ""]
    plot(rows, args.out / "tetra_accuracy.png")
    text = "\n".join(report) + "\n"
    (args.out / "tetra.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
