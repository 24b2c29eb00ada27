"""Ray-guided requests of the single-pass bricked ray caster (issue #33, item 2; vgraph.bricks.ray_requests):
the shader counts the planned cells the atlas misses that its rays reach; the CPU loads them by
priority under the load limit and the next frame refines. Asserted: the requests name exactly the
missing cells rays reached with the pixels that reached them, their order, frames that refine to
the in-core RayCaster's image while the report says incomplete (coarsest level, error bound),
bricks hidden behind an opaque slab never read, where the plan's read-ahead reads them all, and dvr
asking for the same cells and pixels with empty-space skipping or without."""

import numpy as np
import pytest

from vgraph.bricks.cache import LoadLimit
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks import leaf_pages
from vgraph.bricks.ray_requests import by_priority, drawn_from
from vgraph.bricks.sampling import BrickSampling
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.camera import Camera
from vgraph.frame_context import FrameContext
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.bricked import FINEST, SIZE, WINDOW, field, oblique, odd_volume, render
from helpers.networks import UNSHADED_RAMP

ONE_STEP = 1.0 / 255.0
# Opaque at 1 (the slab), translucent around 0.5 (the rest): rays stop in the slab.
SLAB_TF = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.1, 0.3, 0.8, 0.1), (0.7, 0.8, 0.6, 0.3, 0.3),
                                   (0.9, 1, 1, 1, 1.0), (1.0, 1, 1, 1, 1.0)])
SLAB = {"transfer_function": SLAB_TF, "shading": "none", "early_termination": 0.99}


def slab_volume() -> Volume:
    """48 x 32 x 32 voxels (z, y, x), bricks of 16: three layers of 2 x 2 level-0 cells along z; the
    front one (z >= 32, the eye's side) is an opaque slab, the two behind it translucent ripples."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (48, 32, 32)], indexing="ij")
    values = 0.5 + 0.12 * np.sin(7 * x) * np.cos(5 * y + 3 * z)
    values[32:] = 1.0
    return Volume(values.astype(np.float32))


def slab_network(method: str):
    volume = slab_volume()
    camera = Camera.looking_at_box(*volume_box(volume), direction=(0.0, 0.0, -1.0), projection="orthographic")
    network = ray_caster_network(volume, camera, "BrickedRayCaster", method=method, brick_size=16,
                                 lod_bias=FINEST, **SLAB)
    return volume, camera, network


def refine(network, limit: LoadLimit, frames: int = 30):
    """Frames under ``limit`` until one is complete: (images, last_frame of each)."""
    images, reports = [], []
    for number in range(frames):
        network.set("rc.sampling_rate", 1.0 + 1e-6 * (number + 1))  # (a new frame each time)
        images.append(np.asarray(network.evaluate("rc.image", size=SIZE, context=FrameContext(load_limit=limit))))
        reports.append(dict(network["rc"].last_frame))
        if reports[-1]["complete"]:
            break
    return images, reports


def test_requests_go_by_pixels_then_coarser_levels_first():
    requests = [((0, 1, 0, 0), 10), ((1, 0, 0, 0), 10), ((0, 0, 0, 0), 30), ((0, 0, 0, 1), 10), ((2, 0, 0, 0), 5)]
    assert by_priority(requests) == [((0, 0, 0, 0), 30), ((1, 0, 0, 0), 10), ((0, 0, 0, 1), 10),
                                     ((0, 1, 0, 0), 10), ((2, 0, 0, 0), 5)]


def test_the_wanted_table_marks_the_level_0_cells_of_missing_cells_and_the_walk_finds_ancestors():
    geometry = BrickGeometry(ArrayPyramid(field((20, 16, 28)), brick=(8, 8, 8)))  # level 0: 4 x 2 x 3 cells
    planned = [(1, 0, 0, 0), (0, 2, 1, 3), (0, 2, 1, 2)]
    resident = np.array([(0, 2, 1, 2)])  # in the atlas: not missing
    leaf = leaf_pages.build(geometry, planned, resident, np.zeros((1, 3)),
                            lambda level: np.zeros(geometry.grids[level][::-1]), slots=8)
    assert leaf.missing.tolist() == [[1, 0, 0, 0], [0, 2, 1, 3]] and leaf.level == 0  # a flat table: one texel a cell
    wanted = leaf.wanted  # 1 + the index in `missing` of the missing cell holding each level-0 cell
    assert wanted.shape == (3, 2, 4)
    assert (wanted[:2, :2, :2] == 1.0).all() and wanted[2, 1, 3] == 2.0
    assert np.count_nonzero(wanted) == 9
    resident = {(2, 0, 0, 0), (1, 0, 0, 1)}
    assert drawn_from(geometry, (0, 1, 1, 3), resident) == (1, 0, 0, 1)
    assert drawn_from(geometry, (0, 2, 1, 3), resident) == (2, 0, 0, 0)
    assert drawn_from(geometry, (0, 2, 1, 3), set()) is None


def test_requests_name_exactly_the_missing_cells_rays_reached_with_their_pixels():
    volume, camera, network = slab_network("single_pass")
    images, reports = refine(network, LoadLimit(bricks=2))
    assert reports[-1]["complete"]
    rc = network["rc"]
    front = (0, 2, 1, 0)  # a cell of the slab, in every ray's way at x < 16, y >= 16
    rc.parts[PagedSampling].atlas.evict(front)
    rc.parts[BrickSampling].cache.ram.pop(front)
    network.set("rc.sampling_rate", 1.0)
    image = np.asarray(network.evaluate("rc.image", size=SIZE, context=FrameContext(load_limit=LoadLimit(bricks=0))))
    frame = rc.last_frame
    # The pixels whose rays enter the cell: orthographic along -z, those entering the box with
    # x < 1/2 and y >= 1/2 in texture coordinates (the cell owns [0, 1/2) x [1/2, 1)).
    entry = np.asarray(network.evaluate("eep.entry", size=SIZE))
    hit = entry[..., 3] > 0
    inside = hit & (entry[..., 0] < 0.5) & (entry[..., 1] >= 0.5)
    assert [key for key, _ in frame["requests"]] == [front]  # none of the hidden cells behind it
    assert frame["requests"][0][1] == int(inside.sum()) > 0
    assert frame["bricks_read"] == 1 and not frame["complete"] and frame["coarsest_level"] == 1
    assert rc.frame_summary().endswith("coarsest level 1; refining")
    assert np.abs(image - images[-1]).max() <= ONE_STEP  # (the slab is flat: level 1 draws it alike)
    network.set("rc.sampling_rate", 1.0 + 1e-7)
    again = np.asarray(network.evaluate("rc.image", size=SIZE, context=FrameContext(load_limit=LoadLimit(bricks=0))))
    assert rc.last_frame["complete"] and rc.last_frame["bricks_read"] == 0 and rc.last_frame["requests"] == []
    assert np.abs(again - images[-1]).max() <= ONE_STEP


@pytest.mark.parametrize("limit", [2, 64])  # 64: the plan's 12 level-0 bricks would fit one frame
def test_bricks_hidden_behind_an_opaque_slab_are_never_read_where_the_read_ahead_reads_them_all(limit):
    volume, camera, network = slab_network("single_pass")
    images, reports = refine(network, LoadLimit(bricks=limit))
    assert reports[-1]["complete"] and reports[-1]["levels"] == [0] and len(reports) >= 2
    assert not reports[0]["complete"] and reports[0]["coarsest_level"] > 0  # coarse first
    read = sum(report["bricks_read"] for report in reports)
    cache = network["rc"].parts[BrickSampling].cache
    hidden = [(0, z, y, x) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    assert not set(hidden) & set(cache.ram) and cache.stats["bricks_read"] == read
    assert reports[-1]["unreached"] == len(hidden)
    want, _, _ = render(volume, camera, "RayCaster", **SLAB)
    assert np.abs(images[-1] - want).max() <= ONE_STEP and want[..., :3].max() > 0.5

    _, _, passes = slab_network("passes")  # the pass per brick reads the plan's bricks ahead
    _, passes_reports = refine(passes, LoadLimit(bricks=limit))
    assert passes_reports[-1]["complete"]
    passes_read = sum(report["bricks_read"] for report in passes_reports)
    assert set(hidden) <= set(passes["rc"].parts[BrickSampling].cache.ram)
    assert read < passes_read


@pytest.mark.parametrize("mode", ["dvr", "mip", "iso"])
def test_frames_refine_to_the_in_core_image_and_say_how_far_they_are_until_complete(mode):
    volume = odd_volume()
    camera = oblique(volume)
    properties = {**UNSHADED_RAMP, "compositing": mode, "early_termination": 1.0}
    want, _, _ = render(volume, camera, "RayCaster", **properties)
    network = ray_caster_network(volume, camera, "BrickedRayCaster", method="single_pass", brick_size=16,
                                 lod_bias=FINEST, **properties)
    images, reports = refine(network, LoadLimit(bricks=3))
    assert len(reports) > 2 and reports[-1]["complete"]
    for report in reports[:-1]:
        assert not report["complete"] and report["missing"] > 0 and report["coarsest_level"] > 0
        assert report["error_bound"] > 0.0 if mode == "dvr" else report["error_bound"] is None  # (dvr's alone)
        assert report["requests"] == by_priority(report["requests"])
    assert all(later["missing"] < earlier["missing"] for earlier, later in zip(reports, reports[1:-1]))
    last = reports[-1]
    assert last["levels"] == [0] and last["coarsest_level"] == 0
    assert last["error_bound"] == (0.0 if mode == "dvr" else None)
    assert network["rc"].frame_summary().endswith("; complete")
    assert np.abs(images[-1] - want).max() <= 2 * ONE_STEP  # (the sampling rate moved by 3e-5)
    assert np.abs(images[0] - want).max() > 5 * ONE_STEP   # the first frame was coarse


def test_without_room_for_a_fallback_the_frame_still_reads_only_what_rays_ask_for():
    """32 level-0 bricks of 16 under a budget of 32 of them; an opaque block hides one, so the plan
    is never all in memory and the coarser fallback (4 bricks of level 1) does not fit beside the
    31 the rays asked for: it is dropped (not the whole plan read, as the pass per brick does), and
    frames still refine to the complete image without the hidden brick."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (32, 64, 64)], indexing="ij")
    values = 0.5 + 0.12 * np.sin(7 * x) * np.cos(5 * y + 3 * z)
    values[16:, :20, :20] = 1.0  # in front of the cell (0, 0, 0, 0), seen from +z, and a little wider
    volume = Volume(values.astype(np.float32))
    clear = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.1, 0.3, 0.8, 0.02), (0.7, 0.8, 0.6, 0.3, 0.05),
                                     (0.9, 1, 1, 1, 1.0), (1.0, 1, 1, 1, 1.0)])
    properties = {"transfer_function": clear, "shading": "none", "early_termination": 0.99}
    camera = Camera.looking_at_box(*volume_box(volume), direction=(0.0, 0.0, -1.0), projection="orthographic")
    slot = 20 ** 3 * 4  # a brick of 16 with its apron, float32
    network = ray_caster_network(volume, camera, "BrickedRayCaster", method="single_pass", brick_size=16,
                                 lod_bias=FINEST, gl_budget=32 * slot / 2**20, **properties)
    images, reports = refine(network, LoadLimit(bricks=4))
    assert network["rc"].last_frame["atlas_slots"] == 32
    assert reports[-1]["complete"] and reports[-1]["unreached"] == 1 and reports[-1]["levels"] == [0]
    assert (0, 0, 0, 0) not in network["rc"].parts[BrickSampling].cache.ram
    want, _, _ = render(volume, camera, "RayCaster", **properties)
    assert np.abs(images[-1] - want).max() <= ONE_STEP and want[..., :3].max() > 0.5


@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
def test_dvr_refining_frames_skip_the_stand_ins_empty_blocks_and_draw_and_ask_as_without_skipping(shading, monkeypatch):
    """dvr's refining frames march over the slots' block flags (mip's and iso's walk their grids).
    Every box of a frame that asks ends at its level-0 cell, so the first one, which draws every
    cell from a level-1 stand-in, skips the stand-ins' empty blocks (PAGED_BLOCKS) within the
    level-0 cell the ray is in, and draws and asks (keys and pixels) as the frame without skipping
    does, bit for bit; so do the part-loaded ones and the complete one."""
    from vgraph.bricks import paged_grids
    built, radii = paged_grids.block_radii, []

    def recording(blocks, skip, slots, drawn, spans, empty_cells=None, rule=None, stand_ins=False):
        values = built(blocks, skip, slots, drawn, spans, empty_cells, rule, stand_ins)
        radii.append((stand_ins, any(key in drawn for key in slots), bool((values > 0.5).any())))
        return values
    monkeypatch.setattr(paged_grids, "block_radii", recording)
    volume = Volume(field((64, 64, 64)))
    properties = {"transfer_function": WINDOW, "shading": shading, "early_termination": 1.0}
    networks = [ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass", brick_size=16,
                                   lod_bias=FINEST, empty_space_skipping=skipping, **properties)
                for skipping in (True, False)]
    marched = []
    for number in range(1, 30):
        frames = []
        for network in networks:
            network.set("rc.sampling_rate", 1.0 + 1e-6 * number)
            image = network.evaluate("rc.image", size=SIZE, context=FrameContext(load_limit=LoadLimit(bricks=8)))
            frames.append((np.asarray(image), dict(network["rc"].last_frame), dict(network["rc"].passes[-1].defines)))
        (image, report, defines), (plain_image, plain_report, _) = frames
        np.testing.assert_array_equal(image, plain_image)
        assert report["requests"] == plain_report["requests"]
        marched.append((report["levels"], report["complete"], bool(defines.get("PAGED_BLOCKS"))))
        if report["complete"]:
            break
    assert marched[0] == ([1], False, True)  # every cell drawn from a level-1 stand-in, skipped in
    assert radii[0] == (True, False, True)  # no slot drawn wholly, yet blocks to jump: the stand-ins'
    assert any(levels == [0, 1] and flags for levels, complete, flags in marched if not complete)


@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
def test_dvr_asks_for_the_same_cells_with_empty_space_skipping_or_without(shading):
    """The first frame draws every level-0 cell from its level-1 ancestor (a whole level: runs used
    to span the ancestor's cell, and jumps its empty blocks, asking only where they started), so
    without skipping rays asked for none of the cells on the far side of each ancestor (the bonsai:
    56 of 64 cells against 64 with it). Every frame's requests (keys and pixels) and image are the
    same either way, the first one asks for every planned cell (nothing hides any: no early
    termination), and both end at the in-core image."""
    volume = Volume(field((64, 64, 64)))
    camera = oblique(volume)
    properties = {"transfer_function": WINDOW, "shading": shading, "early_termination": 1.0}
    networks = [ray_caster_network(volume, camera, "BrickedRayCaster", method="single_pass", brick_size=16,
                                   lod_bias=FINEST, empty_space_skipping=skipping, **properties)
                for skipping in (True, False)]
    pairs = [refine(network, LoadLimit(bricks=8)) for network in networks]
    (images, reports), (plain_images, plain_reports) = pairs
    assert [r["requests"] for r in reports] == [r["requests"] for r in plain_reports]
    for image, plain in zip(images, plain_images):
        np.testing.assert_array_equal(image, plain)
    first = reports[0]
    assert first["levels"] == [1] and first["unreached"] == 0 and len(first["requests"]) > 16
    assert all(pixels > 0 for _, pixels in first["requests"])
    assert reports[-1]["complete"] and reports[-1]["levels"] == [0] and len(reports) > 2
    want, _, _ = render(volume, camera, "RayCaster", **properties)
    assert np.abs(images[-1] - want).max() <= 2 * ONE_STEP  # (the sampling rate moved by a few 1e-6)
