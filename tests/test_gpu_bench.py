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


def test_distributed_rows_set_each_cluster_against_the_model_fitted_on_one_and_two_workers(tmp_path):
    """The 4+ worker rows take bench_distributed's prediction for the grid it predicts with and the
    measured cold frame on that grid (bench_distributed's JSON, in the shape it writes)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("gpu_measure", ROOT / "bench" / "gpu" / "measure.py")
    measure = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(measure)
    fitted = {"rows": [{"data": "bonsai", "workers": 1, "split": "tiles", "grid": "1x1", "cold_s": 2.0, "model_s": 1.9},
                       {"data": "bonsai", "workers": 2, "split": "leaves", "grid": "-", "cold_s": 1.5}],
              "predictions": {"bonsai": [{"workers": 4, "grid": "2x2", "tiles_s": 0.8},
                                         {"workers": 8, "grid": "4x4", "tiles_s": 0.5}]}}
    (tmp_path / "distributed_scaling.json").write_text(json.dumps(
        {"rows": [{"data": "bonsai", "workers": 4, "split": "tiles", "grid": "2x2", "cold_s": 1.0},
                  {"data": "bonsai", "workers": 4, "split": "tiles", "grid": "4x4", "cold_s": 3.0}]}))
    one = measure._readable(measure._measured_row, fitted, 1, "ok", 10.0)
    assert one["cases"] == [{"data": "bonsai", "grid": "1x1", "cold_s": 2.0, "model_s": 1.9}]
    four = measure._readable(measure._predicted_row, fitted, 4, "ok", 5.0, tmp_path)
    assert four["cases"] == [{"data": "bonsai", "grid": "2x2", "model_s": 0.8, "cold_s": 1.0}]
    broken = measure._readable(measure._predicted_row, fitted, 16, "ok", 5.0, tmp_path)  # no prediction for 16
    assert broken["status"].startswith("ran, but its JSON was not understood")
    table = measure.markdown({"device": "d", "cpus": 16, "python": "3.12", "dry_run": False, "travelling_mib": 50.0,
                              "seconds": 300, "budget_s": 390, "repeat": 5, "renders": [],
                              "distributed": [one, four, broken]})
    assert "| 4 | ok | 5.0 | bonsai | 2x2 | 1.000 | 0.800 | 1.250 |" in table


def test_larger_clusters_carry_the_measured_costs_models_interval_and_its_tables():
    """bench/distributed_costs.py's result (in the shape it writes): each bonsai case of a larger
    cluster gets the interval that model gives for its grid and worker count, the engine's none
    (the costs bench draws the bonsai only), and the table shows it and the costs bench's own tables."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("gpu_measure", ROOT / "bench" / "gpu" / "measure.py")
    measure = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(measure)
    interval = {"low": 0.5, "mid": 0.75, "high": 1.25}
    costs = {"status": "ok", "size": [64, 64], "brick": 32, "rounds": 2, "seconds": 100.0,
             "plans": {"weights": [1] * 4, "tiles": {"1x1": [4]}}, "contention": [1.2, 1.3],
             "costs": {name: {"low": 0.001, "mid": 0.002, "high": 0.003} for name in
                       ("read", "upload", "build", "cold", "plan", "resolve", "roundtrip", "task", "mb",
                        "composite", "contention")} | {"slope": {}, "fixed": {}, "assemble": {}},
             "checks": [], "predictions": [{"workers": 4, "grid": "2x2", "tiles": interval,
                                            "tiles_by_grid": {"2x2": interval, "4x4": interval},
                                            "leaves": interval, "tiles_bricks": 3, "leaves_bricks": 1}]}
    row = {"workers": 4, "status": "ok", "phase_s": 5.0,
           "cases": [{"data": "bonsai", "grid": "2x2", "cold_s": 1.0, "model_s": 0.8},
                     {"data": "engine", "grid": "2x2", "cold_s": 0.5, "model_s": 0.4}]}
    measure._add_costs_model(row, costs)
    assert row["cases"][0]["costs_model"] == interval and "costs_model" not in row["cases"][1]
    eight = {"workers": 8, "cases": [{"data": "bonsai", "grid": "4x4"}]}
    measure._add_costs_model(eight, costs)
    assert "costs_model" not in eight["cases"][0]  # no prediction for 8 workers in this result
    table = measure.markdown({"device": "d", "cpus": 16, "python": "3.12", "dry_run": False, "travelling_mib": 50.0,
                              "seconds": 300, "budget_s": 390, "repeat": 5, "renders": [],
                              "distributed": [row], "costs": costs})
    assert "| 4 | ok | 5.0 | bonsai | 2x2 | 1.000 | 0.800 | 1.250 | 0.500 / 0.750 / 1.250 |" in table
    assert "| 4 | ok | 5.0 | engine | 2x2 | 0.500 | 0.400 | 1.250 |  |" in table
    assert "| 4 | 2x2 | 3 | 0.50 / 0.75 / 1.25 | 1 | 0.50 / 0.75 / 1.25 |" in table  # the costs bench's predictions
    skipped = measure.markdown({"device": "d", "cpus": 2, "python": "3.11", "dry_run": True, "travelling_mib": 1.0,
                                "seconds": 1, "budget_s": 1, "repeat": 1, "renders": [], "distributed": [],
                                "costs": {"status": "skipped: 5 s left, it needs 60 s"}})
    assert "(the model composed from measured costs): skipped: 5 s left" in skipped
