"""mip's refining frames in the single pass (issue #33): a frame whose plan the atlas misses bricks of
walks the grid of block maxima largest first, as a complete frame does (PAGED_MIP_WALK with
PAGED_MIP_ASKS: vgraph.bricks.walk_grids.asking_grid, raycasting/compositing_mip.glsl), and asks for
the missing cells its rays reach as the front-to-back march did (vgraph.bricks.ray_requests).
Asserted against that march (the tree before, forced here: no walk grid where bricks are missing):
the same image, depth and requests (keys and pixels) frame after frame under a load limit, with
missing cells drawn from a coarser brick and with nothing drawn; the frames refine to the level-0
image in as many frames; the grid bounds every sample a coarser brick draws in a finer cell and
flags the blocks of missing cells."""

import numpy as np

from vgraph.testing import ray_caster_network

import helpers.bricked
import helpers.refining
from helpers.bricked import FINEST, oblique
from helpers.networks import UNSHADED_RAMP
from helpers.refining import (assert_level_0_image, assert_refines, assert_same_image_and_requests,
                              frames_until_complete, leave_cells_with_nothing_drawn, two_missing_cells)
from helpers.skipping import block_ranges, noise

bonsai = helpers.bricked.bonsai  # the fixture: the CT bonsai at 64^3
march_where_missing = helpers.refining.march_where_missing  # the fixture: networks with march = True march


def mip_network(volume, march: bool, brick: int = 16):
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass",
                                 **{**UNSHADED_RAMP, "compositing": "mip", "brick_size": brick, "lod_bias": FINEST})
    network["rc"].march = march
    return network


def assert_same_frame(walked, marched):
    assert_same_image_and_requests(walked, marched)
    report, defines = walked.report, walked.defines
    assert bool(defines.get("PAGED_MIP_ASKS")) is (not report["complete"]) and defines.get("PAGED_MIP_WALK")
    assert not marched.defines.get("PAGED_MIP_WALK") or marched.report["complete"]


def test_refining_frames_walk_with_the_marchs_image_and_requests_and_refine_to_level_0(bonsai,
                                                                                   march_where_missing):
    """From an empty cache under a limit of 3 bricks a frame: every frame as the march's (image,
    depth, requests with their pixels), as many frames until complete, the last one level 0's
    image (the frame drawn without a limit, everything read at once)."""
    walked, marched = mip_network(bonsai, False), mip_network(bonsai, True)
    frames = frames_until_complete(walked, marched, range(1, 40), 3, assert_same_frame)
    assert_refines(frames)
    assert_level_0_image(frames[-1], mip_network(bonsai, False))


def test_cells_with_nothing_drawn_are_asked_for_as_the_march_asks(bonsai, march_where_missing):
    """Missing level-0 cells whose ancestors are all gone from the atlas and the cache (nothing
    drawn there, the rays jump them): image, depth and requests as the march's, under no limit to
    read (each frame reads the brick most pixels asked for) until complete again."""
    pair = [mip_network(bonsai, march) for march in (False, True)]
    for network in pair:
        leave_cells_with_nothing_drawn(network)
    reports = [f.report for f in frames_until_complete(*pair, range(2, 30), 0, assert_same_frame)]
    assert reports[-1]["complete"] and len(reports) >= 3
    assert len(reports[0]["requests"]) >= 2 and reports[0]["error_bound"] is None  # (mip: no bound)


def test_the_asking_grid_bounds_what_coarser_bricks_draw_in_finer_cells_and_flags_missing_ones():
    """Level-0 cells drawn from their level-1 ancestor (a missing cell): each block of the grid
    bounds every sample of level 1 in it (random positions) and no more where a cell draws nothing;
    .g is 1 exactly on the blocks within EDGE of the
    missing cells (here: the blocks of those cells and the ring of blocks around them)."""
    from scipy.ndimage import map_coordinates
    from vgraph.bricks.walk_grids import asking_grid
    data = noise((40, 32, 48)).data
    case = two_missing_cells(data, block_ranges)
    source = case.source
    lo, hi = source.value_range
    grid, block = asking_grid(*case.grid_inputs, case.bricks, case.missing)
    every, _ = asking_grid(*case.grid_inputs, case.parents, case.missing)
    assert block == 8 and grid.shape == (5, 4, 6, 2)
    maxima = grid[..., 0]
    assert np.all(maxima <= every[..., 0])
    points = np.random.default_rng(5).random((20000, 3)) * np.asarray(data.shape)  # t * dims0, [z, y, x]
    blocks = tuple((points // 8).astype(int).T)
    drawn = ~np.all((points // 16).astype(int) == np.asarray(case.nothing[1:]), axis=1)
    voxels = (source.read(1, (0, 0, 0), source.levels[1].shape).astype(np.float64) - lo) / (hi - lo)
    values = map_coordinates(voxels, (points.T - 0.5) / 2 - 0.25, order=1, mode="nearest")
    assert np.all(values[drawn] <= maxima[blocks][drawn] + 1e-6)
    flags = np.zeros(grid.shape[:3], dtype=bool)
    flags[1:5, 0:3, 1:5] = True  # cell (0, 1, 0, 1): blocks z 2-3, y 0-1, x 2-3, and a block around
    flags[3:5, 1:4, 3:6] = True  # cell (0, 2, 1, 2): z 4, y 2-3, x 4-5 (the volume's last along z and x)
    np.testing.assert_array_equal(grid[..., 1] == 1.0, flags)
    np.testing.assert_array_equal(every[..., 1], grid[..., 1])
