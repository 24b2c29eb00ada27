"""The walk grids of frame after frame (vgraph.bricks.walk_grids) find the grid's blocks and values
only of the (cell, brick) pairs new since the last frame, keeping each brick's within each cell
with its atlas slot (AtlasBlocks.of_slot, dropped when another brick is recorded there): asserted,
in every frame of refining sequences with loads and evictions (an atlas too small for every brick,
bricks evicted by hand), bit for bit against the grid reduced from scratch, and the images and
requests against a network whose grids are all reduced from scratch."""

import numpy as np
import pytest

from vgraph.bricks import walk_grids
from vgraph.bricks.cache import MB
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.sampling import BrickSampling
from vgraph.testing import ray_caster_network

import helpers.bricked
from helpers.bricked import FINEST, oblique
from helpers.networks import UNSHADED_RAMP
from helpers.refining import assert_same_image_and_requests, frame

bonsai = helpers.bricked.bonsai  # the fixture: the CT bonsai at 64^3 (73 bricks of 16: 64 + 8 + 1)
MODES = {"iso": {"iso_level": 0.3}, "mip": {}, "dvr": {}}
SLOTS = 64  # the atlas's slots: every level-0 brick (refining evicts the coarser ones for them)


@pytest.fixture
def checked(monkeypatch):
    """Every grid reduced with a memo is also reduced from scratch (no memo) on the same inputs and
    asserted the same to the bit; while ``counts["from_scratch"]`` no memo is given (the frames of
    the network drawn from scratch). Yields the counts {"checked": grids compared, "new": pairs
    reduced, "pairs": pairs drawn, "from_scratch": False}."""
    reduced = walk_grids._reduced_grid
    counts = {"checked": 0, "new": 0, "pairs": 0, "from_scratch": False}

    def checking(source, geometry, keys, slot_of, values, reducer, fill, bricks=None, memo=None, channel=""):
        if memo is None or counts["from_scratch"]:
            return reduced(source, geometry, keys, slot_of, values, reducer, fill, bricks)
        before = sum(len(held) for held in memo.derived.values())
        grid, block = reduced(source, geometry, keys, slot_of, values, reducer, fill, bricks, memo, channel)
        again, _ = reduced(source, geometry, keys, slot_of, values, reducer, fill, bricks)
        np.testing.assert_array_equal(grid.view(np.uint32), again.view(np.uint32))
        counts["checked"] += 1
        counts["new"] += sum(len(held) for held in memo.derived.values()) - before
        counts["pairs"] += len(keys) if bricks is None else sum(brick is not None for brick in bricks)
        return grid, block
    monkeypatch.setattr(walk_grids, "_reduced_grid", checking)
    yield counts


def network_of(volume, mode: str, budget: float):
    return ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass",
                              **{**UNSHADED_RAMP, "compositing": mode, **MODES[mode], "brick_size": 16,
                                 "lod_bias": FINEST, "gl_budget": budget})


def evict(network, keys) -> None:
    rc = network["rc"]
    atlas, cache = rc.parts[PagedSampling].atlas, rc.parts[BrickSampling].cache
    for key in keys:
        atlas.evict(key)
        cache.ram.pop(key, None)


@pytest.mark.parametrize("texels", [None, 4 ** 3])
@pytest.mark.parametrize("mode", list(MODES))
def test_refining_frames_grids_equal_the_grids_reduced_from_scratch(bonsai, mode, texels, checked, monkeypatch):
    """From an empty cache under a limit of 4 bricks a frame, an atlas of SLOTS slots (coarser bricks
    evicted for level-0 ones, their slots reused), a few level-0 bricks evicted by hand midway:
    every grid the frames reduce with the memo equals the one reduced from scratch, and each frame's
    image and requests those of a network whose grids are all reduced from scratch; the later
    refining frames reduce fewer pairs than they draw. ``texels``: the grid's size at most, 4^3
    for blocks of 16 (as a volume past 1024^3 has): a block of the grid then takes 8 of a level-0
    brick's blocks of 8."""
    if texels is not None:
        monkeypatch.setattr(walk_grids, "MAX_TEXELS", texels)
    from vgraph.bricks.atlas import slot_shape_of
    from vgraph.bricks.cache import LoadLimit
    probe = network_of(bonsai, mode, 512.0)
    frame(probe, 0, LoadLimit(bricks=1))
    atlas = probe["rc"].parts[PagedSampling].atlas
    budget = (SLOTS + 0.5) * np.prod(slot_shape_of(atlas.source)) * atlas.blocks.format.itemsize / MB
    pair = [network_of(bonsai, mode, budget) for _ in range(2)]
    limit, evicted, complete = LoadLimit(bricks=4), False, 0
    for number in range(1, 60):
        memo_frame = frame(pair[0], number, limit)
        checked["from_scratch"] = True
        scratch_frame = frame(pair[1], number, limit)
        checked["from_scratch"] = False
        assert_same_image_and_requests(memo_frame, scratch_frame)
        complete += memo_frame.report["complete"]
        if complete and not evicted:  # some level-0 cells missing again, drawn from coarser bricks
            gone = [key for key in pair[0]["rc"].parts[PagedSampling].atlas.slots if key[0] == 0 and key[1] == 1][:6]
            for network in pair:
                evict(network, gone)
            evicted, complete = True, 0
        elif complete and evicted:
            break
    atlas = pair[0]["rc"].parts[PagedSampling].atlas
    assert evicted and complete and atlas.capacity == SLOTS and atlas.stats["evictions"] > 6
    assert checked["checked"] >= (3 if mode == "dvr" else 10)
    # most frames' pairs kept from the frames before (dvr: only its two complete frames have grids, the
    # second one reduces the pairs of the 6 bricks loaded again, in both channels)
    assert checked["new"] < checked["pairs"] * (0.6 if mode == "dvr" else 0.5)
