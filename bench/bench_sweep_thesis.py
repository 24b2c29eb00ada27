"""Retondaro 2008's results (ch. 5: fig. 5.1-5.5, table 5.1) redone with the SweepPlaneRenderer
(RZSweep), and RZSweep beside the BrickedRayCaster and the RayCaster on the same data
(docs/explanations/sweep-plane.md, section "Measured", records the numbers).

    .venv/bin/python bench/bench_sweep_thesis.py [--image 800] [--repeat 2] [--sets mriHead ctSkull]
        [--levels 1 2] [--workers 1 2 4 8] [--compare-sizes 256] [--compare-image 256]
        [--psnr-image 128] [--reference-rate 16] [--store-sizes 512] [--store-budget 64]
        [--store-brick 64] [--quick]

Thesis set-up: threshold 40-80 (8-bit scalar values), 800 x 800 pixels, octree levels 1 and 2,
each frame after a rotation of the data (here: of the camera, a new angle each frame). Its data
sets are rebuilt from the shared volumes: each is mapped to 8-bit codes over its value range (the
thesis's Volvis data are 8-bit) and resampled (scipy.ndimage.zoom, linear) to the thesis's size,
keeping the physical extent. The TF is zero outside 40-80, so the threshold leaves the image as
it is and only removes work.

Tiles against leaves (frame time and bytes read per worker, --workers 1 2 4 8 as the thesis's
table 5.2, levels 1 and 2): the SweepPlaneRenderer on the `--split` route through
vgraph.distributed.render_report, which says what each worker's caches read; "not available" with
the reason where the route refuses. A second table: bytes and leaves read per worker and in all.

Side by side: at the --store-sizes (512^3: the in-memory sweep's float64 grid would take about
14 GiB) the SweepPlaneRenderer and the BrickedRayCaster read the volume converted to an OME-Zarr
store (bricks of --store-brick voxels) out of core, through a VolumeSource whose memory_budget is
--store-budget MiB (the sweep's leaves are the store's bricks); the RayCaster draws the volume in
memory (one 3D texture).

Timing: every variant draws one untimed warm-up frame (numba cache load, shader compile), then
the variants take turns frame by frame (bench/interleave.py). Peak memory: the resident high-water
mark (VmHWM) of a child process drawing one frame, above what it held after loading the volume
(GL driver included).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import ndimage
from tqdm import tqdm

from interleave import interleaved, spread
from vgraph.camera import Camera
from vgraph.io import read_volume
from vgraph.network import Network
from vgraph.numerics import reference_raycast
from vgraph.numerics.reference_boxes import volume_box
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LOW, HIGH = 40, 80  # the thesis's threshold, 8-bit codes
# Retondaro 2008 table 5.1: name -> (shared volume standing in for it, thesis size x y z, thesis
# vertices in millions). mriHead <- the T1 MRI head, ctSkull <- the CT head (headsq),
# ctBonsai+ <- the bonsai (the thesis doubled it along x, as here).
THESIS_SETS = {"mriHead": ("mri_head_t1/MR.nii.gz", (256, 256, 111), 6.94),
               "ctSkull": ("ct_head_headsq/quarter.nhdr", (256, 256, 256), 16.0),
               "ctBonsai+": ("ct_bonsai/bonsai.nii.gz", (512, 256, 256), 32.0)}
THESIS_TILES = {1: (1, 1), 2: (2, 1), 4: (2, 2), 8: (4, 2)}  # its table 5.2
TF = TransferFunction(points=[(0.0, 0, 0, 0, 0), (LOW / 255, 0.2, 0.6, 0.2, 0.0),
                              (HIGH / 255, 0.9, 0.8, 0.3, 0.4), ((HIGH + 0.5) / 255, 0, 0, 0, 0),
                              (1.0, 0, 0, 0, 0)])
THRESHOLD = [LOW / 255, HIGH / 255]
RENDERERS = ("SweepPlaneRenderer", "BrickedRayCaster", "RayCaster")


def thesis_volume(path: Path, dims_xyz) -> Volume:
    """``path`` as 8-bit codes over its value range, resampled to ``dims_xyz`` (x, y, z) over the
    same physical extent; value range declared 0-255 so that 40-80 means the thesis's codes."""
    source = read_volume(path)
    codes = np.clip(np.rint(source.normalized(source.data) * 255.0), 0, 255)
    shape = tuple(reversed(dims_xyz))  # the array is (z, y, x)
    zoomed = ndimage.zoom(codes, [n / m for n, m in zip(shape, codes.shape)], order=1) \
        if shape != codes.shape else codes
    extent = [s * (m - 1) for s, m in zip(source.spacing, reversed(codes.shape))]
    spacing = tuple(e / (n - 1) for e, n in zip(extent, dims_xyz))
    return Volume(np.clip(np.rint(zoomed), 0, 255).astype(np.uint8), spacing=spacing,
                  origin=source.origin, declared_range=(0.0, 255.0), source=str(path))


def cube(n: int) -> Volume:
    """The bonsai (256^3) resampled to n^3."""
    return thesis_volume(DATA / "ct_bonsai" / "bonsai.nii.gz", (n, n, n))


def network_of(renderer: str, volume: Volume, camera: Camera) -> Network:
    if renderer == "SweepPlaneRenderer":
        network = Network()
        network.add(GivenVolume(id="src", volume=volume))
        network.add(renderer, id="rc", camera=camera, transfer_function=TF, threshold=THRESHOLD)
        network.connect("src.volume", "rc.volume")
        return network
    extra = {"lod_bias": -16.0} if renderer == "BrickedRayCaster" else {"shading": "none"}  # finest level
    return ray_caster_network(volume, camera, renderer, transfer_function=TF, **extra)



def store_of(volume: Volume, folder: Path, brick: int) -> Path:
    """``volume`` converted to an OME-Zarr store in ``folder`` (bricks of ``brick`` voxels, one level:
    the sweep's leaves and the BrickedRayCaster's finest bricks), next to the grid.json the peak
    child reads."""
    from vgraph.io.convert import convert
    npy = folder / "volume.npy"
    np.save(npy, volume.data)
    store = folder / f"brick{brick}.zarr"
    convert(npy, store, brick=brick, levels=1, progress=False)
    npy.unlink()
    return store


def out_of_core_network(renderer: str, store: Path, volume: Volume, camera: Camera, budget_mib: float) -> Network:
    """``renderer`` over ``store`` read out of core by a VolumeSource (memory_budget ``budget_mib``),
    with ``volume``'s grid; the RayCaster draws ``volume`` in memory (network_of)."""
    if renderer == "RayCaster":
        return network_of(renderer, volume, camera)
    network = Network()
    network.add("VolumeSource", id="src", path=str(store), spacing=list(volume.spacing),
                origin=list(volume.origin), value_range=[0.0, 255.0], memory_budget=budget_mib)
    if renderer == "SweepPlaneRenderer":
        network.add(renderer, id="rc", camera=camera, transfer_function=TF, threshold=THRESHOLD, leaf_level=0)
        network.connect("src.volume", "rc.volume")
        return network
    network.add("EntryExitPoints", id="eep", camera=camera)
    network.add(renderer, id="rc", transfer_function=TF, lod_bias=-16.0)
    network.link("eep.camera", "rc.camera")
    for source, target in (("src.volume", "eep.volume"), ("src.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit")):
        network.connect(source, target)
    return network

def camera_owner(network: Network):
    return network.processors["eep" if "eep" in network.processors else "rc"]


def frame(network: Network, size):
    """frame(camera) -> seconds: one frame at a new camera (None: the warm-up's)."""
    def draw(camera):
        if camera is not None:
            camera_owner(network).camera = camera
        start = time.perf_counter()
        network.evaluate("rc.image", size=size)
        return time.perf_counter() - start
    return draw


def cameras(base: Camera, repeat: int) -> list[Camera]:
    return [base.rotate(0.4 * (k + 1), 0.1 * (k + 1)) for k in range(repeat)]


def bytes_read(renderer: str, network: Network, volume: Volume) -> str:
    """What the renderer read of the volume's data in its last frame."""
    if renderer == "SweepPlaneRenderer" and "leaves_swept" in network.processors["rc"].last_sweep:
        counts = network.processors["rc"].last_sweep
        return (f"{counts['bytes_read'] / 2**20:.1f} MiB ({counts['leaves_swept']} leaves read through the cache, "
                f"peak {counts['peak_cache_bytes'] / 2**20:.0f} MiB held)")
    if renderer == "SweepPlaneRenderer":
        return f"{volume.data.nbytes / 2**20:.0f} MiB (every voxel, classified each frame)"
    if renderer == "BrickedRayCaster":
        return f"{network.processors['rc'].last_frame.get('bytes', 0) / 2**20:.0f} MiB (bricks drawn)"
    return f"0 (texture resident; {volume.data.nbytes / 2**20:.0f} MiB uploaded once)"


def peak_memory_mib(renderer: str, volume: Volume, image: int, store: Path | None = None,
                    budget_mib: float = 0.0) -> str:
    """Peak resident memory a child process adds drawing one frame (run with --peak): the volume
    goes to it as a .npy, so that building it (resampling's float copies) sets no high-water mark;
    or, for a renderer reading ``store`` out of core, the store's path."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "volume.npy"
        np.save(path, volume.data)
        (Path(folder) / "grid.json").write_text(json.dumps({"spacing": volume.spacing, "origin": volume.origin,
                                                            "store": str(store) if store else None,
                                                            "budget_mib": budget_mib}))
        done = subprocess.run([sys.executable, __file__, "--peak", renderer, str(path), str(image)],
                              capture_output=True, text=True, cwd=Path(__file__).parent)
    if done.returncode != 0:
        return f"failed ({done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode})"
    return f"{json.loads(done.stdout.strip().splitlines()[-1])['peak_mib']:.0f}"


def peak_child(renderer: str, path: str, image: int) -> None:
    grid = json.loads((Path(path).parent / "grid.json").read_text())
    out_of_core = grid["store"] is not None and renderer != "RayCaster"
    volume = Volume(np.load(path, mmap_mode="r" if out_of_core else None), spacing=tuple(grid["spacing"]),
                    origin=tuple(grid["origin"]), declared_range=(0.0, 255.0))  # memory-mapped: grid only
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    network = out_of_core_network(renderer, Path(grid["store"]), volume, camera, grid["budget_mib"]) if out_of_core \
        else network_of(renderer, volume, camera)
    before = high_water_kib()
    network.evaluate("rc.image", size=(image, image))
    print(json.dumps({"peak_mib": (high_water_kib() - before) / 1024.0}))


def high_water_kib() -> int:
    """This process's peak resident memory (VmHWM). Not ru_maxrss: Linux carries that across
    fork and exec, so a child would start at its parent's peak."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # no /proc: the nearest thing


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64)[..., :3] - np.asarray(b, np.float64)[..., :3]) ** 2))
    return float("inf") if mse == 0.0 else 10.0 * np.log10(1.0 / mse)


def store_network(volume: Volume, camera: Camera, folder: Path, level: int) -> tuple[Network, int]:
    """VolumeSource (``volume`` converted to an OME-Zarr store whose bricks cut the full-resolution
    grid in 2^level along each axis: the thesis's octree level) -> SweepPlaneRenderer sweeping those
    bricks as its leaves; and the number of leaves. A network the split route can ship (a
    GivenVolume cannot be). No early termination: the leaves split refuses it (a run of leaves
    cannot know what the runs in front left), and tiles and leaves are compared on the same work."""
    from vgraph.io.convert import convert
    npy = folder / "volume.npy"
    if not npy.exists():
        np.save(npy, volume.data)
    brick = [max(2, 2 * -(-d // 2 ** (level + 1))) for d in volume.dims]  # even, ceil(d / 2^level)
    store = convert(npy, folder / f"level{level}.zarr", brick=brick, levels=1, progress=False)
    del store
    network = Network()
    network.add("VolumeSource", id="src", path=str(folder / f"level{level}.zarr"), spacing=list(volume.spacing),
                origin=list(volume.origin), value_range=[0.0, 255.0])
    network.add("SweepPlaneRenderer", id="rc", camera=camera, transfer_function=TF, threshold=THRESHOLD,
                early_termination=1.0, leaf_level=0)
    network.connect("src.volume", "rc.volume")
    return network, int(np.prod([-(-d // b) for d, b in zip(volume.dims, brick)]))


def split_columns(network: Network, size, workers: int) -> dict:
    """Tiles and leaves on ``workers`` local Dask workers (leaves: one run of leaves a worker):
    split -> (seconds, what each worker read in the first frame, in the timed frame: lists of
    (bytes, leaves) per worker), or (why not, None, None) where the route refuses. One timed frame
    each after a 64 x 64 warm-up (worker imports, numba cache load), which is the first, cold
    frame: it reads what the tiles or runs of leaves see (the same at any image size), and the
    workers keep their networks and caches, so the timed frame reads only what the caches' budget
    (the VolumeSource's memory_budget) let go."""
    from vgraph.distributed.render import prepare, render_report
    columns = {}
    for split in ("tiles", "leaves"):
        try:
            prepare(network, split, THESIS_TILES[workers], size, "rc.image")
        except Exception as error:  # the route's own refusal is the answer here
            columns[split] = (f"not available ({str(error).splitlines()[0][:100]})", None, None)
    if len(columns) == 2:
        return columns
    from dask.distributed import Client, LocalCluster
    for split in [s for s in ("tiles", "leaves") if s not in columns]:
        # A cluster of its own per split: workers keep their networks and caches, so the second
        # split's first frame would read only what the first split left out.
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True) as cluster, \
                Client(cluster) as client:
            try:
                options = dict(split=split, tiles=THESIS_TILES[workers], size=size, target="rc.image",
                               runs=workers if split == "leaves" else None)
                first = render_report(network, client, **{**options, "size": (64, 64)})  # warm-up, cold
                start = time.perf_counter()
                timed = render_report(network, client, **options)
                columns[split] = (f"{time.perf_counter() - start:.2f} s", per_worker(first, client),
                                  per_worker(timed, client))
            except Exception as error:
                columns[split] = (f"not available ({str(error).splitlines()[0][:100]})", None, None)
    return columns


def per_worker(frame, client) -> list[tuple[int, int]]:
    """(bytes, leaves) each worker of the cluster read in ``frame``, by address (a worker given no
    task: 0, 0)."""
    addresses = sorted(client.scheduler_info()["workers"])
    read = {address: (report.bytes_read, report.bricks_read) for address, report in frame.workers.items()}
    return [read.get(address, (0, 0)) for address in addresses]


def bytes_each(reads) -> str:
    """'a + b' in bytes units, one term a worker."""
    from vgraph.memory import format_bytes
    return " + ".join(format_bytes(b) for b, _ in reads)


def read_cells(seconds: str, reads) -> str:
    """The bytes-read table's cells of one split: leaves per worker | bytes per worker | in all | s."""
    if reads is None:
        return f"{seconds} | | |"
    from vgraph.memory import format_bytes
    leaves = " + ".join(str(n) for _, n in reads)
    total = f"{format_bytes(sum(b for b, _ in reads))} ({sum(n for _, n in reads)} leaves)"
    return f"{leaves} | {bytes_each(reads)} | {total} | {seconds}"


def thesis_rows(args) -> None:
    size = (args.image, args.image)
    print(f"\n## Thesis set-up: threshold {LOW}-{HIGH}, {args.image} x {args.image}, {args.repeat} frames "
          f"(new rotation each) after a warm-up, frames interleaved across data sets")
    volumes, networks = {}, {}
    for name in tqdm(args.sets, desc="volumes", file=sys.stderr):
        path, dims, _ = THESIS_SETS[name]
        dims = tuple(max(8, d // args.shrink) for d in dims)
        volumes[name] = thesis_volume(DATA / path, dims)
        base = Camera.looking_at_box(*volume_box(volumes[name]), direction=(-0.5, -0.3, -1.0))
        networks[name] = (network_of("SweepPlaneRenderer", volumes[name], base), base)
    if "times" in args.parts:
        single_process_rows(args, volumes, networks, size)
    if "splits" in args.parts:
        side = args.split_image or args.image
        split_rows(args, volumes, {name: base for name, (_, base) in networks.items()}, (side, side))


def single_process_rows(args, volumes, networks, size) -> None:
    base_cameras = {name: cameras(base, args.repeat) for name, (_, base) in networks.items()}
    variants = {name: frame(network, size) for name, (network, _) in networks.items()}
    # interleaved() hands every variant the same argument; each data set turns its own camera.
    rounds = list(range(args.repeat))
    seconds, _ = interleaved({name: (lambda k, name=name: variants[name](None if k is None else base_cameras[name][k]))
                              for name in variants}, rounds, None)
    print("\n| data (thesis size) | here: dims | vertices M (thesis) | swept M | faces M | frame s, 1 process "
          "(min / median / max) | thesis |")
    print("|---|---|---|---|---|---|---|")
    for name, volume in volumes.items():
        counts = networks[name][0].processors["rc"].last_sweep
        print(f"| {name} ({' x '.join(map(str, THESIS_SETS[name][1]))}) | {' x '.join(map(str, volume.dims))} | "
              f"{np.prod(volume.dims) / 1e6:.2f} ({THESIS_SETS[name][2]}) | {counts['vertices_swept'] / 1e6:.2f} | "
              f"{counts['faces_projected'] / 1e6:.2f} | {spread(seconds[name], 2)} | fig. 5.1-5.5: plotted only |")


def split_rows(args, volumes, bases, size) -> None:
    print(f"\nSplits on a Dask LocalCluster (one thread a worker), {size[0]} x {size[1]}, tiles as the thesis's "
          "table 5.2, leaves: one run a worker; no early termination; one frame after a 64 x 64 warm-up "
          "(the first, cold frame). Read per worker (vgraph.distributed.render_report): in the first "
          "frame, and in the timed frame (the workers keep their caches)")
    print("\n| data | octree level (leaves) | workers | tiles s | tiles: read per worker, first frame "
          "(timed frame) | leaves s | leaves: read per worker, first frame (timed frame) |")
    print("|---|---|---|---|---|---|---|")
    reads = []  # the bytes-read table's rows, printed after the first table
    for name, volume in volumes.items():
        with tempfile.TemporaryDirectory() as folder:
            for level in args.levels:
                try:
                    network, count = store_network(volume, bases[name], Path(folder), level)
                except Exception as error:
                    print(f"| {name} | {level} | - | not available ({str(error).splitlines()[0][:100]}) | | | |")
                    reads.append(f"| {name} | {level} | - | not available | | | | | | | |")
                    continue
                for workers in args.workers:
                    columns = split_columns(network, size, workers)
                    cells = [f"{seconds} | {bytes_each(first)} ({bytes_each(timed)})" if first else f"{seconds} | "
                             for seconds, first, timed in (columns["tiles"], columns["leaves"])]
                    print(f"| {name} | {level} ({count}) | {workers} | {' | '.join(cells)} |", flush=True)
                    reads.append(f"| {name} | {level} ({count}) | {workers} | "
                                 + " | ".join(read_cells(seconds, first) for seconds, first, _ in
                                              (columns["tiles"], columns["leaves"])) + " |")
    print("\nBytes read, the first (cold) frame: leaves and bytes per worker and in all (exact counts, "
          "whatever the cores), and the timed frame's seconds\n")
    print("| data | octree level (leaves) | workers | tiles: leaves per worker | tiles: bytes per worker | "
          "tiles: in all | tiles s | leaves: leaves per worker | leaves: bytes per worker | leaves: in all | "
          "leaves s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(reads), flush=True)


def comparison_rows(args) -> None:
    size, psnr_size = (args.compare_image, args.compare_image), (args.psnr_image, args.psnr_image)
    print(f"\n## RZSweep vs BrickedRayCaster vs RayCaster: bonsai resampled to n^3, TF and threshold "
          f"{LOW}-{HIGH} as above, {args.compare_image}^2, {args.repeat} interleaved frames after a warm-up; "
          f"PSNR (RGB) at {args.psnr_image}^2 against the CPU reference at rate {args.reference_rate}; "
          "early termination 0.99, no shading, BrickedRayCaster at its finest level; at "
          f"{args.store_sizes}: sweep and BrickedRayCaster out of core over a store of {args.store_brick}^3 "
          f"bricks, memory_budget {args.store_budget:g} MiB, the RayCaster in memory")
    print("\n| n^3 | renderer | frame s (min / median / max) | bytes read per frame | peak memory MiB | PSNR dB |")
    print("|---|---|---|---|---|---|")
    for n in args.compare_sizes:
        volume = cube(n)
        with tempfile.TemporaryDirectory() as folder:
            store = store_of(volume, Path(folder), args.store_brick) if n in args.store_sizes else None
            comparison_of_size(args, n, volume, store, size, psnr_size)


def comparison_of_size(args, n: int, volume: Volume, store: Path | None, size, psnr_size) -> None:
    base = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    networks = {renderer: network_of(renderer, volume, base) if store is None
                else out_of_core_network(renderer, store, volume, base, args.store_budget) for renderer in RENDERERS}
    seconds, _ = interleaved({r: frame(net, size) for r, net in networks.items()}, cameras(base, args.repeat), None)
    read = {r: bytes_read(r, net, volume) for r, net in networks.items()}
    start = time.perf_counter()
    exact = reference_raycast.render(volume, base, TF, psnr_size, sampling_rate=args.reference_rate)
    print(f"(reference at {n}^3: {time.perf_counter() - start:.1f} s)", file=sys.stderr)
    for renderer, network in tqdm(networks.items(), desc=f"{n}^3 psnr/peak", file=sys.stderr):
        camera_owner(network).camera = base
        image = network.evaluate("rc.image", size=psnr_size)
        peak = "not measured (--quick)" if args.quick else \
            peak_memory_mib(renderer, volume, args.compare_image, store, args.store_budget)
        where = " (out of core)" if store is not None and renderer != "RayCaster" else ""
        print(f"| {n}^3 | {renderer}{where} | {spread(seconds[renderer], 2)} | {read[renderer]} | {peak} | "
              f"{psnr(image, exact):.1f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--image", type=int, default=800, help="thesis rows: image side (the thesis: 800)")
    parser.add_argument("--split-image", type=int, default=None, help="split rows: image side (default --image)")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--sets", nargs="+", default=["mriHead", "ctSkull"], choices=list(THESIS_SETS))
    parser.add_argument("--shrink", type=int, default=1, help="divide the thesis sizes by this (quick runs)")
    parser.add_argument("--levels", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], choices=list(THESIS_TILES))
    parser.add_argument("--compare-sizes", type=int, nargs="+", default=[256])
    parser.add_argument("--compare-image", type=int, default=256)
    parser.add_argument("--psnr-image", type=int, default=128)
    parser.add_argument("--reference-rate", type=float, default=16.0)
    parser.add_argument("--store-sizes", type=int, nargs="*", default=[512],
                        help="compare sizes drawn out of core from a store (sweep, BrickedRayCaster)")
    parser.add_argument("--store-budget", type=float, default=64.0, help="the store's memory_budget, MiB")
    parser.add_argument("--store-brick", type=int, default=64, help="the store's brick (the sweep's leaf)")
    parser.add_argument("--parts", nargs="+", default=["times", "splits", "compare"],
                        choices=["times", "splits", "compare"])
    parser.add_argument("--quick", action="store_true", help="tiny sizes, for the test: seconds")
    parser.add_argument("--peak", nargs=3, metavar=("RENDERER", "NPY", "IMAGE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.peak:
        return peak_child(args.peak[0], args.peak[1], int(args.peak[2]))
    if args.quick:
        args.image, args.repeat, args.sets, args.shrink = 32, 1, ["mriHead"], 16
        args.levels, args.workers, args.compare_sizes = [1], [1], [16, 24]
        args.compare_image, args.psnr_image, args.reference_rate = 32, 16, 2.0
        args.store_sizes, args.store_brick, args.store_budget = [24], 8, 1.0
    print(f"settings: {vars(args)}; numba threads 1 (the sweep is serial)")
    if {"times", "splits"} & set(args.parts):
        thesis_rows(args)
    if "compare" in args.parts:
        comparison_rows(args)


if __name__ == "__main__":
    main()
