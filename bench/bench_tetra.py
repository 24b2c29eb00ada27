"""Projected tetrahedra: ours against VTK, and error against run time (Monsalve 2016 tables 4-6
redone on this machine; issue #13's benchmarks).

    .venv/bin/python bench/bench_tetra.py [--sizes 64 128x128x58 256x128x64] [--size 512]
        [--repeat 3] [--out bench/results] [--accuracy-grid 32] [--skip-vtk] [--zsweep]
        [--skip-speed] [--skip-accuracy] [--sort-sizes ...]

Meshes are made from the CT bonsai (256^3, shared/data) by taking every k-th voxel (64^3 is the
seed's "fuel" size, 5 tetrahedra per cell: 1.25 M tetrahedra before culling) and culling the cells
the transfer function leaves transparent (VolumeToTetMesh, culling = transfer_function): 111 k,
354 k and 820 k tetrahedra for the default sizes. Every renderer draws the same culled mesh (the
same work on both sides: an earlier version also compared our draw-time-culled frame of the whole
mesh with VTK drawing all of it, which is not the same work, so that row is gone). Ours draws it
cell by cell (grid_cells, the default for meshes cut from a volume; averaged and pre-integrated)
and tetrahedron by tetrahedron (grid_cells off, centroid sort, pre-integrated), each variant its
own ProjectedTetrahedra so that no frame switches a renderer's settings.

Fairness (issue #31): VTK's vtkProjectedTetrahedraMapper (and with --zsweep
vtkUnstructuredGridVolumeZSweepMapper) runs with multisampling off (SetMultiSamples(0): VTK's
default window takes 8 samples a pixel, which alone made its PT 1.9-2.1x slower), in a spawned
worker process (VTK and our EGL context do not share a process) that the parent drives frame by
frame. Every renderer draws one untimed warm-up frame, then --repeat rounds of one frame per
renderer in turn (ours, ours, ours, VTK, ours, ...), each round with a new camera, so load from
other processes hits all alike. A frame: camera set, render, glFinish / WaitForCompletion, no
read-back. The table gives min / median / max of each renderer's frames and the ratio of the
medians with the range of the per-round ratios, and prints the settings (VTK version, window
class, GetMultiSamples()) above it. Same points, tetrahedra, scalars, TF (data units, opacity unit
distance = the mesh's reference length), camera and image size on both sides.

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
sys.path.insert(0, str(Path(__file__).resolve().parent))
from interleave import interleaved, spread  # noqa: E402

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


def camera_tuple(camera) -> tuple:
    """What VTK's worker needs of a camera (our Camera does not cross the pipe by design)."""
    return (camera.position, camera.focus, camera.up, camera.fov, camera.near, camera.far)


def our_frame(network, pid: str, size: int):
    """A frame of processor ``pid``: camera set, render, glFinish (no read-back)."""
    from vgraph.gl_context import get_context
    ctx = get_context()

    def frame(camera) -> float:
        network.set(f"{pid}.camera", camera)
        network.invalidate_downstream(pid)  # the same camera twice must still render
        start = time.perf_counter()
        network.update(f"{pid}.image", size=(size, size))
        ctx.finish()
        return time.perf_counter() - start
    return frame


def time_ours(network, cams, size: int) -> tuple[float, np.ndarray]:
    """Best of ``cams`` frames of processor "pt" after a warm-up frame, and the last image."""
    seconds, _ = interleaved({"pt": our_frame(network, "pt", size)}, cams, cams[0].rotate(1.0, 0.0))
    return min(seconds["pt"]), network.output("pt.image").to_numpy()


# --- VTK, in its own process -------------------------------------------------------------------------
# VTK's EGL window and our moderngl EGL context disturb each other in one process (bench_vtk.py), so
# VTK runs in a spawned worker that the parent drives frame by frame; the worker times its own frames.
def vtk_mapper_window(grid, tf_points, value_range, reference_length, size, kind):
    """(render window, renderer) of one VTK mapper on ``grid``, multisampling off."""
    import vtk
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
    window.SetMultiSamples(0)  # VTK's default is 8 samples a pixel: 2x the work, as bench_vtk.py
    window.AddRenderer(renderer)
    window.SetSize(size, size)
    return window, renderer


def vtk_grid(points, tets, scalars):
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
    return grid


def vtk_worker(connection, points, tets, scalars, value_range, reference_length, tf_points, size, kinds):
    """Worker: one window per mapper kind ("pt", "zsweep"); answers ("render", kind, camera) with the
    frame's seconds, ("image", kind, None) with its RGBA image, ("settings", kind, None) with the
    window's class and GetMultiSamples(); None ends it."""
    import os
    os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"  # headless, before VTK loads
    import vtk
    grid = vtk_grid(points, tets, scalars)
    windows = {kind: vtk_mapper_window(grid, tf_points, value_range, reference_length, size, kind)
               for kind in kinds}

    def render(kind, cam):
        window, renderer = windows[kind]
        position, focus, up, fov, near, far = cam
        camera = renderer.GetActiveCamera()
        camera.SetPosition(*position)
        camera.SetFocalPoint(*focus)
        camera.SetViewUp(*up)
        camera.SetViewAngle(fov)
        camera.SetClippingRange(near, far)
        start = time.perf_counter()
        window.Render()
        window.WaitForCompletion()
        return time.perf_counter() - start

    def image(kind, _):
        from vtk.util.numpy_support import vtk_to_numpy
        grab = vtk.vtkWindowToImageFilter()
        grab.SetInput(windows[kind][0])
        grab.SetInputBufferTypeToRGBA()
        grab.ShouldRerenderOff()
        grab.Update()
        pixels = vtk_to_numpy(grab.GetOutput().GetPointData().GetScalars()).reshape(size, size, 4)[::-1]
        return pixels.astype(np.float32) / 255.0

    def settings(kind, _):
        window = windows[kind][0]
        return {"window": window.GetClassName(), "multisamples": window.GetMultiSamples(),
                "vtk": vtk.vtkVersion.GetVTKVersion()}

    commands = {"render": render, "image": image, "settings": settings}
    connection.send("ready")
    while (message := connection.recv()) is not None:
        command, kind, argument = message
        connection.send(commands[command](kind, argument))


class VtkWorker:
    """VTK's mappers on one mesh in a spawned process, driven frame by frame from this one."""

    def __init__(self, mesh, tf, size: int, kinds=("pt",)):
        context = multiprocessing.get_context("spawn")
        self.connection, theirs = context.Pipe()
        self.process = context.Process(target=vtk_worker, daemon=True, args=(
            theirs, mesh.points, mesh.tets, mesh.scalars, mesh.value_range, mesh.opacity_length,
            tf.for_volume(mesh).points, size, tuple(kinds)))
        self.process.start()
        if not self.connection.poll(600) or self.connection.recv() != "ready":
            raise RuntimeError("VTK's worker did not start")

    def call(self, command: str, kind: str, argument=None):
        self.connection.send((command, kind, argument))
        return self.connection.recv()

    def frame(self, kind: str):
        return lambda camera: self.call("render", kind, camera_tuple(camera))

    def close(self) -> None:
        self.connection.send(None)
        self.process.join(60)


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    a8 = np.round(np.clip(a[..., :3], 0, 1) * 255)
    b8 = np.round(np.clip(b[..., :3], 0, 1) * 255)
    mse = float(np.mean((a8 - b8) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


# --- the runs ---------------------------------------------------------------------------------------
def gl_mebibytes(network, pid: str) -> float:
    """The GL buffers the renderer draws from: the mesh's points (tetrahedra path) or the cells'
    data (cells path), and the index buffer in visibility order."""
    import moderngl

    from vgraph.gl.tetrahedra.cells import cell_buffer
    state = network.processors[pid]._draw_state
    mesh = network.output("tets.mesh")
    used = [b for b in state.values() if isinstance(b, moderngl.Buffer)]
    # The cells' data (cached per mesh and context) or the mesh's points (per mesh)
    used.append(cell_buffer(state["ctx"], mesh) if state.get("by_cells") else mesh.buffers(state["ctx"])["points"])
    return sum(b.size for b in used) / 2**20


OURS = {"cells averaged": ("averaged", True), "cells preintegrated": ("preintegrated", True),
        "tets preintegrated": ("preintegrated", False)}


def speed_network(volume):
    """The culled mesh drawn by one ProjectedTetrahedra per variant of OURS (pid = the variant's
    name with "_" for " "), so alternating frames never switch a renderer's settings."""
    network = mesh_network(volume, "transfer_function", "averaged")
    network.remove("pt")
    for label, (integration, cells) in OURS.items():
        pid = label.replace(" ", "_")
        network.add("ProjectedTetrahedra", id=pid, transfer_function=transfer_function(),
                    integration=integration, grid_cells=cells)
        network.connect("tets.mesh", f"{pid}.mesh")
    network.update("tets.mesh")
    return network


def speed_rows(args) -> tuple[list[dict], list]:
    """Per mesh size: the culled mesh, our variants and VTK's mappers drawn in alternating frames.
    Returns a row per mesh and, per mesh, the order the frames were drawn in."""
    rows, orders = [], []
    for dims in tqdm([parse_dims(s) for s in args.sizes], desc="meshes", file=sys.stderr):
        network = speed_network(bonsai_volume(dims))
        mesh = network.output("tets.mesh")
        cams = cameras(mesh, args.repeat)
        renderers = {label: our_frame(network, label.replace(" ", "_"), args.size) for label in OURS}
        worker, settings = None, {}
        if not args.skip_vtk:
            kinds = ("pt", "zsweep") if args.zsweep else ("pt",)
            worker = VtkWorker(mesh, transfer_function(), args.size, kinds)
            settings = worker.call("settings", "pt")
            renderers.update({f"VTK {kind}": worker.frame(kind) for kind in kinds})
        try:
            seconds, order = interleaved(renderers, cams, cams[0].rotate(1.0, 0.0))
        finally:
            if worker is not None:
                worker.close()
        memory = {label: gl_mebibytes(network, label.replace(" ", "_")) for label in OURS}
        rows.append(dict(dims=dims, tetrahedra=len(mesh.tets), seconds=seconds, memory=memory, vtk=settings))
        orders.append(order)
        del network, mesh
    return rows, orders


def ratio(seconds: dict, peer: str, ours: str) -> str:
    """Median of the peer's frames over the median of ours, and the range of the per-round ratios."""
    if peer not in seconds:
        return "(not run)"
    per_round = np.array(seconds[peer]) / np.array(seconds[ours])
    medians = float(np.median(seconds[peer])) / float(np.median(seconds[ours]))
    return f"{medians:.2f} ({per_round.min():.2f}-{per_round.max():.2f})"


def speed_table(args) -> list[str]:
    rows, _ = speed_rows(args)
    vtk = next((r["vtk"] for r in rows if r["vtk"]), {})
    lines = [f"Settings: {args.size}^2 image; meshes culled by VolumeToTetMesh (culling = transfer_function), "
             f"the same tetrahedra for every renderer; one untimed warm-up frame per renderer, then "
             f"{args.repeat} rounds of one frame per renderer in turn, each round a new camera; a frame "
             f"is camera set, render, glFinish / WaitForCompletion, no read-back. VTK "
             f"{vtk.get('vtk', '(not run)')} in a spawned process driven frame by frame, window "
             f"{vtk.get('window', '-')}, GetMultiSamples() = {vtk.get('multisamples', '-')}. "
             "Times: min / median / max seconds; ratios: median / median (range of the per-round ratios).",
             "", "| mesh (voxels) | tetrahedra | cells, averaged (s) | cells, pre-integrated (s) "
             "| tetrahedra, pre-integrated (s) | GL memory cells / tetrahedra (MiB) | VTK PT (s) "
             + ("| VTK ZSweep (s) " if args.zsweep else "")
             + "| VTK PT / cells averaged | VTK PT / cells pre-integrated |",
             "|---|---|---|---|---|---|---|" + ("---|" if args.zsweep else "") + "---|---|"]
    for row in rows:
        s = row["seconds"]
        lines.append(f"| {'x'.join(map(str, row['dims']))} | {row['tetrahedra']:,} | "
                     f"{spread(s['cells averaged'])} | {spread(s['cells preintegrated'])} | "
                     f"{spread(s['tets preintegrated'])} | {row['memory']['cells preintegrated']:.1f} / "
                     f"{row['memory']['tets preintegrated']:.1f} | {spread(s.get('VTK pt', []))} | "
                     + (f"{spread(s.get('VTK zsweep', []))} | " if args.zsweep else "")
                     + f"{ratio(s, 'VTK pt', 'cells averaged')} | {ratio(s, 'VTK pt', 'cells preintegrated')} |")
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
        worker = VtkWorker(mesh, transfer_function(), size, ("pt", "zsweep"))
        try:
            for kind, label in (("pt", "VTK projected tetrahedra"), ("zsweep", "VTK ZSweep")):
                seconds, _ = interleaved({kind: worker.frame(kind)}, [camera] * args.repeat,
                                         camera.rotate(1.0, 0.0))
                image = worker.call("image", kind)
                rows.append((label, min(seconds[kind]), psnr(image, exact),
                             np.abs(image[..., :3] - exact[..., :3]).max()))
        finally:
            worker.close()
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
    parser.add_argument("--sizes", nargs="+", default=["64", "128x128x58", "256x128x64"])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--accuracy-grid", type=int, default=32)
    parser.add_argument("--accuracy-size", type=int, default=128)
    parser.add_argument("--skip-vtk", action="store_true")
    parser.add_argument("--zsweep", action="store_true",
                        help="also VTK's ZSweep mapper in the speed table (3-4x slower than its PT)")
    parser.add_argument("--skip-speed", action="store_true")
    parser.add_argument("--skip-accuracy", action="store_true")
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
    if not args.skip_accuracy:
        lines, rows = accuracy_table(args)
        report += ["## Error against frame time", "", *lines, ""]
        plot(rows, args.out / "tetra_accuracy.png")
    text = "\n".join(report) + "\n"
    (args.out / "tetra.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
