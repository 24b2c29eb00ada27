"""Peak memory (tracemalloc, which sees numpy's buffers) and time of the exact CPU references at
extreme optical depths: the tetrahedra reference on the shared post.vtk and the reference ray
caster on a smooth volume at a high sampling rate. The numbers in docs/reports/accuracy.md
("The exact references at the extremes") come from this script:

    .venv/bin/python bench/reference_memory.py

and the tetrahedra reference before it streamed (commit 1d0d230) from

    git show 1d0d230:src/vgraph/numerics/reference_tetra.py > /tmp/old_reference_tetra.py
    (ulimit -v 6000000; .venv/bin/python bench/reference_memory.py --tetra /tmp/old_reference_tetra.py)
"""

import argparse
import importlib.util
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


def measured(render) -> str:
    """'seconds | peak MiB | finite' of one call, or the MemoryError it raised."""
    tracemalloc.start()
    start = time.perf_counter()
    try:
        image = render()
        outcome = str(bool(np.isfinite(image).all()))
    except MemoryError:
        outcome = "MemoryError"
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] / 2 ** 20
    tracemalloc.stop()
    return f"{seconds:.1f} | {peak:.0f} | {outcome}"


def module_from(path: str):
    spec = importlib.util.spec_from_file_location("reference_tetra_under_test", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tetra", help="a reference_tetra.py to measure instead (the tetrahedra only)")
    args = parser.parse_args()
    tetra = module_from(args.tetra) if args.tetra else reference_tetra
    raw = meshio.read(POST)
    print("| reference | case | size | time (s) | peak traced (MiB) | finite |")
    print("|---|---|---|---|---|---|")
    for length in (1e8, 0.05, 1e-4, 1e-8):
        mesh = TetMesh(raw.points, raw.cells_dict["tetra"], raw.point_data["Pressure"],
                       reference_length=length)
        for size in (64, 256, 512):
            result = measured(lambda: tetra.render(mesh, CAMERA, TF, (size, size)))
            print(f"| tetrahedra (post.vtk) | opacity_length {length:g} | {size}^2 | {result} |")
    if args.tetra:
        return
    z, y, x = np.mgrid[:32, :32, :32] / 31.0
    volume = Volume(np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) * 8).astype(np.float32))
    for rate in (1.0, 64.0):
        for size in (64, 256):
            result = measured(lambda: reference_raycast.render(
                volume, CAMERA, TF, (size, size), sampling_rate=rate, early_termination=1.0))
            print(f"| ray caster (32^3) | sampling rate {rate:g} | {size}^2 | {result} |")


if __name__ == "__main__":
    main()
