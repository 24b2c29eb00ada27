"""The RZSweep benches (bench/bench_sweep_thesis.py, bench/bench_sweep_growth.py) run in --quick
mode and print the tables docs/explanations/sweep-plane.md ("Measured") quotes: every renderer
row with a PSNR, the split columns either measured or "not available" with a reason, the fitted
models, the plot. No timed assertions."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"


def run_bench(name: str, *extra: str) -> str:
    done = subprocess.run([sys.executable, str(ROOT / "bench" / name), "--quick", *extra],
                          capture_output=True, text=True, cwd=ROOT, timeout=240)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


@pytest.mark.skipif(not (DATA / "ct_bonsai" / "bonsai.nii.gz").exists(), reason="needs the shared data")
def test_thesis_bench_prints_every_row():
    out = run_bench("bench_sweep_thesis.py")
    assert "| mriHead (256 x 256 x 111) | 16 x 16 x 8 |" in out
    split_row = next(line for line in out.splitlines() if line.startswith("| mriHead | 1 (8) | 1 |"))
    tiles_s, tiles_read, leaves_s, leaves_read = split_row.strip("|").split("|")[3:]
    for seconds, read in ((tiles_s, tiles_read), (leaves_s, leaves_read)):  # measured, or why not
        assert re.search(r"\d+\.\d+ s", seconds) and re.search(r"\d+(\.\d+)? (bytes|[KMG]iB)", read) \
            or re.search(r"not available \(.+\)", seconds), split_row
    for n, renderer in [(16, r) for r in ("SweepPlaneRenderer", "BrickedRayCaster", "RayCaster")] + \
            [(24, "SweepPlaneRenderer (out of core)"), (24, "BrickedRayCaster (out of core)"), (24, "RayCaster")]:
        row = next(line for line in out.splitlines() if line.startswith(f"| {n}^3 | {renderer} |"))
        assert float(row.strip("|").split("|")[-1]) > 20.0, row  # PSNR against the reference, dB
    assert re.search(r"\| 24\^3 \| SweepPlaneRenderer \(out of core\) \| .* \| \S+ MiB \(\d+ leaves read", out)


def test_growth_bench_fits_both_models_and_writes_the_plot(tmp_path):
    plot = tmp_path / "growth.png"
    out = run_bench("bench_sweep_growth.py", "--plot", str(plot))
    assert len([line for line in out.splitlines() if re.match(r"\| \d+\^3 at \d+\^2 \|", line)]) == 3 + 2 * 3
    assert re.search(r"model A: t = \S+ N log2 N \+ \S+ P \+ \S+", out)
    assert re.search(r"model B: t = .*P N\^\(1/3\)", out)
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
