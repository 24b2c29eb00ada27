"""What the error-against-time sections of ``vgraph bench accuracy`` share: the error measures
(PSNR and the largest error), the data files they read (with the defaults of a clone beside the
shared data), the settings line printed beside the numbers, and the plot of error against time.

Definitions:
- PSNR over RGB in float, 10 log10(1 / mse) (no 8-bit rounding; inf for identical images);
- max error: the largest |difference| of any RGB channel at any pixel.
"""

from __future__ import annotations

import io
import math
import os
import platform
from pathlib import Path

import numpy as np
import PIL.Image

from vgraph.atomic import atomic_path
from vgraph.errors import MeshFileError, VolumeFileError

# The shared meshes and volumes, relative to a clone's root (the clone lies beside ../shared).
SHARED_DATA = Path("../shared/data")
POST_MESH = SHARED_DATA / "tet_lox_post" / "post.vtk"
DISK_MESH = SHARED_DATA / "hex_disk_out_ref" / "disk_out_ref.vtu"
BONSAI = SHARED_DATA / "ct_bonsai" / "bonsai.nii.gz"
PSNR_CEILING = 130.0  # dB where a plot draws identical images (PSNR inf)
PLOT_COLUMNS = 4  # panels a row


def psnr(image, reference) -> float:
    """PSNR over RGB in float (module docstring)."""
    difference = np.asarray(image, np.float64)[..., :3] - np.asarray(reference, np.float64)[..., :3]
    mse = float(np.mean(difference ** 2))
    return math.inf if mse == 0.0 else 10.0 * math.log10(1.0 / mse)


def max_error(image, reference) -> float:
    """The largest |difference| of any RGB channel (module docstring)."""
    difference = np.asarray(image, np.float64)[..., :3] - np.asarray(reference, np.float64)[..., :3]
    return float(np.abs(difference).max())


def require_file(path, option: str, mesh: bool = False) -> Path:
    """``path`` if it is a file; else the error naming it and the option that chose it (before
    any measuring)."""
    path = Path(path)
    if not path.is_file():
        error = MeshFileError if mesh else VolumeFileError
        raise error(path, f"not found; the default lies in the shared data beside the clone "
                          f"({SHARED_DATA}), another file is given with {option}", option)
    return path


def machine_line(ctx) -> str:
    """Where the numbers were taken: CPU cores, the machine and the GL renderer."""
    return (f"{platform.machine()} with {os.cpu_count()} CPU cores, GL renderer "
            f"{ctx.info.get('GL_RENDERER', 'unknown')}")


def write_text(path: Path, text: str) -> None:
    with atomic_path(path) as temporary:
        Path(temporary).write_text(text)


def plot_error_against_time(panels: dict, series_style, path: Path, time_label: str) -> None:
    """A pair of plots per panel, PSNR above max error, against frame time (log x), up to
    PLOT_COLUMNS panels a row; an identical image (PSNR inf, max error 0) shows at PSNR_CEILING
    only; ``panels`` maps a title to a list of (series, ms, psnr, max error);
    ``series_style(series)`` gives (colour, marker, label) of a series."""
    import matplotlib  # imported when used: slow to import, and only the plots need it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    columns = max(1, min(PLOT_COLUMNS, len(panels)))
    rows = max(1, math.ceil(len(panels) / columns))
    figure, axes = plt.subplots(2 * rows, columns, figsize=(3.4 * columns, 5.0 * rows + 0.6), squeeze=False)
    legend = {}
    for k, (title, points) in enumerate(panels.items()):
        top, bottom = axes[2 * (k // columns), k % columns], axes[2 * (k // columns) + 1, k % columns]
        for series, ms, db, worst in points:
            colour, marker, label = series_style(series)
            legend[label] = top.scatter(ms, min(db, PSNR_CEILING), color=colour, marker=marker)
            if worst > 0:  # an identical image has no place on a log axis
                bottom.scatter(ms, worst, color=colour, marker=marker)
        top.set_title(title, fontsize=8)
        top.set_ylabel(f"PSNR (dB; identical at {PSNR_CEILING:g})", fontsize=7)
        bottom.set_ylabel("max error", fontsize=7)
        bottom.set_xlabel(time_label, fontsize=7)
        errors = [worst for *_, worst in points if worst > 0]
        bottom.set_yscale("log")
        if errors:  # whole decades, at least one: readable ticks however close the errors are
            low = math.floor(math.log10(min(errors) / 1.5))
            bottom.set_ylim(10.0 ** low, 10.0 ** max(math.ceil(math.log10(max(errors) * 1.5)), low + 1))
        bottom.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        times = [ms for _, ms, *_ in points]
        for axis in (top, bottom):
            _log_time_axis(axis, times)
    for k in range(len(panels), rows * columns):
        axes[2 * (k // columns), k % columns].axis("off")
        axes[2 * (k // columns) + 1, k % columns].axis("off")
    figure.legend(list(legend.values()), list(legend), loc="lower center", ncol=min(len(legend), 5),
                  fontsize=7, frameon=False)
    figure.tight_layout(rect=(0, 0.6 / (5.0 * rows + 0.6) + 0.03, 1, 1))
    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=90)
    plt.close(figure)
    with PIL.Image.open(buffer) as image, atomic_path(path) as temporary:
        image.convert("RGB").quantize(256).save(temporary, format="PNG", optimize=True)  # a third of the bytes


def _log_time_axis(axis, times) -> None:
    """A log time axis spanning at least a factor of 10 around ``times``, ticks at 1, 2, 5."""
    from matplotlib import ticker
    axis.set_xscale("log")
    if times:
        low, high = min(times), max(times)
        middle = math.sqrt(max(low, 1e-3) * max(high, 1e-3))
        axis.set_xlim(min(low / 1.3, middle / 3.2), max(high * 1.3, middle * 3.2))
    axis.xaxis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.xaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
    axis.xaxis.set_minor_formatter(ticker.NullFormatter())
    axis.tick_params(labelsize=7)
    axis.grid(True, lw=0.3, alpha=0.5)
