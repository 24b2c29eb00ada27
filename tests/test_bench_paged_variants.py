"""bench/bench_paged_variants.py rebuilds the single pass's older paths from the bench side only: on a
tiny smooth ball every case prints a parsable row per variant, each "before" variant compiled
without the define of the path that replaced it and the "after" one with it, and the functions it
replaced for the older frames are vgraph's own again afterwards. No timings are asserted."""

import re

import pytest

import bench_paged_variants as bench  # bench/ is on sys.path (conftest)
from vgraph.bricks import paged_grids, paged_sampling
from vgraph.bricks import sampling as brick_sampling

ROW = re.compile(r"^\s+(?P<name>.+?): (?P<low>\d+) / (?P<median>\d+) / (?P<high>\d+) ms CPU  \((?P<ratio>[\d.]+)x; "
                 r"max difference (?P<steps>[\d.]+) steps\)  \[(?P<drawn>[^;]+); (?P<defines>[^\]]*)\]")
TINY = ["--ball", "32", "--bricks", "8", "--size", "32", "--rounds", "1", "--cpu"]


def rows(out: str) -> dict:
    """{(block heading, variant): its row's fields}: a heading is a line ending in ':'."""
    parsed, heading = {}, None
    for line in out.splitlines():
        if line.endswith(":") and not line.startswith(" "):
            heading = line[:-1]
        elif line.startswith("  ") and "ms CPU" in line:
            match = ROW.match(line)
            assert match, line
            parsed[heading, match["name"].strip()] = match.groupdict()
    return parsed


@pytest.fixture
def untouched():
    """The functions the bench replaces for its older variants' frames, as vgraph has them."""
    before = (paged_grids.walk_grid, paged_sampling.stride_binding, paged_sampling.level_voxel,
              brick_sampling.level_voxel)
    yield
    assert (paged_grids.walk_grid, paged_sampling.stride_binding, paged_sampling.level_voxel,
            brick_sampling.level_voxel) == before


def test_stride_rows_compile_paged_stride_only_for_the_levels_lattice(gl, capsys, untouched):
    bench.main(["stride", *TINY, "--levels", "1", "--modes", "dvr"])
    parsed = rows(capsys.readouterr().out)
    assert set(parsed) == {("dvr, level 1", name) for name in
                           ("passes", "single pass, every level-0 sample", "single pass, the level's lattice")}
    assert "PAGED_STRIDE" not in parsed["dvr, level 1", "single pass, every level-0 sample"]["defines"]
    assert "PAGED_STRIDE" in parsed["dvr, level 1", "single pass, the level's lattice"]["defines"]
    assert all(row["drawn"] == "levels [1], complete" for row in parsed.values())


@pytest.mark.skipif(not (bench.DATA / "ct_bonsai" / "bonsai.nii.gz").is_file(), reason="the bonsai is not in shared/data")
def test_refining_rows_march_and_walk_the_same_frozen_state(gl, capsys, untouched):
    # the tests' 64^3 bonsai: after 3 frames its coarse cells have empty blocks (iso's and dvr's
    # grids are made only where skipping pays; a tiny ball has too few empty blocks)
    bench.main(["refining", "--subsample", "4", "--bricks", "16", "--size", "32", "--rounds", "1", "--cpu",
                "--modes", "mip", "iso", "dvr", "--after", "3", "--limit", "8", "--lows"])
    out = capsys.readouterr().out
    parsed = rows(out)
    assert len(re.findall(r"grids built [\d.]+ ms a frame", out)) == len(parsed) == 7  # 2 a mode, iso's lows
    for mode, march, walk, walk_define in (("mip", "march (before)", "walk (as drawn)", "PAGED_MIP_ASKS"),
                                           ("iso", "march (before)", "walk (as drawn)", "PAGED_WALK_ASKS"),
                                           ("dvr", "march (as drawn)", "walk (did not pay)", "PAGED_WALK_ASKS")):
        heading = f"{mode}, after 3 refining frames"
        assert "PAGED_BLOCKS" in parsed[heading, march]["defines"]  # the slots' distances
        assert walk_define not in parsed[heading, march]["defines"]
        assert walk_define in parsed[heading, walk]["defines"]
        assert parsed[heading, walk]["drawn"].endswith("refining")  # still missing bricks: the state held
        if mode != "dvr":  # mip's and iso's walks draw the march's image (dvr's walk did not)
            assert float(parsed[heading, walk]["steps"]) == 0.0
    assert "PAGED_WALK_ASKS" in parsed["iso, after 3 refining frames", "walk, minima reduced too (before)"]["defines"]


def test_walk_rows_and_gradient_psnrs(gl, capsys, untouched):
    bench.main(["walk", *TINY, "--modes", "iso", "--samples"])
    out = capsys.readouterr().out
    parsed = rows(out)
    samples = [float(n) for n in re.findall(r"([\d.]+) samples a pixel", out)]
    assert len(samples) == 3 and all(n > 0 for n in samples)  # the RayCaster's, the slots' distances', the grid's
    assert "PAGED_ISO_GRID" not in parsed["iso", "slots' distances (before)"]["defines"]
    assert "PAGED_ISO_GRID" in parsed["iso", "walk grid (as drawn)"]["defines"]
    bench.main(["gradients", "--ball", "32", "--bricks", "8", "--size", "32", "--levels", "1"])
    lines = [line for line in capsys.readouterr().out.splitlines() if "level 1 " in line]
    assert [line.split(":")[0].strip() for line in lines] == list(bench.SHADED)
    for line in lines:
        level_0, level = map(float, re.search(r"level 1 ([\d.]+) / ([\d.]+)", line).groups())
        assert level_0 != level  # the level's step is another frame
