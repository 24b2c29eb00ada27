"""bench/bench_tetra.py compares like with like (issue #31): VTK's projected tetrahedra without
multisampling, a warm-up frame for every renderer, and frames of all renderers alternating round by
round on the same culled mesh."""

import argparse
import importlib.util

import pytest

import bench_tetra  # bench/ is on sys.path (conftest); spawned VTK workers import it by name too

needs_bonsai = pytest.mark.skipif(not bench_tetra.BONSAI.is_file(), reason=f"{bench_tetra.BONSAI} not found")
needs_vtk = pytest.mark.skipif(importlib.util.find_spec("vtk") is None,
                               reason="vtk is not installed (it is in the optional .[bench] extra)")


def small_args(skip_vtk: bool) -> argparse.Namespace:
    return argparse.Namespace(sizes=["12"], size=32, repeat=3, skip_vtk=skip_vtk, zsweep=False)


def test_interleaved_warms_every_renderer_up_then_alternates_rounds():
    drawn = []

    def renderer(name):
        def frame(camera):
            drawn.append((name, camera))
            return 0.5
        return frame

    seconds, order = bench_tetra.interleaved({"a": renderer("a"), "b": renderer("b")}, ["c0", "c1"], "warm")
    assert drawn == [("a", "warm"), ("b", "warm"), ("a", "c0"), ("b", "c0"), ("a", "c1"), ("b", "c1")]
    assert order == [(0, "a"), (0, "b"), (1, "a"), (1, "b")]
    assert seconds == {"a": [0.5, 0.5], "b": [0.5, 0.5]}  # warm-up frames are not counted


@needs_bonsai
def test_our_variants_alternate_frame_by_frame_on_the_culled_mesh(gl):
    rows, orders = bench_tetra.speed_rows(small_args(skip_vtk=True))
    names = list(bench_tetra.OURS)
    assert orders == [[(r, name) for r in range(3) for name in names]]
    row = rows[0]
    assert row["tetrahedra"] > 0
    assert all(len(row["seconds"][name]) == 3 for name in names)


@needs_bonsai
@needs_vtk
def test_vtk_projected_tetrahedra_run_without_multisampling_alternating_with_ours(gl):
    rows, orders = bench_tetra.speed_rows(small_args(skip_vtk=False))
    assert rows[0]["vtk"]["multisamples"] == 0
    names = [*bench_tetra.OURS, "VTK pt"]
    assert orders == [[(r, name) for r in range(3) for name in names]]
    assert len(rows[0]["seconds"]["VTK pt"]) == 3
