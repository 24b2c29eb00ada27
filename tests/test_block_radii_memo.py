"""The block flags of frame after frame (vgraph.bricks.paged_grids.block_flags, block_radii) make
each slot's distances within its cell (wholly drawn, or a stand-in in dvr's frames that ask) only
for the slots whose brick, rule (TF, iso level, mode), grouping or standing in changed, keeping
them with the slot (AtlasBlocks.of_slot, dropped when another brick is recorded there): asserted,
in every frame of refining sequences with loads, evictions (an atlas too small for every brick,
bricks evicted by hand) and a TF change, bit for bit against the flags built from scratch on the
same inputs."""

import numpy as np
import pytest

from vgraph.bricks import block_radii as radii_module
from vgraph.bricks import paged_grids
from vgraph.bricks.cache import MB, LoadLimit
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.sampling import BrickSampling
from vgraph.testing import ray_caster_network

import helpers.bricked
from helpers.bricked import FINEST, WINDOW, oblique
from helpers.networks import UNSHADED_RAMP
from helpers.refining import frame

bonsai = helpers.bricked.bonsai  # the fixture: the CT bonsai at 64^3 (73 bricks of 16: 64 + 8 + 1)
RAMP = UNSHADED_RAMP["transfer_function"]
TFS = {"window then ramp": (WINDOW, RAMP), "ramp then window": (RAMP, WINDOW)}  # (first, then)
SLOTS = 64  # the atlas's slots: every level-0 brick (refining evicts the coarser ones for them)


@pytest.fixture
def checked(monkeypatch):
    """Every block_radii built with a rule (the memo) is also built from scratch (no rule, nothing
    kept) and asserted the same to the bit. Yields the counts {"checked": builds compared, "made":
    slots whose distances were made, "drawn": wholly drawn slots}."""
    built = radii_module.block_radii
    counts = {"checked": 0, "made": 0, "drawn": 0}

    def checking(blocks, skip, slots, drawn, spans, empty_cells=None, rule=None, stand_ins=False):
        assert rule is not None
        counts["stand-ins"] = counts.get("stand-ins", 0) + stand_ins
        before = {slot: held.get("block radii") for slot, held in blocks.derived.items()}  # (held: no id reused)
        values = built(blocks, skip, slots, drawn, spans, empty_cells, rule, stand_ins)
        again = built(blocks, skip, slots, drawn, spans, empty_cells, stand_ins=stand_ins)
        np.testing.assert_array_equal(values.view(np.uint32), again.view(np.uint32))
        counts["checked"] += 1
        counts["made"] += sum(held.get("block radii") is not before.get(slot) for slot, held in blocks.derived.items()
                              if "block radii" in held)
        counts["drawn"] += len(slots) if stand_ins else sum(key in drawn for key in slots)  # (slots with radii)
        return values
    monkeypatch.setattr(paged_grids, "block_radii", checking)
    yield counts


def network_of(volume, tf, budget: float):
    """dvr (mip's and iso's refining frames walk: no block flags)."""
    return ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass",
                              **{**UNSHADED_RAMP, "compositing": "dvr", "transfer_function": tf, "brick_size": 16,
                                 "lod_bias": FINEST, "gl_budget": budget})


@pytest.mark.parametrize("tfs", list(TFS))
def test_refining_frames_flags_equal_the_flags_built_from_scratch(bonsai, tfs, checked):
    """From an empty cache under a limit of 4 bricks a frame, an atlas of SLOTS slots (coarser bricks
    evicted for level-0 ones, their slots reused), a few level-0 bricks evicted by hand once the
    frame is complete, the other TF from the 8th frame on: every frame's flags equal those built
    from scratch; the frames make far fewer slots' distances than they draw."""
    from vgraph.bricks.atlas import slot_shape_of
    first, then = TFS[tfs]
    probe = network_of(bonsai, first, 512.0)
    frame(probe, 0, LoadLimit(bricks=1))
    atlas = probe["rc"].parts[PagedSampling].atlas
    budget = (SLOTS + 0.5) * np.prod(slot_shape_of(atlas.source)) * atlas.blocks.format.itemsize / MB
    network = network_of(bonsai, first, budget)
    rc = network["rc"]
    limit, evicted, changed, complete = LoadLimit(bricks=4), False, False, 0
    for number in range(1, 60):
        if number == 8:  # a new rule midway: every slot's distances made again
            network.set("rc.transfer_function", then)
            changed = True
        complete += frame(network, number, limit).report["complete"]
        if complete and not evicted:  # some level-0 cells missing again, drawn from coarser bricks
            atlas, cache = rc.parts[PagedSampling].atlas, rc.parts[BrickSampling].cache
            for key in [key for key in atlas.slots if key[0] == 0 and key[1] == 1][:6]:
                atlas.evict(key)
                cache.ram.pop(key, None)
            evicted, complete = True, 0
        elif complete:
            break
    atlas = rc.parts[PagedSampling].atlas
    assert evicted and changed and complete and atlas.capacity == SLOTS and atlas.stats["evictions"] > 6
    assert checked["checked"] >= 10 and checked["stand-ins"] >= 3  # (frames that ask: stand-ins skip too)
    assert 0 < checked["made"] < checked["drawn"] * 0.5
