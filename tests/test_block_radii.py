"""vgraph.bricks.block_radii: the distances per octant that the single pass's rays jump and run by,
against brute force (every box they promise is all empty, or all occupied, and no larger one is)."""

import itertools

import numpy as np

from vgraph.bricks.atlas_blocks import AtlasBlocks
from vgraph.bricks.block_radii import OCTANTS, block_radii, forward_distances


def brute_forward(mask, signs):
    """The largest k with mask all True over the box from b to b + signs * (k - 1), by trying each k."""
    out = np.zeros(mask.shape, dtype=np.float32)
    for b in itertools.product(*[range(n) for n in mask.shape]):
        k = 0
        while True:
            ends = [c + s * k for c, s in zip(b, signs)]
            if not all(0 <= e < n for e, n in zip(ends, mask.shape)):
                break
            box = tuple(slice(min(c, e), max(c, e) + 1) for c, e in zip(b, ends))
            if not mask[box].all():
                break
            k += 1
        out[b] = k
    return out


def test_forward_distances_match_brute_force_in_every_octant_up_to_the_farthest_kept():
    rng = np.random.default_rng(3)
    mask = rng.random((5, 6, 7)) < 0.8
    for signs in OCTANTS:
        exact = brute_forward(mask, signs)
        np.testing.assert_array_equal(forward_distances(mask, signs, farthest=64), exact)
        np.testing.assert_array_equal(forward_distances(mask, signs, farthest=2), np.minimum(exact, 2.0))


def octant(values, index, per_layout):
    """The values of octant ``index`` (OCTANTS' order) from block_radii's 2 x 2 x 2 layout."""
    z, y, x = (index >> 2) & 1, (index >> 1) & 1, index & 1
    nz, ny, nx = per_layout
    return values[z * nz:(z + 1) * nz, y * ny:(y + 1) * ny, x * nx:(x + 1) * nx]


def test_empty_boxes_cross_cells_drawn_at_the_same_level_and_runs_stay_in_the_slot():
    # three level-0 cells of 2^3 blocks side by side along x, in slots 0, 1, 2 (slot grid 3 x 1 x 1);
    # the third is resident but not drawn (it stands in for nothing this frame)
    blocks = AtlasBlocks((2 * 8 + 4,) * 3, (3, 1, 1), None, {})
    rng = np.random.default_rng(5)
    skip = rng.random((3, 2, 2, 2)) < 0.7
    skip[0, :, :, 1] = skip[1, :, :, 0] = True  # an empty stretch across the first two cells' face
    slots = {(0, 0, 0, 0): 0, (0, 0, 0, 1): 1, (0, 0, 0, 2): 2}
    drawn = {(0, 0, 0, 0), (0, 0, 0, 1)}
    spans = {0: [(np.array([0]), np.array([16])), (np.array([0]), np.array([16])),
                 (np.array([0, 16, 32]), np.array([16, 32, 48]))]}
    values = block_radii(blocks, skip, slots, drawn, spans)
    assert values.shape == (4, 4, 12)
    volume = blocks.laid_out(skip) > 0  # here the slots lie as their cells do: [z, y, x] blocks
    jumpable = volume.copy()
    jumpable[:, :, 4:] = False  # the undrawn cell's blocks are never jumped
    for index, signs in enumerate(OCTANTS):
        got = octant(values, index, (2, 2, 6))
        np.testing.assert_array_equal(np.maximum(got, 0.0), brute_forward(jumpable, signs))
        for cell in range(3):
            inside = slice(2 * cell, 2 * cell + 2)
            runs = brute_forward(~jumpable[:, :, inside], signs)
            np.testing.assert_array_equal(np.maximum(-got[:, :, inside], 0.0), runs)
    forward = octant(values, 0, (2, 2, 6))
    assert forward[0, 0, 1] >= 2  # the jump from the first cell's last block reaches into the second


def test_a_core_of_no_whole_number_of_blocks_keeps_jumps_in_the_cell():
    blocks = AtlasBlocks((2 * 8 + 4,) * 3, (2, 1, 1), None, {})
    skip = np.ones((2, 2, 2, 2), dtype=bool)
    slots = {(0, 0, 0, 0): 0, (0, 0, 0, 1): 1}
    spans = {0: [(np.array([0]), np.array([16])), (np.array([0]), np.array([16])),
                 (np.array([0, 12]), np.array([12, 20]))]}  # cores of 12 and 8 voxels along x
    values = octant(block_radii(blocks, skip, slots, set(slots), spans), 0, (2, 2, 4))
    assert values[0, 0, 0] == 1 and values[0, 0, 1] == -1  # block 1 reaches past the first core
    assert values[0, 0, 2] == 2  # the last cell's blocks may reach past the volume's end


def test_boxes_cross_the_cells_the_plan_leaves_out_at_level_0():
    # cells 0 and 2 along x drawn, cell 1 between them left out by the plan (it adds nothing)
    blocks = AtlasBlocks((2 * 8 + 4,) * 3, (3, 1, 1), None, {})
    rng = np.random.default_rng(7)
    skip = rng.random((3, 2, 2, 2)) < 0.8
    skip[2] = False  # slot 2 is free: its blocks are unknown
    skip[0, :, :, 1] = True  # cell 0's blocks next to the left-out cell add nothing
    slots = {(0, 0, 0, 0): 0, (0, 0, 0, 2): 1}
    spans = {0: [(np.array([0]), np.array([16])), (np.array([0]), np.array([16])),
                 (np.array([0, 16, 32]), np.array([16, 32, 48]))]}
    empty_cells = np.array([[[False, True, False]]])
    values = block_radii(blocks, skip, slots, set(slots), spans, empty_cells)
    jumpable = np.concatenate([skip[0], np.ones((2, 2, 2), dtype=bool), skip[1]], axis=2)
    for index, signs in enumerate(OCTANTS):
        got = octant(values, index, (2, 2, 6))
        expected = brute_forward(jumpable, signs)
        np.testing.assert_array_equal(np.maximum(got[:, :, :2], 0.0), expected[:, :, :2])  # slot 0: cell 0
        np.testing.assert_array_equal(np.maximum(got[:, :, 2:4], 0.0), expected[:, :, 4:])  # slot 1: cell 2
    without = octant(block_radii(blocks, skip, slots, set(slots), spans), 0, (2, 2, 6))
    assert octant(values, 0, (2, 2, 6))[0, 0, 1] > without[0, 0, 1]  # reaches into the left-out cell
