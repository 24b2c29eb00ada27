"""BrickedRayCaster levels of detail, error against frame time, with and without the error budget
(max_error): the ``bricked`` section of ``vgraph bench accuracy`` (docs/reports/accuracy.md,
"Bricked levels: error against frame time").

Transfer functions: smooth (a ramp over 0.3..1), stiff (a spike 0.02 wide at 0.45) and faint
(opacity 0.002..0.004, one colour: the regime where the bound lets levels coarsen). Rows per
volume and transfer function: every level 0..n drawn everywhere (``finest_level`` n with lod_bias
-16: every brick asks for level 0 and gets n), then the footprint asking for the coarsest level
(lod_bias 15) under max_error 1 (no budget), 0.5, 0.1 and 0.02. Each row gives the frame time
(median of ``repeat`` frames; the rows' frames are interleaved, one frame of each row per round
after a round that reads the bricks and compiles, each frame re-planned by nudging lod_bias by
1e-6 and back), the PSNR and max error
(vgraph.accuracy_common) against the level-0 frame, the reference here, and the frame's reported
bound (last_frame["error_bound"]). Unshaded dvr, no early termination, sampling rate 1.

Volumes: bonsai (ct_bonsai/bonsai.nii.gz, 256^3 uint8, shared data) and synthetic (the
Marschner-Lobb function sampled at 64^3 uint8 by vgraph.implicit: no data).
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vgraph.accuracy_common import (BONSAI, machine_line, max_error, plot_error_against_time, psnr,
                                    require_file, write_text)
from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.gl_context import get_context
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction

SMOOTH = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.4, 0.9, 0.0),
                                  (0.6, 1.0, 0.7, 0.2, 0.3), (1.0, 1, 1, 1, 0.6)])
STIFF = TransferFunction(points=[(0.0, 1.0, 0.8, 0.3, 0.0), (0.44, 1.0, 0.8, 0.3, 0.0),
                                 (0.45, 1.0, 0.8, 0.3, 0.8), (0.46, 1.0, 0.8, 0.3, 0.0),
                                 (1.0, 1.0, 0.8, 0.3, 0.0)])
FAINT = TransferFunction(points=[(0.0, 0.9, 0.8, 0.6, 0.0), (0.2, 0.9, 0.8, 0.6, 0.002),
                                 (1.0, 0.9, 0.8, 0.6, 0.004)])
TRANSFER_FUNCTIONS = {"smooth": SMOOTH, "stiff": STIFF, "faint": FAINT}
BUDGETS = (1.0, 0.5, 0.1, 0.02)
COARSEST = 15.0  # lod_bias asking every brick for the coarsest level
FINEST = -16.0  # lod_bias asking every brick for level 0 (finest_level then sets the level drawn)
VOLUMES = ("bonsai", "synthetic")
SYNTHETIC_RESOLUTION = 64
DEFAULTS = {"volumes": VOLUMES, "size": (192, 192), "repeat": 3, "brick": 32}
QUICK = {"volumes": ("synthetic",), "size": (96, 96), "repeat": 1, "brick": 16}
VIEW_DIRECTION = (-0.5, -0.3, -1.0)
COMMON = dict(compositing="dvr", shading="none", early_termination=1.0)


@dataclass(frozen=True)
class Row:
    volume: str
    tf: str
    label: str  # "level L" or "lod_bias 15, max_error B"
    ms: float  # median frame
    speedup: float  # level 0's ms / this row's
    psnr: float
    max_error: float
    bound: float | None
    levels: tuple
    bricks: int


# --- the cases -----------------------------------------------------------------------------------
def synthetic_volume():
    from vgraph.implicit import sample  # imported when used, as the curvature section does
    return sample("marschner_lobb", SYNTHETIC_RESOLUTION, "uint8")


def load_volume(name: str, bonsai: Path):
    if name == "synthetic":
        return f"Marschner-Lobb {SYNTHETIC_RESOLUTION}^3 uint8", synthetic_volume()
    from vgraph.io import read_volume  # imported when used: the readers take a while
    return f"bonsai ({bonsai.name})", read_volume(bonsai)


def camera_for(volume) -> Camera:
    return Camera.looking_at_box(*volume_box(volume), direction=VIEW_DIRECTION)


def check_options(volumes, repeat: int, brick: int, bonsai) -> None:
    """Refuse unknown names, bad numbers and a missing volume file before any measuring."""
    bad = [v for v in volumes if v not in VOLUMES]
    if bad or not volumes:
        raise VGraphError(f"--volumes: unknown {', '.join(map(repr, bad)) or '(none given)'}; "
                          f"choose from {', '.join(VOLUMES)}")
    if repeat < 1:
        raise VGraphError(f"--repeat must be at least 1, got {repeat}")
    if brick < 8:
        raise VGraphError(f"--brick must be at least 8 voxels, got {brick}")
    if "bonsai" in volumes:
        require_file(bonsai, "--bonsai")


def networks(volume, camera, tf, brick: int, levels: int):
    """(label, network, its lod_bias) of every row of one transfer function."""
    rows = [(f"level {level}", ray_caster_network(volume, camera, "BrickedRayCaster", lod_bias=FINEST,
                                                  finest_level=level, transfer_function=tf, brick_size=brick,
                                                  **COMMON), FINEST) for level in range(levels)]
    rows += [(f"lod_bias {COARSEST:g}, max_error {budget:g}",
              ray_caster_network(volume, camera, "BrickedRayCaster", lod_bias=COARSEST, max_error=budget,
                                 transfer_function=tf, brick_size=brick, **COMMON), COARSEST)
             for budget in BUDGETS]
    return rows


def frame(network, lod_bias: float, size, odd: bool):
    """One re-planned frame: (image, seconds, last_frame)."""
    network.set("rc.lod_bias", lod_bias + 1e-6 * odd)
    began = time.perf_counter()
    image = np.asarray(network.evaluate("rc.image", size=size))
    return image, time.perf_counter() - began, dict(network["rc"].last_frame)


# --- measuring -------------------------------------------------------------------------------------
def measure_tf(label, volume, camera, tf_name, tf, brick, size, repeat, bar) -> list[Row]:
    probe = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=brick)
    levels = len(probe["rc"].brick_source(volume).levels)
    table = networks(volume, camera, tf, brick, levels)
    times = {name: [] for name, *_ in table}
    frames = {}
    for round_ in range(repeat + 1):  # round 0 warms (reads the bricks, compiles)
        bar.set_postfix_str(f"{label} {tf_name}: round {round_} of {repeat}")
        for name, network, lod_bias in table:
            image, seconds, last = frame(network, lod_bias, size, bool(round_ % 2))
            if round_:
                times[name].append(seconds)
            frames[name] = image, last
    reference = frames["level 0"][0]
    base = statistics.median(times["level 0"])
    rows = []
    for name, *_ in table:
        image, last = frames[name]
        ms = 1e3 * statistics.median(times[name])
        rows.append(Row(label, tf_name, name, ms, 1e3 * base / ms, psnr(image, reference),
                        max_error(image, reference), last.get("error_bound"),
                        tuple(last.get("levels", ())), int(last.get("bricks", 0))))
    return rows


def run(volumes=VOLUMES, size=(192, 192), repeat: int = 3, brick: int = 32, bonsai=BONSAI,
        progress: bool = True) -> list[Row]:
    """Every volume x TF: the levels and the budgets (module docstring)."""
    check_options(volumes, repeat, brick, bonsai)
    rows = []
    with tqdm(total=len(volumes) * len(TRANSFER_FUNCTIONS), desc="bricked", unit="TF",
              disable=not progress) as bar:
        for name in volumes:
            label, volume = load_volume(name, Path(bonsai))
            camera = camera_for(volume)
            for tf_name, tf in TRANSFER_FUNCTIONS.items():
                rows += measure_tf(label, volume, camera, tf_name, tf, brick, size, repeat, bar)
                bar.update(1)
    return rows


# --- the report --------------------------------------------------------------------------------------
def _bound(value) -> str:
    return "—" if value is None else f"{value:.3g}"


def markdown(rows: list[Row], size, repeat: int, brick: int, bonsai=None) -> str:
    data = f" Data: {bonsai}." if bonsai is not None and any(r.volume.startswith("bonsai") for r in rows) else ""
    lines = ["# BrickedRayCaster levels: error against frame time\n",
             f"Settings: {size[0]} x {size[1]} pixels, {brick}^3 bricks, unshaded dvr, sampling rate 1, "
             f"no early termination; frame time the median of {repeat} interleaved frames; "
             f"{machine_line(get_context())}; PSNR over RGB in float and max over channels against "
             f"the level-0 frame.{data}\n",
             "| volume | TF | row | frame ms | × level 0 | PSNR dB | max error | bound | levels | bricks |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r.volume} | {r.tf} | {r.label} | {r.ms:.0f} | {r.speedup:.2f} | {r.psnr:.1f} | "
              f"{r.max_error:.3g} | {_bound(r.bound)} | {list(r.levels)} | {r.bricks} |" for r in rows]
    return "\n".join(lines) + "\n"


def _style(label: str):
    import matplotlib.pyplot as plt  # the plot has imported it
    if label.startswith("level"):
        level = int(label.split()[1])
        return plt.get_cmap("viridis")(min(level, 5) / 5), "o", label
    budget = float(label.rsplit(" ", 1)[1])
    return plt.get_cmap("autumn")(BUDGETS.index(budget) / len(BUDGETS)), "s", f"max_error {budget:g}"


def write(rows: list[Row], out: Path, size, repeat: int, brick: int, bonsai=None) -> list[Path]:
    """bricked.md and bricked.png (a column per volume and TF) in ``out``."""
    text = markdown(rows, size, repeat, brick, bonsai)
    write_text(out / "bricked.md", text)
    panels: dict = {}
    for r in rows:
        if r.label != "level 0":  # the reference itself
            panels.setdefault(f"{r.volume}, {r.tf}", []).append((r.label, r.ms, r.psnr, r.max_error))
    plot_error_against_time(panels, _style, out / "bricked.png", "frame (ms, median)")
    print(text)
    return [out / "bricked.md", out / "bricked.png"]
