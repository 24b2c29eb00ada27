"""Reports of ``vgraph bench accuracy``: CSV, markdown tables, the error-against-time plot, the
Cabral 2010 figures 6.1 (derivative modes) and 6.4 (8/16/32 bit) with their numbers, and the command.

Files written to --out (default bench/results/accuracy/):
  accuracy.csv       one row per case (vgraph.accuracy.Result.row: errors, hits, times)
  accuracy.md        summary (targets, comparisons) and the full table
  accuracy.png       log-log: median relative error of k1 against ms per frame, one panel per function
  fig6_1_derivatives.png, fig6_4_precision.png   the seed's figures; numbers in accuracy.md
Numbers are relative errors (vgraph.accuracy explains the definition) and milliseconds per frame.
"""

from __future__ import annotations

import csv
import io
import math
import sys
from pathlib import Path

import numpy as np
import PIL.Image
import PIL.ImageDraw

from vgraph import accuracy
from vgraph.accuracy import MEASURES, MODES, Case, Result, Stats
from vgraph.accuracy_common import write_text
from vgraph.atomic import atomic_path
from vgraph.camera import Camera
from vgraph.errors import VGraphError

DEFAULT_OUT = Path("bench/results/accuracy")
TARGET = Case("torus", 64, "float32", "tricubic")  # the target case
TARGET_MEDIAN, TARGET_P95 = 5e-3, 2e-2
FIGURE_BACKGROUND = (0.08, 0.08, 0.1, 1.0)
FIGURE_PANEL = 192  # pixels, at most
# The figures look down the torus's axis, tilted by 11 degrees, like the seed's fig. 6.1: the zero
# contour of K (the top circle) then shows the modes' error patterns as distortions of a circle.
FIGURE_DIRECTION = (0.0, -0.2, -1.0)
COLORS = {"forward": "tab:red", "central": "tab:orange", "filtered": "tab:olive",
          "tricubic": "tab:blue", "tricubic_fast": "tab:cyan", "cpu": "black"}
MARKERS = {"uint8": "^", "uint16": "s", "float32": "o"}


# --- tables --------------------------------------------------------------------------------------------
def write_csv(results: list[Result], path: Path) -> None:
    rows = [r.row() for r in results]
    with atomic_path(path) as temporary, open(temporary, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]) if rows else ["function"])
        writer.writeheader()
        writer.writerows(rows)


def read_csv(path: Path) -> list[Result]:
    """The results of a written accuracy.csv (to rebuild tables and the plot without measuring)."""
    results = []
    with open(path, newline="") as handle:
        for row in csv.DictReader(handle):
            case = Case(row["function"], int(row["resolution"]), row["data_type"], row["derivatives"])
            errors = {m: Stats(*(float(row[f"{m}_{s}"]) for s in Stats._fields)) for m in MEASURES}
            distance = Stats(float(row["distance_median"]), math.nan, float(row["distance_max"]))
            results.append(Result(case, int(row["hits"]), int(row["undefined"]), int(row["excluded"]),
                                  errors, distance, float(row["ms_best"]), float(row["ms_median"]),
                                  float(row["cpu_ms"]), (int(row["width"]), int(row["height"]))))
    return results


def _e(value: float) -> str:
    return "—" if not math.isfinite(value) else f"{value:.1e}"


def full_table(results: list[Result]) -> str:
    """Every case: median / 95th percentile / max of each measure, hits and times."""
    head = ["function", "res", "data", "derivatives", "hits"]
    head += [f"{m} {s}" for m in MEASURES for s in ("median", "p95", "max")]
    head += ["ms best", "ms median", "CPU ms"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        cells = [r.case.function, str(r.case.resolution), r.case.data_type, r.case.derivatives,
                 str(r.hits)]
        cells += [_e(v) for m in MEASURES for v in r.errors[m]]
        cells += [f"{r.ms_best:.1f}", f"{r.ms_median:.1f}", f"{r.cpu_ms:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def pivot(results: list[Result], data_type: str, value) -> str:
    """Rows function x resolution, one column per derivative mode, cells value(result)."""
    modes = [m for m in MODES if any(r.case.derivatives == m for r in results)]
    by_key = {(r.case.function, r.case.resolution, r.case.derivatives): r
              for r in results if r.case.data_type == data_type}
    rows = sorted({(f, n) for f, n, _ in by_key}, key=lambda k: (results_order(results, k[0]), k[1]))
    lines = ["| function | res | " + " | ".join(modes) + " |", "|---|---|" + "---|" * len(modes)]
    for function, resolution in rows:
        cells = [value(by_key[key]) if (key := (function, resolution, m)) in by_key else "—"
                 for m in modes]
        lines.append(f"| {function} | {resolution} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def results_order(results: list[Result], function: str) -> int:
    return [r.case.function for r in results].index(function)


def find(results: list[Result], case: Case) -> Result | None:
    return next((r for r in results if r.case == case), None)


def target_lines(results: list[Result]) -> list[str]:
    """The issue's targets on the torus 64^3 float32, if the matrix holds the cases."""
    lines = []
    target = find(results, TARGET)
    if target is not None:
        k1 = target.errors["k1"]
        verdict = "met" if k1.median < TARGET_MEDIAN and k1.p95 < TARGET_P95 else "NOT met"
        lines.append(f"- Target (torus 64^3 float32, tricubic, k1): median {k1.median:.2%} "
                     f"(< 0.5 %), 95th percentile {k1.p95:.2%} (< 2 %): **{verdict}**.")
    others = {m: find(results, Case(TARGET.function, TARGET.resolution, TARGET.data_type, m))
              for m in ("forward", "central", "tricubic_fast", "cpu")}
    if target is not None and others["central"] is not None and others["forward"] is not None:
        t, c, f = (r.errors["k1"].median for r in (target, others["central"], others["forward"]))
        order = "holds" if t < c < f else "does NOT hold"
        lines.append(f"- Order tricubic < central < forward (k1 median) {order}: {t:.1e} < {c:.1e} "
                     f"< {f:.1e}; central/tricubic {c / t:.1f}x, forward/central {f / c:.1f}x; "
                     f"time {target.ms_best:.0f} / {others['central'].ms_best:.0f} / "
                     f"{others['forward'].ms_best:.0f} ms (best).")
    fast = others["tricubic_fast"]
    if target is not None and fast is not None:
        lines.append(f"- tricubic_fast: k1 median {fast.errors['k1'].median:.2e} (tricubic "
                     f"{target.errors['k1'].median:.2e}), {fast.ms_best:.0f} ms against "
                     f"{target.ms_best:.0f} ms (best), CPU {fast.cpu_ms:.0f} against "
                     f"{target.cpu_ms:.0f} ms.")
    if others["cpu"] is not None:
        k1 = others["cpu"].errors["k1"]
        lines.append(f"- CPU reference at the same hits: k1 median {k1.median:.2%}, "
                     f"95th percentile {k1.p95:.2%}.")
    return lines


def fast_against_direct(results: list[Result]) -> str:
    """Per resolution over all functions and data types: time ratios fast / direct, and how far
    the k1 medians differ (absolutely for float32, where the errors are smallest; relatively for
    the integer types, where quantisation makes them large)."""
    lines = ["| res | cases | time fast / direct (median of the cases; wall, best) "
             "| CPU time fast / direct | float32: largest \\|Δ k1 median\\| "
             "| uint8, uint16: largest relative Δ k1 median |", "|---|---|---|---|---|---|"]
    for resolution in sorted({r.case.resolution for r in results}):
        pairs = [(r, fast) for r in results if r.case.resolution == resolution
                 and r.case.derivatives == "tricubic"
                 and (fast := find(results, Case(r.case.function, r.case.resolution,
                                                 r.case.data_type, "tricubic_fast"))) is not None]
        if not pairs:
            continue
        wall = np.median([f.ms_best / d.ms_best for d, f in pairs])
        cpu = np.median([f.cpu_ms / d.cpu_ms for d, f in pairs])
        delta = [abs(f.errors["k1"].median - d.errors["k1"].median) for d, f in pairs
                 if d.case.data_type == "float32"]
        relative = [abs(f.errors["k1"].median / d.errors["k1"].median - 1) for d, f in pairs
                    if d.case.data_type != "float32"]
        lines.append(f"| {resolution} | {len(pairs)} | {wall:.2f} | {cpu:.2f} | "
                     f"{_e(max(delta, default=math.nan))} | {_e(max(relative, default=math.nan))} |")
    return "\n".join(lines)


def summary_markdown(results: list[Result], size, repeat: int) -> str:
    parts = ["# Curvature accuracy against frame time\n",
             f"Image {size[0]} x {size[1]}, times best/median of {repeat} frames "
             f"(llvmpipe); errors relative (vgraph.accuracy).\n", *target_lines(results), ""]
    for data_type in ("float32", "uint16", "uint8"):
        if any(r.case.data_type == data_type for r in results):
            parts += [f"\n## k1 median relative error, {data_type}\n",
                      pivot(results, data_type, lambda r: _e(r.errors["k1"].median)),
                      f"\n## ms per frame (best), {data_type}\n",
                      pivot(results, data_type, lambda r: f"{r.ms_best:.0f}")]
    fast = fast_against_direct(results)
    if fast.count("\n") > 1:
        parts += ["\n## tricubic_fast against tricubic\n", fast]
    parts += ["\n## All cases\n", full_table(results)]
    return "\n".join(parts) + "\n"


# --- plot ------------------------------------------------------------------------------------------------
def write_plot(results: list[Result], path: Path) -> None:
    """Log-log median k1 error against ms per frame; a line per (mode, data type) through the
    resolutions (marker size grows with resolution)."""
    import matplotlib  # imported when used: slow to import, and only this plot needs it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import ticker
    functions = list(dict.fromkeys(r.case.function for r in results))
    columns = min(2, len(functions))
    rows = math.ceil(len(functions) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(5.2 * columns, 4.2 * rows), squeeze=False)
    for ax, function in zip(axes.flat, functions):
        for mode in MODES:
            for data_type, marker in MARKERS.items():
                line = sorted((r for r in results if r.case.function == function and
                               r.case.derivatives == mode and r.case.data_type == data_type
                               and r.errors["k1"].median > 0), key=lambda r: r.case.resolution)
                if not line:
                    continue
                x = [r.ms_best for r in line]
                y = [r.errors["k1"].median for r in line]
                ax.plot(x, y, "-", color=COLORS[mode], lw=0.8, alpha=0.6)
                ax.scatter(x, y, s=[8 + r.case.resolution / 4 for r in line], marker=marker,
                           color=COLORS[mode], zorder=3)
                if data_type == "float32" and mode == "tricubic":
                    for r in line:
                        ax.annotate(f"{r.case.resolution}³", (r.ms_best, r.errors["k1"].median),
                                    textcoords="offset points", xytext=(4, -10), fontsize=7)
        ax.set(xscale="log", yscale="log", title=function, xlabel="ms per frame (best)",
               ylabel="median relative error of k1")
        ax.xaxis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.xaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(ticker.NullFormatter())
        ax.grid(True, which="major", lw=0.4, alpha=0.5)
    for ax in list(axes.flat)[len(functions):]:
        ax.axis("off")
    handles = [plt.Line2D([], [], color=c, marker="o", ls="-", label=m + (" (evaluation only)"
                                                                         if m == "cpu" else ""))
               for m, c in COLORS.items() if any(r.case.derivatives == m for r in results)]
    handles += [plt.Line2D([], [], color="grey", marker=k, ls="", label=t) for t, k in MARKERS.items()
                if any(r.case.data_type == t for r in results)]
    handles.append(plt.Line2D([], [], color="none", label="marker size: resolution"))
    figure.legend(handles=handles, loc="lower center", ncol=min(len(handles), 5), fontsize=8,
                  frameon=False)
    figure.tight_layout(rect=(0, 0.08 if rows > 1 else 0.14, 1, 1))
    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=80)
    plt.close(figure)
    with PIL.Image.open(buffer) as image:  # a 256-colour palette: a third of the bytes
        with atomic_path(path) as temporary:
            image.convert("RGB").quantize(256).save(temporary, format="PNG", optimize=True)


# --- the seed's figures ------------------------------------------------------------------------------------
FIGURES = {
    "fig6_1_derivatives": [[("float32", 32, m) for m in ("forward", "central", "filtered", "tricubic")]],
    "fig6_4_precision": [[(t, n, "tricubic") for t in ("uint8", "uint16", "float32")] for n in (32, 64)],
}


def render_figures(out: Path, panel: int, repeat: int) -> dict[str, list[tuple[np.ndarray, Result]]]:
    """Torus panels of the seed's fig. 6.1 and 6.4 (Gaussian curvature, JET, zero contour), each
    measured like a benchmark case at the panel's size; writes the PNGs to ``out``."""
    camera = Camera.looking_at_box(*accuracy.VIEW_BOXES["torus"], direction=FIGURE_DIRECTION)
    figures = {}
    for name, grid in FIGURES.items():
        measured = []
        for row in grid:
            for data_type, resolution, mode in row:
                net = accuracy.build_network("torus", resolution, data_type, camera,
                                             background=FIGURE_BACKGROUND, shading="none")
                case = Case("torus", resolution, data_type, mode)
                result, _ = accuracy.measure_gpu(net, case, camera, (panel, panel), repeat)
                image = net.evaluate("cr.image", size=(panel, panel))
                measured.append((np.clip(image[..., :3], 0.0, 1.0), result))
        write_grid(measured, len(grid[0]), out / f"{name}.png")
        figures[name] = measured
    return figures


def write_grid(panels, columns: int, path: Path) -> None:
    """Panels in a grid with a two-line caption under each (8-bit RGB PNG)."""
    size = panels[0][0].shape[0]
    band = 28
    rows = math.ceil(len(panels) / columns)
    canvas = PIL.Image.new("RGB", (size * columns, (size + band) * rows), (255, 255, 255))
    draw = PIL.ImageDraw.Draw(canvas)
    for k, (pixels, result) in enumerate(panels):
        x, y = (k % columns) * size, (k // columns) * (size + band)
        canvas.paste(PIL.Image.fromarray((pixels * 255 + 0.5).astype(np.uint8)), (x, y))
        c = result.case
        draw.text((x + 4, y + size + 2), f"{c.derivatives}, {c.resolution}^3 {c.data_type}",
                  fill=(0, 0, 0))
        draw.text((x + 4, y + size + 14), f"median error k1 {percent(result.errors['k1'].median)}, "
                  f"K {percent(result.errors['K'].median)}", fill=(0, 0, 0))
    with atomic_path(path) as temporary:
        canvas.save(temporary, format="PNG", optimize=True)


def percent(value: float) -> str:
    return f"{100 * value:.2g} %"


def figures_markdown(figures) -> str:
    parts = []
    for name, measured in figures.items():
        parts += [f"\n## {name}\n", "| panel | hits | k1 median | k1 p95 | K median | K p95 | "
                  "H median | ms best |", "|---|---|---|---|---|---|---|---|"]
        for _, r in measured:
            c = r.case
            parts.append(f"| {c.derivatives}, {c.resolution}³ {c.data_type} | {r.hits} | "
                         f"{_e(r.errors['k1'].median)} | {_e(r.errors['k1'].p95)} | "
                         f"{_e(r.errors['K'].median)} | {_e(r.errors['K'].p95)} | "
                         f"{_e(r.errors['H'].median)} | {r.ms_best:.1f} |")
    return "\n".join(parts) + "\n"


# --- the command -------------------------------------------------------------------------------------------
def options(args) -> dict:
    """The matrix from the command line: given options, else --quick's or the full defaults."""
    base = accuracy.QUICK if getattr(args, "quick", False) else accuracy.DEFAULTS
    chosen = {key: getattr(args, key, None) for key in base}
    return {key: tuple(value) if isinstance(value, list) else value
            for key, value in ((k, base[k] if v is None else v) for k, v in chosen.items())}


def checked_options(args) -> dict:
    """The matrix of the command line, refused (VGraphError) before any work if it is wrong."""
    matrix = options(args)
    if matrix["repeat"] < 1:
        raise VGraphError(f"--repeat must be at least 1, got {matrix['repeat']}")
    accuracy.check_matrix(*(matrix[k] for k in ("functions", "resolutions", "data_types",
                                                "derivatives")))
    return matrix


def measure_and_write(matrix: dict, out: Path) -> list[Path]:
    """Measure the matrix, print the summary, write the files into ``out``; their paths."""
    out.mkdir(parents=True, exist_ok=True)
    results = accuracy.run(**matrix)
    panel = min(matrix["size"][1], FIGURE_PANEL)
    figures = render_figures(out, panel, matrix["repeat"])
    summary = summary_markdown(results, matrix["size"], matrix["repeat"])
    write_text(out / "accuracy.md", summary + "\n# Figures (torus)\n" + figures_markdown(figures))
    write_csv(results, out / "accuracy.csv")
    write_plot(results, out / "accuracy.png")
    print(summary)
    return [out / n for n in ("accuracy.csv", "accuracy.md", "accuracy.png", *(f"{n}.png" for n in FIGURES))]


def command(args) -> int:
    """The curvature section alone: measure, print the summary, write the files."""
    out = Path(args.out) if getattr(args, "out", None) else DEFAULT_OUT
    written = measure_and_write(checked_options(args), out)
    print("wrote " + ", ".join(map(str, written)), file=sys.stderr)
    return 0
