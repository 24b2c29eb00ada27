"""The distributed cost model's arithmetic (bench/cost_model.py, issue #31 item 4) on synthetic
constants: each frame is the sum its docstring gives, the interval is the model at every constant's
minimum and maximum, and the bench's tables are built from the measured samples. No timing here."""

import math

import pytest

from cost_model import (MIB, PIXEL_BYTES, Costs, Spread, TileWork, assignments, grid_for, in_turn, leaves_frame,
                        predict, predict_tiles, tiles_for, tiles_frame)

GRIDS = ["1x1", "2x1", "2x2"]


def flat(**changes) -> Costs:
    """Round constants, so each expected frame below can be summed by hand."""
    values = dict(read=0.010, upload=0.002, slope={g: 0.001 for g in GRIDS}, fixed={g: 0.100 for g in GRIDS},
                  build=0.050, cold=0.200, plan=0.030, resolve=0.040, roundtrip=0.005, task=0.003, mb=0.004,
                  assemble={g: 0.0005 for g in GRIDS}, composite=0.020, contention=1.5)
    return Costs(**(values | changes))


def bricks(*ranges) -> frozenset:
    return frozenset((0, i, 0, 0) for r in ranges for i in r)


def test_spread_is_min_median_max_and_refuses_nothing():
    assert Spread.of([3.0, 1.0, 2.0, 10.0]) == Spread(1.0, 2.5, 10.0)
    with pytest.raises(ValueError, match="no values"):
        Spread.of([])


def test_pick_takes_one_value_of_every_spread_including_the_per_grid_ones():
    costs = flat(read=Spread(1.0, 2.0, 3.0), slope={"1x1": Spread(4.0, 5.0, 6.0)})
    low, high = costs.pick("low"), costs.pick("high")
    assert (low.read, low.slope["1x1"], high.read, high.slope["1x1"]) == (1.0, 4.0, 3.0, 6.0)
    assert low.build == 0.050  # a plain number stays


def test_one_worker_reads_the_union_of_its_tiles_bricks_once_and_draws_every_tile():
    c = flat()
    tiles = [TileWork(bricks(range(0, 60)), 100), TileWork(bricks(range(40, 100)), 100)]  # 20 shared
    expected = (c.roundtrip + c.build + c.cold + (c.read + c.upload) * 100
                + 2 * c.fixed["2x1"] + c.slope["2x1"] * 120 + c.task
                + c.mb * 200 * PIXEL_BYTES / MIB + c.assemble["2x1"])
    assert tiles_frame(c, "2x1", tiles, 1) == pytest.approx(expected)


def test_two_busy_workers_are_the_busiest_one_slowed_by_contention():
    c = flat()
    heavy, light = TileWork(bricks(range(0, 80)), 100), TileWork(bricks(range(80, 100)), 100)
    busiest = c.build + c.cold + (c.read + c.upload + c.slope["2x1"]) * 80 + c.fixed["2x1"]
    expected = c.roundtrip + busiest * c.contention + c.mb * 200 * PIXEL_BYTES / MIB + c.assemble["2x1"]
    assert tiles_frame(c, "2x1", [light, heavy], 2) == pytest.approx(expected)
    # one tile on two workers: the other worker is idle, nothing is shared
    one = TileWork(bricks(range(0, 80)), 100)
    alone = c.roundtrip + busiest + c.mb * 100 * PIXEL_BYTES / MIB + c.assemble["1x1"]
    assert tiles_frame(c, "1x1", [one], 2) == pytest.approx(alone)


def test_tiles_go_out_in_turn_and_two_workers_may_get_any_even_split():
    assert in_turn(4, 2) == [[0, 2], [1, 3]]
    assert in_turn(2, 4) == [[0], [1], [], []]
    ways = assignments(4, 2)
    assert sorted(sorted(map(tuple, way)) for way in ways) == [[(0, 1), (2, 3)], [(0, 2), (1, 3)], [(0, 3), (1, 2)]]
    assert assignments(64, 64) == [in_turn(64, 64)]


def test_the_tiles_interval_spans_the_splits_whose_bricks_overlap_least():
    """2x2 on 2 workers: a column's tiles (in turn) share 30 bricks, so its worker reads 50; a
    diagonal's worker reads 80, a row's 100: the interval's top is the rows' frame at every maximum."""
    left, right = range(0, 50), range(50, 100)
    tiles = [TileWork(bricks(left[:30], left[30:]), 10), TileWork(bricks(right[:30], right[30:]), 10),
             TileWork(bricks(left[:10], left[30:]), 10), TileWork(bricks(right[:10], right[30:]), 10)]
    costs = flat(read=Spread(0.008, 0.010, 0.012))
    spread = predict_tiles(costs, "2x2", tiles, 2)
    high = costs.pick("high")
    rows, diagonals = ([[0, 1], [2, 3]], [[0, 3], [1, 2]])
    assert spread.high == pytest.approx(tiles_frame(high, "2x2", tiles, 2, rows))
    assert tiles_frame(high, "2x2", tiles, 2, rows) > tiles_frame(high, "2x2", tiles, 2, diagonals) \
        > tiles_frame(high, "2x2", tiles, 2)
    assert spread.mid == pytest.approx(tiles_frame(costs.pick("mid"), "2x2", tiles, 2))
    assert spread.low <= spread.mid < spread.high


def test_leaves_on_one_worker_plan_run_and_resolve_without_moving_a_partial():
    c = flat()
    pixels = 64 * 64
    expected = ((c.roundtrip + c.build + c.cold + c.plan)
                + (c.roundtrip + c.fixed["1x1"] + (c.read + c.upload + c.slope["1x1"]) * 10)
                + (c.roundtrip + c.resolve + c.mb * pixels * PIXEL_BYTES / MIB))
    assert leaves_frame(c, [1] * 10, pixels, 1) == pytest.approx(expected)


def test_leaves_on_four_workers_add_two_composite_levels_and_the_other_workers_builds():
    c = flat()
    pixels = 64 * 64
    partial = 2 * pixels * PIXEL_BYTES / MIB
    run = c.build + c.cold + c.fixed["1x1"] + (c.read + c.upload + c.slope["1x1"]) * 10  # 40 bricks / 4
    expected = ((c.roundtrip + c.build + c.cold + c.plan) + (c.roundtrip + run * c.contention)
                + 2 * (c.roundtrip + c.composite + c.mb * partial)
                + (c.roundtrip + c.resolve + c.mb * partial + c.mb * pixels * PIXEL_BYTES / MIB))
    assert leaves_frame(c, [1] * 40, pixels, 4) == pytest.approx(expected)


def test_the_interval_is_the_model_at_every_minimum_and_every_maximum():
    costs = flat(read=Spread(0.008, 0.010, 0.015), slope={g: Spread(0.0005, 0.001, 0.002) for g in GRIDS},
                 roundtrip=Spread(0.004, 0.005, 0.030), contention=Spread(1.2, 1.5, 1.9))
    tiles = [TileWork(bricks(range(0, 60)), 100), TileWork(bricks(range(40, 100)), 100)]
    spread = predict(costs, tiles_frame, "2x1", tiles, 2)
    assert spread.low == pytest.approx(tiles_frame(costs.pick("low"), "2x1", tiles, 2))
    assert spread.high == pytest.approx(tiles_frame(costs.pick("high"), "2x1", tiles, 2))
    assert spread.low < spread.mid < spread.high
    leaves = predict(costs, leaves_frame, [1] * 50, 4096, 8)
    assert leaves.low < leaves.mid < leaves.high


@pytest.mark.parametrize("name", ["read", "upload", "build", "cold", "plan", "resolve", "roundtrip", "task", "mb",
                                  "composite", "contention"])
def test_no_frame_gets_faster_when_a_constant_grows(name):
    """What makes the min/max evaluation an interval: every frame is non-decreasing in every constant."""
    tiles = [TileWork(bricks(range(0, 60)), 100), TileWork(bricks(range(40, 100)), 100)]
    base, more = flat(), flat(**{name: getattr(flat(), name) * 2})
    for workers in (1, 2):
        assert tiles_frame(more, "2x1", tiles, workers) >= tiles_frame(base, "2x1", tiles, workers)
        assert leaves_frame(more, [1] * 30, 4096, workers) >= leaves_frame(base, [1] * 30, 4096, workers)


def test_the_grid_for_n_workers_is_the_smallest_with_a_tile_each():
    grids = ["1x1", "2x1", "2x2", "4x2", "4x4", "8x4", "8x8"]
    assert [grid_for(n, grids) for n in (1, 2, 3, 4, 8, 16, 32, 64)] == \
        ["1x1", "2x1", "2x2", "2x2", "4x2", "4x4", "8x4", "8x8"]
    assert math.isfinite(tiles_frame(flat(), "2x2", [TileWork(frozenset(), 1)] * 4, 8))  # idle workers


def test_the_bench_composes_its_constants_and_tables_from_the_rounds_samples():
    import distributed_costs
    from distributed_costs_report import markdown
    samples = [{"read": r, "upload": 0.001, "build": 0.01, "cold": 0.1, "plan": 0.02, "resolve": 0.03,
                "roundtrip": 0.01, "task": 0.002, "mb": 0.003, "composite": 0.004,
                **{f"{kind}:{g}": value for g in distributed_costs.GRIDS
                   for kind, value in (("slope", 0.001), ("fixed", 0.05), ("assemble", 0.0001))}}
               for r in (0.010, 0.012, 0.020)]
    costs = distributed_costs.costs_of(samples, [1.3, 1.4, 1.6])
    assert costs.read == Spread(0.010, 0.012, 0.020) and costs.contention == Spread(1.3, 1.4, 1.6)
    assert costs.slope["8x8"] == Spread(0.001, 0.001, 0.001)
    plans = {"weights": [1] * 8, "tiles": {g: [{"bricks": [[[0, i, 0, 0], [0, 0, 1, 1]] for i in range(8)],
                                                "pixels": 100}] * tiles_for(g)
                                           for g in distributed_costs.GRIDS}}
    predicted = distributed_costs.predictions(costs, plans, (16, 16))
    assert [p["workers"] for p in predicted] == [4, 8, 16, 32, 64]
    assert all(p["tiles"]["low"] <= p["tiles"]["mid"] <= p["tiles"]["high"] for p in predicted)
    # every grid with a tile per worker (what bench_distributed --scheduler measures on the GPU machine)
    assert list(predicted[1]["tiles_by_grid"]) == ["4x2", "4x4", "8x4", "8x8"] and predicted[1]["grid"] == "4x2"
    rows = [{"split": s, "grid": g, "workers": w, "seconds": 1.0, "bricks_read": [8 + r] * w}
            for s, g in distributed_costs.CHECKS for w in (1, 2) for r in (0, 0, 1)]
    checks = distributed_costs.checked(rows, costs, costs, plans, (16, 16))
    result = {"size": [16, 16], "brick": 32, "rounds": 3, "plans": {"weights": [1] * 8, "tiles": {
        g: [8] * tiles_for(g) for g in distributed_costs.GRIDS}}, "checks": checks,
        "predictions": predicted, "contention": [1.3, 1.4, 1.6],
        "costs": distributed_costs._costs_json(costs)}
    table = markdown(result)
    assert "| read: read one brick from the store (per brick) | 10.00 / 12.00 / 20.00 | ms |" in table
    assert "| 64 | 8x8 |" in table and "| tiles | 2x2 | 2 |" in table
    assert "| 8 / 8 or 9 / 9; 8 / 0 |" in table  # both splits the rounds saw; the model's (in turn)
