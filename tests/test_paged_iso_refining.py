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

from vgraph.bricks import paged_grids
from vgraph.bricks.cache import LoadLimit
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.sampling import BrickSampling
from vgraph.frame_context import FrameContext
from vgraph.testing import ray_caster_network

import test_bricked_raycaster
from helpers.networks import UNSHADED_RAMP
from test_bricked_raycaster import FINEST, SIZE, oblique
from test_ray_requests import ONE_STEP

bonsai = test_bricked_raycaster.bonsai  # the fixture: the CT bonsai at 64^3


@pytest.fixture
def march_where_missing(monkeypatch):
    """Networks whose processor has ``march = True`` draw frames with missing bricks front to back
    (the tree before: no walk grid where bricks are missing, the slots' block flags instead)."""
    walk_grid = paged_grids.walk_grid

    def chosen(processor, kept, frame, source, geometry, plan, atlas, missing):
        if getattr(processor, "march", False) and len(missing):
            return None
        return walk_grid(processor, kept, frame, source, geometry, plan, atlas, missing)
    monkeypatch.setattr(paged_grids, "walk_grid", chosen)


# (at 0.3 this bonsai's rays reach every missing cell in an occupied block, where any walk asks: at
# 0.5 many cross only a missing cell's empty blocks, where the ASKING blocks alone make them ask)
LEVEL = 0.5


def iso_network(volume, march: bool, shading: str, brick: int = 16):
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass",
                                 **{**UNSHADED_RAMP, "compositing": "iso", "iso_level": LEVEL, "shading": shading,
                                    "brick_size": brick, "lod_bias": FINEST})
    network["rc"].march = march
    return network


def frame(network, number: int, limit: LoadLimit | None):
    """(image, depth, last_frame, defines) of a new frame under ``limit``."""
    network.set("rc.sampling_rate", 1.0 + 1e-6 * number)  # (a new frame each time)
    context = FrameContext(load_limit=limit) if limit is not None else None
    image = np.asarray(network.evaluate("rc.image", size=SIZE, context=context))
    depth = np.asarray(network.evaluate("rc.depth", size=SIZE, context=context))  # (the same frame: nothing read)
    rc = network["rc"]
    return image, depth, dict(rc.last_frame), dict(rc.passes[-1].defines)


def assert_same_frame(walked, marched):
    image, depth, report, defines = walked
    np.testing.assert_array_equal(image, marched[0])
    np.testing.assert_array_equal(depth[..., :2], marched[1][..., :2])  # (b: the samples taken differ)
    assert report["requests"] == marched[2]["requests"]  # keys and pixels, in the order read
    assert report["complete"] is marched[2]["complete"]
    assert not marched[3].get("PAGED_WALK") and not marched[3].get("PAGED_WALK_ASKS")
    assert bool(defines.get("PAGED_WALK_ASKS")) is (bool(defines.get("PAGED_WALK")) and not report["complete"])


@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
def test_refining_frames_walk_with_the_marchs_image_and_requests_and_refine_to_level_0(bonsai, shading,
                                                                                   march_where_missing):
    """From an empty cache under a limit of 3 bricks a frame: every frame as the march's (image,
    depth, requests with their pixels), as many frames until complete, the last one level 0's
    image (the frame drawn without a limit, everything read at once)."""
    walked, marched = iso_network(bonsai, False, shading), iso_network(bonsai, True, shading)
    frames = []
    for number in range(1, 40):
        pair = [frame(network, number, LoadLimit(bricks=3)) for network in (walked, marched)]
        assert_same_frame(*pair)
        frames.append(pair[0])
        if pair[0][2]["complete"]:
            break
    assert frames[-1][2]["complete"] and frames[-1][2]["levels"] == [0]
    refining = [f for f in frames if not f[2]["complete"]]
    assert len(refining) >= 3 and max(len(f[2]["requests"]) for f in refining) > 4
    assert any(f[2]["coarsest_level"] > 0 for f in refining)  # missing cells drawn from coarser bricks
    # walked where skipping pays (the first frames, all or most cells missing: it does not)
    walking = [f[3].get("PAGED_WALK", False) for f in refining]
    assert sum(walking) >= len(refining) // 2, walking
    whole = iso_network(bonsai, False, shading)
    image, _, report, _ = frame(whole, 1, None)
    assert report["complete"] and report["levels"] == [0]
    assert np.abs(frames[-1][0] - image).max() <= ONE_STEP and image[..., :3].std() > 0.01


@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
def test_cells_with_nothing_drawn_are_asked_for_as_the_march_asks(bonsai, shading, march_where_missing):
    """Missing level-0 cells whose ancestors are all gone from the atlas and the cache (nothing
    drawn there, the rays jump them): image, depth and requests as the march's, under no limit to
    read (each frame reads the brick most pixels asked for) until complete again."""
    pair = [iso_network(bonsai, march, shading) for march in (False, True)]
    for network in pair:
        frame(network, 1, None)  # complete: every level-0 brick in the atlas
        rc = network["rc"]
        atlas, cache = rc.parts[PagedSampling].atlas, rc.parts[BrickSampling].cache
        gone = [key for key in list(atlas.slots) if key[0] > 0 or (key[1] == 1 and key[2] >= 1)]
        for key in gone:
            atlas.evict(key)
            cache.ram.pop(key, None)
    reports, walked_defines = [], []
    for number in range(2, 30):
        both = [frame(network, number, LoadLimit(bricks=0)) for network in pair]
        assert_same_frame(*both)
        reports.append(both[0][2])
        walked_defines.append(both[0][3])
        if both[0][2]["complete"]:
            break
    assert reports[-1]["complete"] and len(reports) >= 3
    assert len(reports[0]["requests"]) >= 2
    assert all(defines.get("PAGED_WALK") for defines, report in zip(walked_defines, reports) if not report["complete"])


def test_the_grid_asks_in_the_empty_blocks_of_missing_cells_and_no_jump_enters_them():
    """Level-0 cells drawn from their level-1 ancestor, two of them missing (one with nothing drawn):
    the grid is ASKING exactly on the empty blocks within EDGE of the missing cells, 0 on the blocks
    whose drawn range reaches the level, and every other block's radius r jumps only blocks of
    neither kind (the cube of Chebyshev radius r - 1 around it)."""
    from vgraph.bricks.brick_geometry import BrickGeometry
    from vgraph.bricks.cache import texture_format
    from vgraph.bricks.pyramid import ArrayPyramid
    from vgraph.bricks.walk_grids import ASKING, asking_grid, skip_radii
    from test_mip_skipping import block_ranges, noise
    data = noise((40, 32, 48)).data
    source = ArrayPyramid(data, brick=(16, 16, 16))
    geometry = BrickGeometry(source)
    fmt = texture_format(source.dtype, source.value_range)
    level1 = [(1, z, y, x) for z in range(geometry.grids[1][2]) for y in range(geometry.grids[1][1])
              for x in range(geometry.grids[1][0])]
    ranges = np.stack([block_ranges(source, key, fmt) for key in level1])
    slot_of = {key: i for i, key in enumerate(level1)}.__getitem__
    cells = [(0, z, y, x) for z in range(geometry.grids[0][2]) for y in range(geometry.grids[0][1])
             for x in range(geometry.grids[0][0])]
    nothing = (0, 2, 1, 2)  # a missing cell with nothing resident above it
    bricks = [None if cell == nothing else (1, z // 2, y // 2, x // 2) for cell, (_, z, y, x) in zip(cells, cells)]
    missing = np.asarray([(0, 1, 0, 1), nothing])
    maxima, _ = asking_grid(source, geometry, cells, slot_of, ranges, bricks, missing)
    level = float(np.quantile(maxima[..., 0], 0.6))  # (the noise's blocks: about 40 % reach it)
    grid, block = skip_radii(source, geometry, cells, slot_of, ranges, lambda low, high: ~(high < level), bricks,
                             missing, lows=False)
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
