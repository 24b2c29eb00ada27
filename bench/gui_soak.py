"""GUI soak: the real window used without pause for a while, watched for leaks and failures.

    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/gui_soak.py [--minutes 30]
        [--network networks/raycast_sphere.json] [--settle-every 1] [--out bench/results]

Opens the network in a MainWindow with its own render process (as ``vgraph gui`` does) and loops
scripted user actions (``bench/scripted_user.py``): property edits in the inspector, node
drags, a connection deleted, undone, redone and made again with the mouse, trackball drags on the
canvas, transfer-function point drags. After every ``--settle-every`` actions it waits until the
render process has caught up. Once a minute (and at the end) it records: actions done and frames
received in that minute, the resident memory (RSS) of the GUI process and of the render process,
``sys.getrefcount(None)`` (PySide6 6.12.0 lost one per fillRect and Python aborted when it reached
zero), and the errors and warnings in the window's log.

Prints the table as it goes and writes bench/results/gui_soak_<time>.csv and .png. Exits 1 if the
log has errors, ``None`` lost references, or the render process could not keep up. Settings
(recent files, autosaves) go to a temporary folder, never the user's. Linux only (RSS from /proc).
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

REPO = Path(__file__).resolve().parents[1]
MINUTE = 60.0
NONE_SLACK = 50   # see tests/test_gui_reliability.py


@dataclass
class Sample:
    minute: float
    actions: int
    frames: int
    gui_rss_mb: float
    render_rss_mb: float
    none_refs: int
    errors: int
    warnings: int


def rss_mb(pid: int | None) -> float:
    if pid is None:
        return float("nan")
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--network", type=Path, default=REPO / "networks" / "raycast_sphere.json")
    parser.add_argument("--settle-every", type=int, default=1,
                        help="wait for the render process after this many actions")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    return parser.parse_args(argv)


def open_window(network: Path, settings_dir: Path):
    from PySide6.QtCore import QSettings
    from vgraph.gui.app import MainWindow
    from vgraph.live.render_process import RenderProcess
    settings = QSettings(str(settings_dir / "settings.ini"), QSettings.IniFormat)
    window = MainWindow(settings, RenderProcess())
    window.show()
    if not window.open_network(network):
        raise SystemExit(f"cannot open {network}")
    window.evaluation.run(wait=True)
    return window


class Recorder:
    """Per-minute counts from the running totals of the scripted user and the log."""

    def __init__(self, window, user, start: float):
        self.window, self.user, self.start = window, user, start
        self.samples: list[Sample] = []
        self._last_actions = self._last_frames = 0

    def sample(self) -> Sample:
        log = self.window.log
        row = Sample(minute=round((time.monotonic() - self.start) / MINUTE, 2),
                     actions=self.user.actions_done - self._last_actions,
                     frames=self.user.frames - self._last_frames,
                     gui_rss_mb=round(rss_mb(os.getpid()), 1),
                     render_rss_mb=round(rss_mb(self.window.evaluation.renderer.pid), 1),
                     none_refs=sys.getrefcount(None),
                     errors=len(log.messages("error")), warnings=len(log.messages("warning")))
        self._last_actions, self._last_frames = self.user.actions_done, self.user.frames
        self.samples.append(row)
        return row


def print_header() -> None:
    print(f"{'minute':>7} {'actions':>8} {'frames':>7} {'GUI RSS MB':>11} {'render RSS MB':>14} "
          f"{'None refs':>10} {'errors':>7} {'warnings':>9}", flush=True)


def print_row(row: Sample) -> None:
    print(f"{row.minute:>7.2f} {row.actions:>8} {row.frames:>7} {row.gui_rss_mb:>11.1f} "
          f"{row.render_rss_mb:>14.1f} {row.none_refs:>10} {row.errors:>7} {row.warnings:>9}", flush=True)


def soak(window, minutes: float, settle_every: int) -> tuple[list[Sample], bool]:
    """Run the actions for ``minutes``; returns the samples and whether rendering kept up."""
    from scripted_user import ScriptedUser
    user = ScriptedUser(window)
    start = time.monotonic()
    end = start + minutes * MINUTE
    recorder = Recorder(window, user, start)
    print_header()
    print_row(recorder.sample())
    next_sample = start + MINUTE
    kept_up = True
    while time.monotonic() < end:
        user.do_next()
        if user.actions_done % settle_every == 0:
            kept_up = user.settle() and kept_up
        if time.monotonic() >= next_sample:
            print_row(recorder.sample())
            next_sample += MINUTE
    kept_up = user.settle() and kept_up
    if recorder.samples[-1].minute < minutes:
        print_row(recorder.sample())
    return recorder.samples, kept_up


def write_csv(samples: list[Sample], path: Path) -> None:
    with path.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(asdict(samples[0])))
        writer.writeheader()
        writer.writerows(asdict(s) for s in samples)


def write_plot(samples: list[Sample], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    minutes = [s.minute for s in samples]
    figure, axes = plt.subplots(4, 1, figsize=(8, 10), sharex=True)
    axes[0].plot(minutes[1:], [s.actions for s in samples[1:]], "o-", label="actions")
    axes[0].plot(minutes[1:], [s.frames for s in samples[1:]], "s-", label="frames")
    axes[0].set_ylabel("per minute")
    axes[1].plot(minutes, [s.gui_rss_mb for s in samples], "o-", label="GUI process")
    axes[1].plot(minutes, [s.render_rss_mb for s in samples], "s-", label="render process")
    axes[1].set_ylabel("RSS (MB)")
    axes[2].plot(minutes, [s.none_refs for s in samples], "o-")
    axes[2].set_ylabel("refcount(None)")
    axes[3].plot(minutes, [s.errors for s in samples], "o-", label="errors")
    axes[3].plot(minutes, [s.warnings for s in samples], "s-", label="warnings")
    axes[3].set_ylabel("log entries")
    axes[3].set_xlabel("minutes")
    for axis in axes:
        if axis.get_legend_handles_labels()[0]:
            axis.legend()
        axis.grid(alpha=0.3)
    figure.suptitle("vgraph GUI soak")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def main(argv=None) -> int:
    args = parse_args(argv)
    from PySide6.QtWidgets import QApplication
    from vgraph.gui.app import log_exceptions
    app = QApplication.instance() or QApplication(["gui_soak"])  # noqa: F841  (kept alive)
    with tempfile.TemporaryDirectory(prefix="vgraph-soak-") as settings_dir:
        window = open_window(args.network, Path(settings_dir))
        with log_exceptions(window):
            samples, kept_up = soak(window, args.minutes, args.settle_every)
        problems = window.log.messages("error")
        window.workspace.undo_stack.setClean()
        window.close()
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.out / time.strftime("gui_soak_%Y%m%d_%H%M%S")
    write_csv(samples, stem.with_suffix(".csv"))
    write_plot(samples, stem.with_suffix(".png"))
    lost = samples[0].none_refs - min(s.none_refs for s in samples)
    total_actions = sum(s.actions for s in samples)
    total_frames = sum(s.frames for s in samples)
    base = samples[1] if len(samples) > 2 else samples[0]   # the first minute warms caches up
    growth = {name: getattr(samples[-1], name) - getattr(base, name) for name in ("gui_rss_mb", "render_rss_mb")}
    print(f"{args.minutes:g} min: {total_actions} actions, {total_frames} frames, "
          f"{len(problems)} errors, None lost {max(lost, 0)} references; RSS since minute {base.minute:g}: GUI "
          f"{growth['gui_rss_mb']:+.1f} MB, render {growth['render_rss_mb']:+.1f} MB; "
          f"wrote {stem}.csv and .png")
    for message in problems:
        print(f"error: {message}", file=sys.stderr)
    return 0 if not problems and lost < NONE_SLACK and kept_up else 1


if __name__ == "__main__":
    sys.exit(main())
