"""bench/gpu/run.sh --dry-run (issue #31, item 5): the GPU script's whole flow on llvmpipe at tiny sizes,
bounded, writes a table with the documented columns, and every image it draws matches the llvmpipe
reference of the same network in bench/gpu/refs (the images a GPU run is checked against)."""

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUN = ROOT / "bench" / "gpu" / "run.sh"
COLUMNS = ["case", "volume", "size", "first_s", "best_s", "median_s", "check", "psnr_db", "note"]
SHIPPED = {"raycast_sphere", "raycast_head", "curvature_volume", "curvature_torus", "tets_bonsai",
           "tets_lox_post", "tets_disk_out_ref"}


def test_dry_run_writes_the_table_and_every_image_matches_its_llvmpipe_reference(tmp_path, data_dir):
    done = subprocess.run(["bash", str(RUN), "--dry-run", "--out", str(tmp_path)],
                          env=os.environ | {"PYTHON": sys.executable},
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads((tmp_path / "gpu_bench.json").read_text())
    assert result["dry_run"] is True
    assert 0 < result["travelling_mib"] < 64  # what a GPU run carries fits the run tool's limit
    markdown = (tmp_path / "gpu_bench.md").read_text()
    assert "| " + " | ".join(COLUMNS) + " |" in markdown
    rows = result["renders"]
    assert all(set(row) == set(COLUMNS) for row in rows)
    assert SHIPPED <= {row["case"] for row in rows}
    checked = [row for row in rows if row["check"] not in ("n/a", "skipped")]
    assert {row["case"] for row in checked} >= {"raycast_sphere", "raycast_head"}  # the first cases fit any budget
    assert all(row["check"] == "pass" and row["psnr_db"] >= 30 for row in checked), checked
    assert all(row["best_s"] > 0 for row in rows if row["check"] != "skipped")
    # bench_distributed gets what is left of the budget: each worker count has a row saying what happened
    assert [row["workers"] for row in result["distributed"]] == [1, 2, 4]
    assert all(row["status"] for row in result["distributed"])
    assert "| workers | status |" in markdown
