"""What the tests of the single pass's refining frames share (tests/test_paged_iso_refining.py,
tests/test_paged_mip_refining.py): each draws a network that walks a grid where bricks are missing
beside one forced to march there (the tree before), frame after frame, and asserts the two alike.

- ``march_where_missing``: the fixture that makes a network whose processor has ``march = True``
  march its frames with missing bricks (import it into the test module, as a fixture)
- ``frame``: a new frame of a network under a load limit, as a ``Frame``
- ``frames_until_complete``: the walked network's frames, each asserted as the marched one's,
  up to the first complete one; ``assert_refines`` and ``assert_level_0_image`` check such a run
- ``leave_cells_with_nothing_drawn``: evicts bricks so some missing cells have nothing drawn
- ``assert_same_image_and_requests``: the part of two frames' comparison every mode shares
- ``two_missing_cells``: a small pyramid whose level-0 cells are drawn from level 1, two of
  them missing, for the tests of the grids themselves (walk_grids)
"""

from typing import NamedTuple

import numpy as np
import pytest

from vgraph.bricks import paged_grids
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.cache import LoadLimit, texture_format
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.sampling import BrickSampling
from vgraph.frame_context import FrameContext
from vgraph.scheduler import evaluate, target_data, to_numpy

from helpers.bricked import SIZE  # the frames' size (that of the oblique camera the networks use)

ONE_STEP = 1.0 / 255.0  # one step of an 8-bit channel: the refined image against level 0's


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


class Frame(NamedTuple):
    image: np.ndarray
    depth: np.ndarray
    report: dict  # the ray caster's last_frame
    defines: dict  # its last pass's


def frame(network, number: int, limit: LoadLimit | None) -> Frame:
    """A new frame of ``network`` (its processor ``rc``) under ``limit``."""
    network.set("rc.sampling_rate", 1.0 + 1e-6 * number)  # (a new frame each time)
    context = FrameContext(load_limit=limit) if limit is not None else None
    # Image and depth of one frame: one evaluation (a second one under a load limit draws the next
    # frame, reading more bricks).
    evaluate(network, ["rc.image", "rc.depth"], size=SIZE, context=context)
    image, depth = (np.asarray(to_numpy(target_data(network, t))) for t in ("rc.image", "rc.depth"))
    rc = network["rc"]
    return Frame(image, depth, dict(rc.last_frame), dict(rc.passes[-1].defines))


def frames_until_complete(walked, marched, numbers, bricks: int, assert_same_frame) -> list:
    """The frames of ``walked``, each drawn after ``marched``'s of the same number (of ``numbers``)
    under a limit of ``bricks`` a frame and asserted the same by ``assert_same_frame(walked's,
    marched's)``, up to the first complete one (or the last number)."""
    frames = []
    for number in numbers:
        pair = [frame(network, number, LoadLimit(bricks=bricks)) for network in (walked, marched)]
        assert_same_frame(*pair)
        frames.append(pair[0])
        if pair[0].report["complete"]:
            break
    return frames


def assert_refines(frames) -> list:
    """``frames`` (from an empty cache) end complete at level 0 after at least 3 refining frames,
    one asking for more than 4 bricks, some drawing missing cells from coarser bricks; returns the
    refining ones."""
    assert frames[-1].report["complete"] and frames[-1].report["levels"] == [0]
    refining = [f for f in frames if not f.report["complete"]]
    assert len(refining) >= 3 and max(len(f.report["requests"]) for f in refining) > 4
    assert any(f.report["coarsest_level"] > 0 for f in refining)  # missing cells drawn from coarser bricks
    return refining


def assert_level_0_image(last: Frame, whole) -> None:
    """``last`` is, within a step, the image of ``whole`` (a new network of the same case) drawn
    without a limit (everything read at once, at level 0), which is not blank."""
    image, _, report, _ = frame(whole, 1, None)
    assert report["complete"] and report["levels"] == [0]
    assert np.abs(last.image - image).max() <= ONE_STEP and image[..., :3].std() > 0.01


def leave_cells_with_nothing_drawn(network) -> None:
    """Draws a complete frame (every level-0 brick in the atlas), then evicts from the atlas and the
    cache every coarser brick and the level-0 bricks at z 1, y >= 1: those cells are missing with
    no resident ancestor (nothing drawn there) in the next frame."""
    frame(network, 1, None)
    rc = network["rc"]
    atlas, cache = rc.parts[PagedSampling].atlas, rc.parts[BrickSampling].cache
    gone = [key for key in list(atlas.slots) if key[0] > 0 or (key[1] == 1 and key[2] >= 1)]
    for key in gone:
        atlas.evict(key)
        cache.ram.pop(key, None)


def assert_same_image_and_requests(walked: Frame, marched: Frame) -> None:
    """The same image, depth (its first two channels) and requests (keys and pixels), and both
    complete or not; each mode's test adds what its defines must be."""
    np.testing.assert_array_equal(walked.image, marched.image)
    np.testing.assert_array_equal(walked.depth[..., :2], marched.depth[..., :2])  # (b: the samples taken differ)
    assert walked.report["requests"] == marched.report["requests"]  # keys and pixels, in the order read
    assert walked.report["complete"] is marched.report["complete"]


class MissingCells(NamedTuple):
    source: ArrayPyramid
    geometry: BrickGeometry
    cells: list  # every level-0 key
    slot_of: object  # a level-1 key's slot (its index in ``ranges``)
    ranges: np.ndarray  # the level-1 bricks' block ranges, as the atlas records them
    parents: list  # each cell's level-1 ancestor
    bricks: list  # what each cell is drawn from: its parent, None for ``nothing``
    missing: np.ndarray  # the missing cells' keys
    nothing: tuple  # the missing cell with nothing resident above it

    @property
    def grid_inputs(self) -> tuple:
        """The first arguments of walk_grids.asking_grid and skip_radii: (source, geometry, cells,
        slot_of, ranges)."""
        return self.source, self.geometry, self.cells, self.slot_of, self.ranges


def two_missing_cells(data, block_ranges) -> MissingCells:
    """``data`` in bricks of 16, every level-1 brick resident and every level-0 cell drawn from its
    level-1 ancestor; two cells missing, (0, 1, 0, 1) and ``nothing`` (0, 2, 1, 2), which has
    nothing drawn. ``block_ranges(source, key, fmt)``: a brick's block ranges as the atlas records
    them (test_mip_skipping's)."""
    source = ArrayPyramid(data, brick=(16, 16, 16))
    geometry = BrickGeometry(source)
    fmt = texture_format(source.dtype, source.value_range)
    level1 = [(1, z, y, x) for z in range(geometry.grids[1][2]) for y in range(geometry.grids[1][1])
              for x in range(geometry.grids[1][0])]
    ranges = np.stack([block_ranges(source, key, fmt) for key in level1])
    slot_of = {key: i for i, key in enumerate(level1)}.__getitem__
    cells = [(0, z, y, x) for z in range(geometry.grids[0][2]) for y in range(geometry.grids[0][1])
             for x in range(geometry.grids[0][0])]
    parents = [(1, z // 2, y // 2, x // 2) for _, z, y, x in cells]
    nothing = (0, 2, 1, 2)
    bricks = [None if cell == nothing else parent for cell, parent in zip(cells, parents)]
    missing = np.asarray([(0, 1, 0, 1), nothing])
    return MissingCells(source, geometry, cells, slot_of, ranges, parents, bricks, missing, nothing)
