"""Peak memory (tracemalloc, which sees numpy's buffers) and time of the exact CPU references at
extreme optical depths: the tetrahedra reference on the shared post.vtk and the reference ray
caster on a smooth volume at a high sampling rate. The numbers in docs/reports/accuracy.md
("The exact references at the extremes") come from this script:

    .venv/bin/python bench/reference_memory.py
"""

import time
import tracemalloc
from pathlib import Path

import meshio
import numpy as np

from vgraph.camera import Camera
from vgraph.mesh import TetMesh
from vgraph.numerics import reference_raycast, reference_tetra
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

POST = Path("/work/shared/data/tet_lox_post/post.vtk")
TF = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.4, 1.0, 0.5, 0.1, 0.0), (0.5, 1.0, 0.6, 0.2, 0.6),
                              (0.6, 0.2, 0.6, 1.0, 0.05), (1.0, 1.0, 0.9, 0.6, 1.0)])
CAMERA = Camera(fit_to_data=True).viewed_from("iso")


def measured(render):
    tracemalloc.start()
    start = time.perf_counter()
    image = render()
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] / 2 ** 20
    tracemalloc.stop()
    return seconds, peak, bool(np.isfinite(image).all())


def main():
    raw = meshio.read(POST)
    print("| reference | case | size | time (s) | peak traced (MiB) | finite |")
    print("|---|---|---|---|---|---|")
    for length in (1e8, 0.05, 1e-4, 1e-8):
        mesh = TetMesh(raw.points, raw.cells_dict["tetra"], raw.point_data["Pressure"],
                       reference_length=length)
        for size in (64, 256):
            seconds, peak, finite = measured(lambda: reference_tetra.render(mesh, CAMERA, TF, (size, size)))
            print(f"| tetrahedra (post.vtk) | opacity_length {length:g} | {size}^2 | {seconds:.1f} | "
                  f"{peak:.0f} | {finite} |")
    z, y, x = np.mgrid[:32, :32, :32] / 31.0
    volume = Volume(np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) * 8).astype(np.float32))
    for rate in (1.0, 64.0):
        for size in (64, 256):
            seconds, peak, finite = measured(lambda: reference_raycast.render(
                volume, CAMERA, TF, (size, size), sampling_rate=rate, early_termination=1.0))
            print(f"| ray caster (32^3) | sampling rate {rate:g} | {size}^2 | {seconds:.1f} | {peak:.0f} | {finite} |")


if __name__ == "__main__":
    main()
