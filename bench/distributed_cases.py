"""Networks the cluster's accuracy is measured and tested on (issue 30; bench/distributed_tolerances.py
and tests/test_distributed*.py share them): everything they read is a file in a folder the workers
see, so a network travels to a worker as its JSON document.

- ``bricked_network``: a rippled ball of 0..100 data units (a data unit is 1 % of the range) drawn
  by a BrickedRayCaster in 16^3 bricks, an oblique view.
- ``tets_network`` / ``stiff_mesh_network``: a smooth blob on a 6^3 grid cut into tetrahedra, its
  scalar in 0..100 data units, saved as a VTK file and drawn by ProjectedTetrahedra.
- ``tiles_picture`` / ``leaves_picture``: the picture of a split drawn by the workers' own task
  functions called in this process (a task on a worker is the same function of the same
  arguments), with the single-process picture; ``difference`` compares them.
- ``spike_tf``: a transfer function in data units that is ``opacity`` over ``width`` data units
  around ``centre`` (a spike one data unit wide: the stiff case of issue 30, item 6) and 0 elsewhere.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import vgraph
from vgraph.camera import Camera
from vgraph.distributed.leaves import bricked_caster, composite, plan_task, resolve_task, run_task, split_runs
from vgraph.distributed.render import prepare
from vgraph.distributed.tiles import assemble
from vgraph.distributed.worker import render_tile, shipped
from vgraph.network import Network
from vgraph.transfer_function import TransferFunction

REPO = Path(__file__).resolve().parents[1]
DATA_UNITS = 100.0  # the cases' fields run over 0..100


def shipped_network(name: str, values: dict | None = None) -> Network:
    """networks/<name>.json with ``values`` ('id.property' -> value) set."""
    network = vgraph.load(REPO / "networks" / f"{name}.json")
    for address, value in (values or {}).items():
        network.set(address, value)
    return network


def spike_tf(centre: float, width: float = 1.0, opacity: float = 0.9) -> TransferFunction:
    """``opacity`` over ``width`` data units around ``centre`` (a triangle: 0, opacity at the
    centre, 0), the colour turning across it; 0 elsewhere."""
    half = width / 2.0
    return TransferFunction(space="data", points=[
        (0.0, 1.0, 0.5, 0.2, 0.0), (max(centre - half, 0.0), 1.0, 0.5, 0.2, 0.0),
        (centre, 1.0, 0.9, 0.3, opacity),
        (min(centre + half, DATA_UNITS), 0.2, 0.5, 1.0, 0.0), (DATA_UNITS, 0.2, 0.5, 1.0, 0.0)])


def ball_file(folder: Path, shape=(37, 29, 41)) -> Path:
    """A ball with ripples in 0..100 data units, saved where the workers read it."""
    path = Path(folder) / f"ripple_ball_{'x'.join(map(str, shape))}.npy"
    if not path.exists():
        z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in shape], indexing="ij")
        data = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.15 * np.sin(9 * x)
        np.save(path, (DATA_UNITS * np.clip(data, 0, 1)).astype(np.float32))
    return path


def bricked_network(folder: Path, shape=(37, 29, 41), **properties) -> Network:
    """bricked_network_of the rippled ball of ``shape`` (16^3 bricks, all at level 0)."""
    return bricked_network_of(ball_file(folder, shape), **properties)


def bricked_network_of(path: Path, **properties) -> Network:
    """VolumeSource of ``path`` -> EntryExitPoints -> BrickedRayCaster 'rc' (16^3 bricks, all at
    level 0, unless ``properties`` say otherwise) -> Canvas, an oblique view. ``method`` passes
    unless told: its tiles are the single-process picture bit for bit and its leaves are what the
    leaves split draws (``auto`` draws dvr, iso and mip in one pass, whose tiles agree within float
    rounding: docs/explanations/bricked-ray-casting.md, "Which method draws")."""
    network = Network(base_dir=Path(path).parent)
    network.add("VolumeSource", id="source", path=str(path))
    camera = Camera(position=(0.7, -0.5, 1.0), focus=(0, 0, 0), near=None, far=None, fit_to_data=True)
    network.add("EntryExitPoints", id="eep", camera=camera)
    network.add("BrickedRayCaster", id="rc", **{"brick_size": 16, "lod_bias": -16.0, "method": "passes",
                                                    **properties})
    network.add("Canvas", id="canvas")
    network.link("eep.camera", "rc.camera")
    for source, target in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit"), ("rc.image", "canvas.image")):
        network.connect(source, target)
    return network


def mesh_file(folder: Path, n: int = 6) -> Path:
    """A smooth blob on an n^3 grid of spacing 1 cut into 5 tetrahedra per cell, its scalar in
    0..100, as a VTK file."""
    import meshio

    from vgraph.tetrahedralize import volume_tetrahedra
    path = Path(folder) / f"blob{n}.vtk"
    if not path.exists():
        z, y, x = np.mgrid[0:n, 0:n, 0:n] / (n - 1)
        data = np.exp(-((x - 0.45) ** 2 + (y - 0.5) ** 2 + (z - 0.55) ** 2) / 0.12)
        points, tets, voxels = volume_tetrahedra(data.astype(np.float32), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), None)
        meshio.write(path, meshio.Mesh(np.asarray(points, np.float64), [("tetra", np.asarray(tets))],
                                       point_data={"scalar": DATA_UNITS * data.reshape(-1)[voxels]}))
    return path


def tets_network(folder: Path, transfer_function=None, reference_length: float = 1.0,
                 **properties) -> Network:
    """MeshSource (the blob, ``reference_length``) -> ProjectedTetrahedra 'pt' -> Canvas."""
    path = mesh_file(folder)
    network = Network(base_dir=path.parent)
    network.add("MeshSource", id="source", path=str(path), array="scalar",
                value_range=(0.0, DATA_UNITS), reference_length=reference_length)
    pt = {"background": (0.0, 0.0, 0.0, 1.0), **properties}
    if transfer_function is not None:
        pt["transfer_function"] = transfer_function
    network.add("ProjectedTetrahedra", id="pt", **pt)
    network.add("Canvas", id="canvas")
    network.connect("source.mesh", "pt.mesh")
    network.connect("pt.image", "canvas.image")
    return network


def stiff_mesh_network(folder: Path, integration: str = "partial", reference_length: float = 1.0,
                       **properties) -> Network:
    """The blob under a spike one data unit wide at 50 (1 % of its range)."""
    return tets_network(folder, spike_tf(50.0), reference_length, integration=integration, **properties)


# --- the splits, by the workers' own task functions called in this process ---------------------------
def tiles_picture(network, size, grid):
    """(the picture assembled from the workers' tiles, the single-process picture)."""
    plan = prepare(network, tiles=grid, size=size)
    document, base_dir = shipped(plan.network)
    parts = [render_tile(document, base_dir, plan.target, plan.size, tile) for tile in plan.tiles]
    return assemble(plan.size, plan.tiles, parts), plan.network.evaluate(plan.target, size=size)


def leaves_picture(network, size, runs):
    """(the picture of the leaves split with ``runs`` runs of bricks, the single-process picture)."""
    plan = prepare(network, split="leaves", size=size)
    caster = bricked_caster(plan.network, plan.target)
    document, base_dir = shipped(plan.network)
    common = (document, base_dir, plan.target, plan.size, caster, ())
    bricks, weights = plan_task(*common)
    mode = plan.network[caster].compositing
    layers = [run_task(*common, bricks[a:b]) for a, b in split_runs(weights, runs)]
    while len(layers) > 1:
        layers = [composite(*layers[j:j + 2], mode) if j + 1 < len(layers) else layers[j]
                  for j in range(0, len(layers), 2)]
    image = resolve_task(*common, layers[0] if layers else None)
    return image, plan.network.evaluate(plan.target, size=size)


def difference(image, reference) -> dict:
    a, b = image.astype(np.float64), reference.astype(np.float64)
    both = np.isfinite(a) & np.isfinite(b)
    error = np.where(both, np.abs(a - b), 0.0)
    per_pixel = error.max(axis=-1)
    worst = np.unravel_index(int(np.argmax(per_pixel)), per_pixel.shape)
    return {"max": float(error.max()), "pixels": int((per_pixel > 1e-6).sum()),
            "worst_pixel": tuple(int(v) for v in worst),
            "finite": bool(np.isfinite(a).all() and np.isfinite(b).all()),
            "same_nan": bool(np.array_equal(np.isnan(a), np.isnan(b))),
            "range": float(np.ptp(b[..., :3]))}
