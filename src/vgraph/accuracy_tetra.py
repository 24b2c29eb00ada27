"""ProjectedTetrahedra error against frame time: the ``tetrahedra`` section of ``vgraph bench
accuracy`` (docs/reports/accuracy.md, "Projected tetrahedra: error against frame time").

For each mesh and transfer function, every integration (averaged, preintegrated, partial) with
every visibility order (centroid, mpvo, mpvonc) is compared with the exact CPU reference
(vgraph.numerics.reference_tetra.render, same camera and size): PSNR and max error as
vgraph.accuracy_common defines them. The frame time is the best of ``repeat`` frames, each with the
camera turned 0.01 rad from the last (so every frame sorts again), including the sort, the draw and
glFinish, not the read-back. Meshes:

- post: tet_lox_post/post.vtk, Pressure (shared data; 8,750 tetrahedra split from wedges);
- disk: hex_disk_out_ref/disk_out_ref.vtu, Temp (shared data; 44,832 tetrahedra from hexahedra);
- grid: a 6^3 blob as 625 tetrahedra, its scalar 0..100 (made here, no data);
- c: the non-convex C of vgraph.mesh_shapes.c_shape (675 tetrahedra), seen through both arms.

Transfer functions: "ramp", the ray casters' default (TransferFunctionLut.DEFAULT); "spike", an
opacity spike to 0.9 whose base is 1 % of the value range wide (one data unit on the 0..100
grid), at the field's median, the colour turning across it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vgraph.accuracy_common import (DISK_MESH, POST_MESH, machine_line, max_error,
                                    plot_error_against_time, psnr, require_file, write_text)
from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.gl.raycasting.components import TransferFunctionLut
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
from vgraph.gl_context import get_context
from vgraph.mesh import TetMesh
from vgraph.mesh_shapes import c_shape
from vgraph.numerics import reference_tetra
from vgraph.registry import registry
from vgraph.tetrahedralize import volume_tetrahedra
from vgraph.transfer_function import TransferFunction

INTEGRATIONS = ("averaged", "preintegrated", "partial")
ORDERS = ("centroid", "mpvo", "mpvonc")
MESHES = ("post", "disk", "grid", "c")
SYNTHETIC = ("grid", "c")  # made here: no data file
DEFAULTS = {"meshes": MESHES, "integrations": INTEGRATIONS, "orders": ORDERS, "size": (256, 256),
            "repeat": 3}
QUICK = {"meshes": SYNTHETIC, "integrations": INTEGRATIONS, "orders": ORDERS, "size": (96, 96),
         "repeat": 1}
FRAME_TURN = 0.01  # radians between timed frames: each frame sorts again
COLOURS = dict(zip(INTEGRATIONS, ("tab:orange", "tab:blue", "tab:green")))
MARKERS = dict(zip(ORDERS, ("o", "s", "^")))


@dataclass(frozen=True)
class Row:
    mesh: str  # the mesh's label
    tetrahedra: int
    tf: str
    integration: str
    order: str
    psnr: float
    max_error: float
    ms: float  # best frame


# --- the cases -----------------------------------------------------------------------------------
def grid_mesh(n: int = 6) -> TetMesh:
    """A Gaussian blob on an n^3 grid as tetrahedra, its scalar 0..100, opacity length 1."""
    z, y, x = np.mgrid[0:n, 0:n, 0:n] / (n - 1)
    data = np.exp(-((x - 0.45) ** 2 + (y - 0.5) ** 2 + (z - 0.55) ** 2) / 0.12).astype(np.float32)
    points, tets, voxels = volume_tetrahedra(data, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), None)
    return TetMesh(points, tets, data.reshape(-1)[voxels] * 100.0, reference_length=1.0)


def c_camera(mesh: TetMesh) -> Camera:
    """The view through both arms of the C."""
    return Camera.looking_at_box(*mesh.box, direction=(-1.0, 0.2, -0.3))


def check_options(meshes, integrations, orders, repeat: int, files: dict) -> None:
    """Refuse unknown names and missing data files before any measuring; ``files`` maps
    "post" and "disk" to (path, option)."""
    for option, values, known in (("--meshes", meshes, MESHES),
                                  ("--integrations", integrations, INTEGRATIONS),
                                  ("--orders", orders, ORDERS)):
        bad = [v for v in values if v not in known]
        if bad or not values:
            raise VGraphError(f"{option}: unknown {', '.join(map(repr, bad)) or '(none given)'}; "
                              f"choose from {', '.join(known)}")
    if repeat < 1:
        raise VGraphError(f"--repeat must be at least 1, got {repeat}")
    for name in meshes:
        if name in files:
            require_file(*files[name], mesh=True)


def load_meshes(names, files: dict):
    """(label, mesh, camera) of each named mesh; ``files`` as for check_options."""
    from vgraph.io.meshes import read_mesh  # imported when used: meshio takes a while
    for name in names:
        if name == "post":
            yield "post.vtk (Pressure)", read_mesh(files["post"][0], array="Pressure"), DEFAULT_CAMERA
        elif name == "disk":
            yield "disk_out_ref.vtu (Temp)", read_mesh(files["disk"][0], array="Temp"), DEFAULT_CAMERA
        elif name == "grid":
            yield "6^3 grid, 0..100", grid_mesh(), DEFAULT_CAMERA
        else:
            mesh = c_shape()
            yield "C (non-convex)", mesh, c_camera(mesh)


def transfer_functions(mesh: TetMesh) -> dict[str, TransferFunction]:
    """"ramp" and "spike" (module docstring)."""
    low, high = (float(v) for v in mesh.value_range)
    centre, half = float(np.median(mesh.scalars)), 0.005 * (high - low)
    spike = TransferFunction(space="data", points=[(centre - half, 1.0, 0.5, 0.2, 0.0),
                                                   (centre, 1.0, 0.9, 0.3, 0.9),
                                                   (centre + half, 0.2, 0.5, 1.0, 0.0)])
    return {"ramp": TransferFunctionLut.DEFAULT, "spike": spike}


# --- measuring -------------------------------------------------------------------------------------
def render(mesh: TetMesh, camera: Camera, tf, size, integration: str, order: str):
    """(processor, image) of ProjectedTetrahedra (found by name: processors are a higher layer)."""
    processor = registry.get("ProjectedTetrahedra")(camera=camera, transfer_function=tf,
                                                    integration=integration, visibility_order=order)
    processor.render_size = tuple(size)
    return processor, processor.process(mesh)["image"].to_numpy()


def measure(mesh, camera, tf, reference, size, repeat: int, integration: str, order: str):
    """(PSNR, max error, best ms) of one integration and order (module docstring)."""
    ctx = get_context()
    processor, image = render(mesh, camera, tf, size, integration, order)
    times = []
    for k in range(repeat):
        processor.camera = camera.rotate(FRAME_TURN * (k + 1), 0.0)
        start = time.perf_counter()
        processor.process(mesh)
        ctx.finish()
        times.append(time.perf_counter() - start)
    return psnr(image, reference), max_error(image, reference), 1e3 * min(times)


def run(meshes=MESHES, integrations=INTEGRATIONS, orders=ORDERS, size=(256, 256), repeat: int = 3,
        files: dict | None = None, progress: bool = True) -> list[Row]:
    """Every mesh x TF x integration x order."""
    files = files or {"post": (POST_MESH, "--post-mesh"), "disk": (DISK_MESH, "--disk-mesh")}
    check_options(meshes, integrations, orders, repeat, files)
    rows = []
    total = len(meshes) * 2 * len(integrations) * len(orders)
    with tqdm(total=total, desc="tetrahedra", unit="case", disable=not progress) as bar:
        for label, mesh, camera in load_meshes(meshes, files):
            for tf_name, tf in transfer_functions(mesh).items():
                bar.set_postfix_str(f"{label} {tf_name}: exact reference")
                reference = reference_tetra.render(mesh, camera, tf, size)
                for integration in integrations:
                    for order in orders:
                        bar.set_postfix_str(f"{label} {tf_name} {integration} {order}")
                        measured = measure(mesh, camera, tf, reference, size, repeat, integration, order)
                        rows.append(Row(label, len(mesh.tets), tf_name, integration, order, *measured))
                        bar.update(1)
    return rows


# --- the report --------------------------------------------------------------------------------------
def markdown(rows: list[Row], size, repeat: int, files: dict) -> str:
    """The settings, then a row per case."""
    data = ", ".join(f"{name}: {path}" for name, (path, _) in files.items()
                     if any(r.mesh.startswith(Path(path).name) for r in rows))
    lines = ["# ProjectedTetrahedra: error against frame time\n",
             f"Settings: {size[0]} x {size[1]} pixels, best of {repeat} frames (each turned "
             f"{FRAME_TURN} rad: a new sort), {machine_line(get_context())}; PSNR over RGB in float, "
             f"max over channels, against the exact reference vgraph.numerics.reference_tetra"
             + (f"; data {data}" if data else "") + ".\n",
             "| mesh | tetrahedra | TF | integration | order | PSNR (dB) | max error | frame (ms) |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r.mesh} | {r.tetrahedra:,} | {r.tf} | {r.integration} | {r.order} | {r.psnr:.1f} | "
              f"{r.max_error:.2g} | {r.ms:.0f} |" for r in rows]
    return "\n".join(lines) + "\n"


def write(rows: list[Row], out: Path, size, repeat: int, files: dict) -> list[Path]:
    """tetrahedra.md and tetrahedra.png (a column per mesh and TF) in ``out``."""
    text = markdown(rows, size, repeat, files)
    write_text(out / "tetrahedra.md", text)
    panels: dict = {}
    for r in rows:
        panels.setdefault(f"{r.mesh}, {r.tf}", []).append(((r.integration, r.order), r.ms, r.psnr,
                                                           r.max_error))
    plot_error_against_time(panels, lambda s: (COLOURS[s[0]], MARKERS[s[1]], f"{s[0]}, {s[1]}"),
                            out / "tetrahedra.png", "frame (ms, best)")
    print(text)
    return [out / "tetrahedra.md", out / "tetrahedra.png"]
