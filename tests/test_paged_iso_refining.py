"""iso's refining frames in the single pass (issue #33), shaded or not: a frame whose plan the atlas
misses bricks of walks a frame-wide grid of skip radii (PAGED_WALK with PAGED_WALK_ASKS,
raycasting/march.glsl; vgraph.bricks.walk_grids.skip_radii with each cell drawn from its finest
resident ancestor and the empty blocks of missing cells ASKING), and asks for the missing cells its
rays reach as the front-to-back march did (vgraph.bricks.ray_requests). Asserted against that
march (the tree before, forced here: no walk grid where bricks are missing): the same image, depth
and requests (keys and pixels) frame after frame under a load limit, with missing cells drawn from
a coarser brick and with nothing drawn; the frames refine to the level-0 image in as many frames;
the grid's ASKING blocks. dvr's refining frames march (their walk did not pay and asked for other
pixels: walk_grids' docstring)."""

import numpy as np
import pytest

from vgraph.testing import ray_caster_network

import helpers.bricked
import helpers.refining
from helpers.bricked import FINEST, oblique
from helpers.networks import UNSHADED_RAMP
from helpers.refining import (assert_level_0_image, assert_refines, assert_same_image_and_requests,
                              frames_until_complete, leave_cells_with_nothing_drawn, two_missing_cells)

bonsai = helpers.bricked.bonsai  # the fixture: the CT bonsai at 64^3
march_where_missing = helpers.refining.march_where_missing  # the fixture: networks with march = True march

# (at 0.3 this bonsai's rays reach every missing cell in an occupied block, where any walk asks: at
# 0.5 many cross only a missing cell's empty blocks, where the ASKING blocks alone make them ask)
LEVEL = 0.5


def iso_network(volume, march: bool, shading: str, brick: int = 16):
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass",
                                 **{**UNSHADED_RAMP, "compositing": "iso", "iso_level": LEVEL, "shading": shading,
                                    "brick_size": brick, "lod_bias": FINEST})
    network["rc"].march = march
    return network


def assert_same_frame(walked, marched):
    assert_same_image_and_requests(walked, marched)
    report, defines = walked.report, walked.defines
    assert not marched.defines.get("PAGED_WALK") and not marched.defines.get("PAGED_WALK_ASKS")
    assert bool(defines.get("PAGED_WALK_ASKS")) is (bool(defines.get("PAGED_WALK")) and not report["complete"])


@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
def test_refining_frames_walk_with_the_marchs_image_and_requests_and_refine_to_level_0(bonsai, shading,
                                                                                   march_where_missing):
    """From an empty cache under a limit of 3 bricks a frame: every frame as the march's (image,
    depth, requests with their pixels), as many frames until complete, the last one level 0's
    image (the frame drawn without a limit, everything read at once)."""
    walked, marched = iso_network(bonsai, False, shading), iso_network(bonsai, True, shading)
    frames = frames_until_complete(walked, marched, range(1, 40), 3, assert_same_frame)
    refining = assert_refines(frames)
    # walked where skipping pays (the first frames, all or most cells missing: it does not)
    walking = [f.defines.get("PAGED_WALK", False) for f in refining]
    assert sum(walking) >= len(refining) // 2, walking
    assert_level_0_image(frames[-1], iso_network(bonsai, False, shading))


@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
def test_cells_with_nothing_drawn_are_asked_for_as_the_march_asks(bonsai, shading, march_where_missing):
    """Missing level-0 cells whose ancestors are all gone from the atlas and the cache (nothing
    drawn there, the rays jump them): image, depth and requests as the march's, under no limit to
    read (each frame reads the brick most pixels asked for) until complete again."""
    pair = [iso_network(bonsai, march, shading) for march in (False, True)]
    for network in pair:
        leave_cells_with_nothing_drawn(network)
    frames = frames_until_complete(*pair, range(2, 30), 0, assert_same_frame)
    reports = [f.report for f in frames]
    assert reports[-1]["complete"] and len(reports) >= 3
    assert len(reports[0]["requests"]) >= 2
    assert all(f.defines.get("PAGED_WALK") for f in frames if not f.report["complete"])


def test_the_grid_asks_in_the_empty_blocks_of_missing_cells_and_no_jump_enters_them():
    """Level-0 cells drawn from their level-1 ancestor, two of them missing (one with nothing drawn):
    the grid is ASKING exactly on the empty blocks within EDGE of the missing cells, 0 on the blocks
    whose drawn range reaches the level, and every other block's radius r jumps only blocks of
    neither kind (the cube of Chebyshev radius r - 1 around it)."""
    from vgraph.bricks.walk_grids import ASKING, asking_grid, skip_radii
    from helpers.skipping import block_ranges, noise
    case = two_missing_cells(noise((40, 32, 48)).data, block_ranges)
    maxima, _ = asking_grid(*case.grid_inputs, case.bricks, case.missing)
    level = float(np.quantile(maxima[..., 0], 0.6))  # (the noise's blocks: about 40 % reach it)
    grid, block = skip_radii(*case.grid_inputs, lambda low, high: ~(high < level), case.bricks, case.missing, lows=False)
    assert block == 8 and grid.shape == maxima.shape[:3]
    occupied = maxima[..., 0] >= level
    asking = (maxima[..., 1] == 1.0) & ~occupied
    assert asking.sum() >= 8 and occupied.sum() >= 8 and (~occupied & ~asking).sum() >= 8
    np.testing.assert_array_equal(grid == ASKING, asking)
    np.testing.assert_array_equal(grid == 0.0, occupied)
    blocked = np.argwhere(occupied | asking)
    for z, y, x in np.argwhere(grid >= 1.0):
        reach = np.abs(blocked - (z, y, x)).max(axis=1)
        assert reach.min() >= grid[z, y, x]  # the nearest block it must not jump: outside the cube
