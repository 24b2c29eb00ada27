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
from test_mip_skipping import block_ranges, noise
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


def mip_network(volume, march: bool, brick: int = 16):
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass",
                                 **{**UNSHADED_RAMP, "compositing": "mip", "brick_size": brick, "lod_bias": FINEST})
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
    assert bool(defines.get("PAGED_MIP_ASKS")) is (not report["complete"]) and defines.get("PAGED_MIP_WALK")
    assert not marched[3].get("PAGED_MIP_WALK") or marched[2]["complete"]


def test_refining_frames_walk_with_the_marchs_image_and_requests_and_refine_to_level_0(bonsai,
                                                                                   march_where_missing):
    """From an empty cache under a limit of 3 bricks a frame: every frame as the march's (image,
    depth, requests with their pixels), as many frames until complete, the last one level 0's
    image (the frame drawn without a limit, everything read at once)."""
    walked, marched = mip_network(bonsai, False), mip_network(bonsai, True)
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
    whole = mip_network(bonsai, False)
    image, _, report, _ = frame(whole, 1, None)
    assert report["complete"] and report["levels"] == [0]
    assert np.abs(frames[-1][0] - image).max() <= ONE_STEP and image[..., :3].std() > 0.01


def test_cells_with_nothing_drawn_are_asked_for_as_the_march_asks(bonsai, march_where_missing):
    """Missing level-0 cells whose ancestors are all gone from the atlas and the cache (nothing
    drawn there, the rays jump them): image, depth and requests as the march's, under no limit to
    read (each frame reads the brick most pixels asked for) until complete again."""
    pair = [mip_network(bonsai, march) for march in (False, True)]
    for network in pair:
        frame(network, 1, None)  # complete: every level-0 brick in the atlas
        rc = network["rc"]
        atlas, cache = rc.parts[PagedSampling].atlas, rc.parts[BrickSampling].cache
        gone = [key for key in list(atlas.slots) if key[0] > 0 or (key[1] == 1 and key[2] >= 1)]
        for key in gone:
            atlas.evict(key)
            cache.ram.pop(key, None)
    reports = []
    for number in range(2, 30):
        both = [frame(network, number, LoadLimit(bricks=0)) for network in pair]
        assert_same_frame(*both)
        reports.append(both[0][2])
        if both[0][2]["complete"]:
            break
    assert reports[-1]["complete"] and len(reports) >= 3
    assert len(reports[0]["requests"]) >= 2 and reports[0]["error_bound"] is None  # (mip: no bound)


def test_the_asking_grid_bounds_what_coarser_bricks_draw_in_finer_cells_and_flags_missing_ones():
    """Level-0 cells drawn from their level-1 ancestor (a missing cell): each block of the grid
    bounds every sample of level 1 in it (random positions) and no more where a cell draws nothing;
    .g is 1 exactly on the blocks within EDGE of the
    missing cells (here: the blocks of those cells and the ring of blocks around them)."""
    from scipy.ndimage import map_coordinates
    from vgraph.bricks.cache import texture_format
    from vgraph.bricks.pyramid import ArrayPyramid
    from vgraph.bricks.brick_geometry import BrickGeometry
    from vgraph.bricks.walk_grids import asking_grid
    data = noise((40, 32, 48)).data
    source = ArrayPyramid(data, brick=(16, 16, 16))
    geometry = BrickGeometry(source)
    fmt = texture_format(source.dtype, source.value_range)
    lo, hi = source.value_range
    level1 = [(1, z, y, x) for z in range(geometry.grids[1][2]) for y in range(geometry.grids[1][1])
              for x in range(geometry.grids[1][0])]
    ranges = np.stack([block_ranges(source, key, fmt) for key in level1])
    slot_of = {key: i for i, key in enumerate(level1)}.__getitem__
    cells = [(0, z, y, x) for z in range(geometry.grids[0][2]) for y in range(geometry.grids[0][1])
             for x in range(geometry.grids[0][0])]
    parent = [(1, z // 2, y // 2, x // 2) for _, z, y, x in cells]
    nothing = (0, 2, 1, 2)  # a missing cell with nothing resident above it
    bricks = [None if cell == nothing else brick for cell, brick in zip(cells, parent)]
    missing = np.asarray([(0, 1, 0, 1), nothing])
    grid, block = asking_grid(source, geometry, cells, slot_of, ranges, bricks, missing)
    every, _ = asking_grid(source, geometry, cells, slot_of, ranges, parent, missing)
    assert block == 8 and grid.shape == (5, 4, 6, 2)
    maxima = grid[..., 0]
    assert np.all(maxima <= every[..., 0])
    points = np.random.default_rng(5).random((20000, 3)) * np.asarray(data.shape)  # t * dims0, [z, y, x]
    blocks = tuple((points // 8).astype(int).T)
    drawn = ~np.all((points // 16).astype(int) == np.asarray(nothing[1:]), axis=1)
    voxels = (source.read(1, (0, 0, 0), source.levels[1].shape).astype(np.float64) - lo) / (hi - lo)
    values = map_coordinates(voxels, (points.T - 0.5) / 2 - 0.25, order=1, mode="nearest")
    assert np.all(values[drawn] <= maxima[blocks][drawn] + 1e-6)
    flags = np.zeros(grid.shape[:3], dtype=bool)
    flags[1:5, 0:3, 1:5] = True  # cell (0, 1, 0, 1): blocks z 2-3, y 0-1, x 2-3, and a block around
    flags[3:5, 1:4, 3:6] = True  # cell (0, 2, 1, 2): z 4, y 2-3, x 4-5 (the volume's last along z and x)
    np.testing.assert_array_equal(grid[..., 1] == 1.0, flags)
    np.testing.assert_array_equal(every[..., 1], grid[..., 1])
