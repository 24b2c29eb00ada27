"""Inácio 2009 table 4.2 redone: frames per second of the GL ray caster at 128^2 .. 1024^2 for an
opaque and a fully transparent transfer function, with the CPU reference ray caster beside it and
the GL / CPU speed ratio (Inácio 2009 ch. 4.2.4 found its GPU ~3000x faster than its CPU).

    .venv/bin/python bench/bench_raycast_table.py [--volume bonsai|torus]
        [--sizes 128 256 512 1024] [--repeat 5] [--cpu-sizes 128 256 512 1024]
        [--cpu-repeat 2] [--cameras A B] [--out bench/results]
        [--plot docs/images/performance_raycast_fps.png]

Conventions:
- As in the seed: opaque = opacity 1 at every intensity (early ray termination after the first
  sample), transparent = opacity 0 at every intensity (no ray ever terminates). Two cameras:
  A looks along -z at the box, B obliquely; both frame the box's bounding sphere (perspective,
  30 degree field of view), sampling rate 1 (step = smallest spacing), DVR, no shading.
- GL frame: both EntryExitPoints passes and the RayCaster pass, until glFinish returns: the image
  is complete in its texture, as in the seed (render to texture). EntryExitPoints is invalidated
  each frame, so no pass is reused. Reading the RGBA32F image back is timed apart. Transparent
  is timed twice: with empty-space skipping off, where every ray takes every sample (the seed's
  measurement), and with it on (our default: a TF with no opacity makes every block empty, so
  rays jump to the exit). Opaque leaves skipping on; it switches itself off (no block is empty).
- CPU frame: one call of vgraph.numerics.reference_raycast.render (numpy, float64, rays in chunks
  of 65536, one thread), the same model; it includes that function's set-up (rays, box clipping,
  a normalised float64 copy of the volume), which dominates the opaque frames.
- fps = 1 / best seconds of --repeat frames (after one untimed frame that compiles and uploads).
  Ratio = GL fps / CPU fps (transparent: GL without skipping, both then take every sample).

Writes bench/results/raycast_table_<volume>.md and .png (fps against image size) and the plot to
--plot. Timings on shared machines vary up to 2x between runs: compare within one run.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_vtk import small_png  # noqa: E402
from raycaster_speed import BONSAI, load_bonsai, network  # noqa: E402

from vgraph.camera import Camera  # noqa: E402
from vgraph.gl_context import get_context  # noqa: E402
from vgraph.implicit import sample  # noqa: E402
from vgraph.numerics.reference_raycast import render, volume_box  # noqa: E402
from vgraph.transfer_function import TransferFunction  # noqa: E402
from vgraph.volume import Volume  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OPAQUE = TransferFunction(points=[(0.0, 0.9, 0.8, 0.7, 1.0), (1.0, 1.0, 1.0, 1.0, 1.0)])
TRANSPARENT = TransferFunction(points=[(0.0, 0.9, 0.8, 0.7, 0.0), (1.0, 1.0, 1.0, 1.0, 0.0)])
CAMERAS = {"A": (0.0, 0.0, -1.0), "B": (-0.45, -0.35, -1.0)}  # viewing directions
# Inácio 2009 table 4.2, fps on a GeForce 9800M GS (2009), 512x512x460 CT in fp16: quoted for the plot.
SEED_TABLE = {("A", "opaque"): (519.5, 251.5, 124.3, 55.4),
              ("A", "transparent"): (34.7, 15.3, 7.8, 2.6),
              ("B", "opaque"): (469.3, 235.2, 112.6, 53.5),
              ("B", "transparent"): (21.5, 9.4, 5.45, 2.3)}
SEED_SIZES = (128, 256, 512, 1024)
# (row label, renderer, TF name, skipping)
ROWS = [("GL opaque", "gl", "opaque", True),
        ("GL transparent, no skipping", "gl", "transparent", False),
        ("GL transparent, skipping", "gl", "transparent", True),
        ("CPU opaque", "cpu", "opaque", None),
        ("CPU transparent", "cpu", "transparent", None)]
TFS = {"opaque": OPAQUE, "transparent": TRANSPARENT}


def load_volume(name: str) -> Volume:
    if name == "bonsai":
        if not BONSAI.is_file():
            raise SystemExit(f"{BONSAI} not found: use --volume torus")
        return load_bonsai()
    return sample("torus", 256, "float32")


def gl_seconds(net, size: int, repeat: int) -> tuple[float, float, float, float]:
    """Best seconds of ``repeat`` GL frames, the mean samples per covered pixel, the total samples
    of a frame (the depth output's counter) and the best seconds of reading the image back."""
    shape = (size, size)
    ctx = get_context()
    net.evaluate("rc.image", size=shape)  # untimed: compile, upload, build blocks
    seconds, read_back = [], []
    for _ in range(repeat):
        net.invalidate_downstream("eep")
        start = time.perf_counter()
        net.update("rc.image", size=shape)
        ctx.finish()  # GL returns before llvmpipe has drawn: wait for the image
        seconds.append(time.perf_counter() - start)
        start = time.perf_counter()
        net.output("rc.image").to_numpy()
        read_back.append(time.perf_counter() - start)
    depth = net.evaluate("rc.depth", size=shape)
    covered = net.evaluate("eep.entry", size=shape)[..., 3] > 0
    counts = depth[..., 2][covered]
    return min(seconds), float(counts.mean()), float(counts.sum()), min(read_back)


def cpu_seconds(volume, camera, tf, size: int, repeat: int) -> tuple[float, float, float]:
    seconds = []
    # Untimed: after GL work the first calls pay page faults for the float64 copy (0.2-0.5 s).
    for _ in range(2):
        render(volume, camera, tf, (16, 16))
    for _ in range(repeat):
        start = time.perf_counter()
        _, taken = render(volume, camera, tf, (size, size), return_samples=True)
        seconds.append(time.perf_counter() - start)
    return min(seconds), float(taken[taken > 0].mean()), float(taken.sum()), 0.0


def measure(args, volume: Volume) -> dict:
    """{(camera, row label, size): (seconds, samples per covered pixel, samples, read-back s)}."""
    results = {}
    cells = [(c, row, s) for c in args.cameras for row in ROWS
             for s in (args.cpu_sizes if row[1] == "cpu" else args.sizes)]
    cameras = {c: Camera.looking_at_box(*volume_box(volume), direction=CAMERAS[c])
               for c in args.cameras}
    net = network(volume, cameras[args.cameras[0]])
    for camera_name, (label, kind, tf_name, skipping), size in tqdm(cells, desc="cells"):
        camera = cameras[camera_name]
        if kind == "gl":
            net.set("eep.camera", camera)
            net.set("rc.transfer_function", TFS[tf_name])
            net.set("rc.empty_space_skipping", skipping)
            results[camera_name, label, size] = gl_seconds(net, size, args.repeat)
        else:
            results[camera_name, label, size] = cpu_seconds(volume, camera, TFS[tf_name], size,
                                                            args.cpu_repeat)
    return results


def markdown(results: dict, args, description: str) -> str:
    sizes = sorted(set(args.sizes) | set(args.cpu_sizes))
    head = "| camera | renderer, TF | " + " | ".join(f"{s}^2" for s in sizes) + " | samples/pixel |"
    lines = [description, "", "Frames per second (best of the runs):", "", head,
             "|---|---|" + "---|" * (len(sizes) + 1)]
    for camera in args.cameras:
        for label, *_ in ROWS:
            cells = [results.get((camera, label, s)) for s in sizes]
            fps = [f"{1.0 / c[0]:.3g}" if c else "" for c in cells]
            per_pixel = next((f"{c[1]:.0f}" for c in cells if c), "")
            lines.append(f"| {camera} | {label} | " + " | ".join(fps) + f" | {per_pixel} |")
    lines += ["", "Speed ratio GL / CPU (fps over fps; transparent: GL without skipping):", "",
              "| camera | TF | " + " | ".join(f"{s}^2" for s in sizes) + " |",
              "|---|---|" + "---|" * len(sizes)]
    for camera in args.cameras:
        for tf_name, gl_label in (("opaque", "GL opaque"),
                                  ("transparent", "GL transparent, no skipping")):
            ratios = []
            for s in sizes:
                gl = results.get((camera, gl_label, s))
                cpu = results.get((camera, f"CPU {tf_name}", s))
                ratios.append(f"{cpu[0] / gl[0]:.0f}" if gl and cpu else "")
            lines.append(f"| {camera} | {tf_name} | " + " | ".join(ratios) + " |")
    reads = [results.get((args.cameras[0], "GL opaque", s)) for s in sizes]
    lines += ["", "GL read-back of the RGBA32F image (not in the frames; ms): " + ", ".join(
        f"{s}^2 {c[3] * 1e3:.1f}" for s, c in zip(sizes, reads) if c)]
    lines += ["", "Samples per second, transparent (every sample; million/s):", ""]
    for camera in args.cameras:
        parts = []
        for label in ("GL transparent, no skipping", "CPU transparent"):
            for s in sizes:
                cell = results.get((camera, label, s))
                if cell:
                    parts.append(f"{label.split()[0]} {s}^2: {cell[2] / cell[0] / 1e6:.1f}")
        lines.append(f"- camera {camera}: " + ", ".join(parts))
    return "\n".join(lines) + "\n"


def plot(results: dict, args, paths: list[Path], title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8.4, 4.2), dpi=80)
    styles = {"GL opaque": ("C0", "o"), "GL transparent, no skipping": ("C1", "s"),
              "GL transparent, skipping": ("C2", "^"), "CPU opaque": ("C3", "o"),
              "CPU transparent": ("C4", "s")}
    for camera, line in zip(args.cameras, ("-", "--")):
        for label, (colour, marker) in styles.items():
            sizes = [s for s in sorted(set(args.sizes) | set(args.cpu_sizes))
                     if (camera, label, s) in results]
            fps = [1.0 / results[camera, label, s][0] for s in sizes]
            ax.plot(sizes, fps, line, color=colour, marker=marker, markersize=4,
                    label=f"{label} ({camera})")
    for (camera, tf_name), fps in SEED_TABLE.items():
        if camera == args.cameras[0]:
            ax.plot(SEED_SIZES, fps, ":", color="grey", marker="x" if tf_name == "opaque" else "+",
                    label=f"Inácio 2009 GeForce 9800M, {tf_name} ({camera})")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xticks(SEED_SIZES, [f"{s}²" for s in SEED_SIZES])
    ax.set_xlabel("image size (pixels)")
    ax.set_ylabel("frames per second")
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    for path in paths:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path)
        small_png(path)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", choices=["bonsai", "torus"], default="bonsai")
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512, 1024])
    parser.add_argument("--repeat", type=int, default=5, help="GL frames per cell (best is kept)")
    parser.add_argument("--cpu-sizes", type=int, nargs="+", default=[128, 256, 512, 1024])
    parser.add_argument("--cpu-repeat", type=int, default=2, help="CPU frames per cell")
    parser.add_argument("--cameras", nargs="+", choices=sorted(CAMERAS), default=["A", "B"])
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results")
    parser.add_argument("--plot", type=Path,
                        default=ROOT / "docs" / "images" / "performance_raycast_fps.png")
    args = parser.parse_args()
    volume = load_volume(args.volume)
    name = "ct_bonsai 256^3 uint8" if args.volume == "bonsai" else "torus SDF 256^3 float32"
    description = (f"{name}, DVR, sampling rate 1, no shading; GL best of {args.repeat}, "
                   f"CPU reference best of {args.cpu_repeat}")
    results = measure(args, volume)
    text = markdown(results, args, description)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"raycast_table_{args.volume}.md").write_text(text)
    plot(results, args, [args.out / f"raycast_table_{args.volume}.png", args.plot],
         f"{name}: GL (llvmpipe) and CPU reference, fps vs image size")


if __name__ == "__main__":
    main()
