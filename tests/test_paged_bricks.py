"""The single-pass bricked ray caster (issue #33, item 1; BrickedRayCaster ``method="single_pass"``):
the page table's states (missing, resident, refined, empty), the brick atlas's slots (placed,
evicted, reused), the image at level 0 with every brick resident against the in-core RayCaster
(dvr, mip, iso, shaded; a brick size that does not divide the volume), missing bricks drawn from a
coarser resident level, and budgets the atlas cannot honour refused by name."""

import math

import numpy as np
import pytest

from vgraph import ProcessorError, VGraphWarning
from vgraph.bricks import atlas as atlas_module
from vgraph.bricks.atlas import BrickAtlas, slot_grid_of, slot_shape_of
from vgraph.bricks.cache import HALO, LoadLimit, read_with_halo, texture_format, to_texture_values
from vgraph.bricks.page_table import EMPTY, REFINE, RESIDENT, PageTable, texel_offsets
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.sampling import BrickSampling
from vgraph.bricks.cells import coarseness
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.selection import LeafPass, key_set
from vgraph.bricks.volume import BrickedVolume
from vgraph.camera import Camera
from vgraph.clipping import ClipPlane
from vgraph.frame_context import FrameContext
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume

import helpers.bricked
from helpers.bricked import FINEST, SIZE, WINDOW, field, oblique, odd_volume, render
from helpers.networks import UNSHADED_RAMP

ONE_STEP = 1.0 / 255.0  # the bound: images within one 8-bit step of the in-core RayCaster


def single_pass(volume, camera, **properties):
    return render(volume, camera, method="single_pass", **properties)


# --- the page table ---------------------------------------------------------------------------------
def small_pyramid() -> ArrayPyramid:
    return ArrayPyramid(field((20, 24, 28)), brick=(8, 8, 8))  # levels: 28x24x20, 14x12x10, 7x6x5


def test_page_table_marks_resident_refined_missing_and_empty_cells():
    source = small_pyramid()
    geometry = BrickGeometry(source)
    planned = [(0, 0, 0, 0), (0, 0, 0, 1), (1, 1, 1, 1)]  # two level-0 cells and a level-1 one
    offsets = {(0, 0, 0, 0): np.array([10.5, 0.5, 0.5]), (2, 0, 0, 0): np.array([30.5, 0.5, 0.5])}
    table = PageTable.entries(geometry, planned, offsets, lambda level: np.full(geometry.grids[level][::-1], 0.25))
    (size_x, size_y, size_z), z = PageTable.layout(geometry)
    assert table.shape == (size_z, size_y, size_x, 4) and z == [0, 3, 5]

    def entry(key):
        return table[z[key[0]] + key[1], key[2], key[3]]

    assert entry((0, 0, 0, 0)).tolist() == [10.5, 0.5, 0.5, RESIDENT]
    assert entry((0, 0, 0, 1))[3] == 0                        # planned, not in the atlas: missing
    assert entry((1, 0, 0, 0))[3] == REFINE                   # holds planned cells, not resident
    assert entry((2, 0, 0, 0)).tolist() == [30.5, 0.5, 0.5, REFINE + RESIDENT]  # a fallback for them
    assert entry((1, 1, 1, 1))[3] == 0                        # planned at level 1, missing
    assert entry((0, 1, 0, 0)).tolist() == [0.25, 0, 0, EMPTY]  # a child of a refined cell not planned
    assert entry((1, 0, 1, 1)).tolist() == [0.25, 0, 0, EMPTY]
    assert entry((0, 2, 2, 3))[3] == 0                        # below an empty cell: never reached

    # The leaf table: each level-0 cell as the shader reads it (a = 1 + level drawn, or -(1 + level
    # where the walk stopped) when nothing is drawn).
    leaf = PageTable.resolve(geometry, table)
    assert leaf.shape == (3, 3, 4, 4)
    assert leaf[0, 0, 0].tolist() == [10.5, 0.5, 0.5, 1.0]      # resident at level 0
    assert leaf[0, 0, 1].tolist() == [30.5, 0.5, 0.5, 3.0]      # missing: from the top level
    assert leaf[0, 1, 0].tolist() == [0.25, 0.0, 0.0, -1.0]     # empty at level 0
    assert leaf[0, 2, 2].tolist() == [0.25, 0.0, 0.0, -2.0]     # empty at level 1: jump its cell
    assert leaf[2, 2, 3].tolist() == [30.5, 0.5, 0.5, 3.0]      # the missing level-1 cell, from level 2


def test_texel_offsets_take_level_voxels_to_the_slot():
    source = small_pyramid()
    # brick (1, 0, 0, 1) of level 1 starts at voxel (8, 0, 0), brick (0, 2, 1, 3) of level 0 at
    # (24, 8, 16): their first voxel sits at texel HALO + 1/2 (its centre) from the slot's corner
    keys = np.array([(1, 0, 0, 1), (0, 2, 1, 3)])
    origins = np.array([(40, 20, 0), (0, 12, 24)])
    offsets = texel_offsets(source, keys, origins)
    np.testing.assert_allclose(np.array([(8, 0, 0), (24, 8, 16)]) + offsets, origins + HALO + 0.5)


# --- the atlas --------------------------------------------------------------------------------------
def test_atlas_places_evicts_the_least_recently_used_unpinned_brick_and_reuses_its_slot(gl):
    source = small_pyramid()
    fmt = texture_format(source.dtype, source.value_range)
    slot = slot_shape_of(source)
    assert slot == (12, 12, 12)  # 8 + 2 * HALO
    atlas = BrickAtlas().ensure(gl, source, fmt, 2 * np.prod(slot) * fmt.itemsize)
    assert atlas.capacity == 2
    data = {key: to_texture_values(read_with_halo(source, key), fmt, source.value_range)
            for key in [(0, 0, 0, 0), (0, 0, 0, 1), (0, 1, 1, 1)]}
    a, b, c = data
    assert atlas.place(a, lambda: data[a]) == 0 and atlas.place(b, lambda: data[b]) == 1
    assert atlas.place(a, lambda: pytest.fail("resident: no upload")) == 0  # a is now the most recent
    atlas.begin_frame({a})
    assert atlas.place(c, lambda: data[c]) == 1  # b evicted (a is pinned), its slot reused
    assert atlas.slot_of(b) is None and atlas.stats == {"uploads": 3, "evictions": 1}
    texels = np.frombuffer(atlas.texture.read(), dtype=np.float32).reshape(atlas.size[::-1])
    x, y, z = atlas.slot_origin(1)
    nz, ny, nx = data[c].shape
    np.testing.assert_array_equal(texels[z:z + nz, y:y + ny, x:x + nx], data[c])
    atlas.begin_frame({a, c})
    assert atlas.place(b, lambda: data[b]) is None  # every slot pinned: b stays missing
    atlas.release()


def test_slot_grid_stays_within_the_texture_limit():
    grid = slot_grid_of(10, (20, 20, 20), 64)
    assert np.prod(grid) >= 10 and max(grid) * 20 <= 64
    with pytest.raises(ValueError, match="GL_MAX_3D_TEXTURE_SIZE"):
        slot_grid_of(28, (20, 20, 20), 64)  # 3 x 3 x 3 at most


# --- images -----------------------------------------------------------------------------------------
CASES = [{"compositing": "dvr"}, {"compositing": "mip"}, {"compositing": "iso"},
         {"compositing": "dvr", "transfer_function": WINDOW},  # empty bricks skipped
         {"compositing": "dvr", "early_termination": 0.9},   # rays stop across bricks
         {"compositing": "dvr", "shading": "blinn_phong", "derivatives": "central"},
         {"compositing": "iso", "shading": "blinn_phong", "derivatives": "sobel"},
         {"compositing": "dvr", "camera": "orthographic"}]


@pytest.mark.parametrize("case", CASES, ids=lambda case: "-".join(str(v) for v in case.values() if isinstance(v, str)))
def test_single_pass_at_level_0_equals_the_in_core_raycaster(case):
    volume = odd_volume()  # 41 x 29 x 37 voxels in bricks of 16: none divides
    case = dict(case)
    camera = oblique(volume, projection="orthographic") if case.pop("camera", None) else oblique(volume)
    properties = {**UNSHADED_RAMP, "early_termination": 1.0, **case}
    want, want_depth, _ = render(volume, camera, "RayCaster", **properties)
    got, got_depth, rc = single_pass(volume, camera, brick_size=16, lod_bias=FINEST, **properties)
    assert rc.last_frame["levels"] == [0] and rc.last_frame["complete"]
    assert np.abs(got - want).max() <= ONE_STEP
    assert want[..., :3].max() > 0.2  # something to compare
    hit = want_depth[..., 3] > 0
    np.testing.assert_array_equal(got_depth[..., 3] > 0, hit)
    np.testing.assert_allclose(got_depth[..., :2][hit], want_depth[..., :2][hit], atol=1e-3 * volume.dims[0])


bonsai = helpers.bricked.bonsai  # the fixture: the CT bonsai at 64^3


@pytest.mark.parametrize("mode", ["dvr", "mip", "iso"])
def test_bonsai_at_level_0_equals_the_in_core_raycaster(bonsai, mode):
    """uint8 CT (64^3, the atlas in R16 as the volume's texture), shaded dvr with the RayCaster's
    default early termination: rays stop inside whichever brick they reach 0.99 in."""
    properties = {"dvr": {"transfer_function": WINDOW, "shading": "blinn_phong", "early_termination": 0.99},
                  "mip": {}, "iso": {"iso_level": 0.3, "shading": "blinn_phong"}}[mode]
    properties = {**UNSHADED_RAMP, "compositing": mode, **properties}
    camera = oblique(bonsai)
    want, _, _ = render(bonsai, camera, "RayCaster", **properties)
    got, _, rc = single_pass(bonsai, camera, brick_size=16, lod_bias=FINEST, **properties)
    assert rc.last_frame["levels"] == [0] and rc.last_frame["complete"]
    assert np.abs(got - want).max() <= ONE_STEP and got[..., :3].std() > 0.01


def test_an_ome_zarr_py_store_kept_in_z_renders_each_level_as_the_pass_per_brick(tmp_path):
    """Cells that are not each level's bricks (ome-zarr-py keeps z, halves y and x: vgraph.bricks.cells):
    level 0 equals the array in memory, each coarser level the pass per brick's picture of it."""
    foreign = pytest.importorskip("helpers.foreign_stores")  # (skips without ome-zarr-py)
    data = (field((24, 96, 80)) * 60000).astype(np.uint16)
    path = foreign.ome_zarr_py_image(tmp_path / "image.zarr", data, scale_factors=[2, 4, 8],
                                     scale={"z": 2.0, "y": 0.5, "x": 0.5}, storage_options={"chunks": (8, 32, 32)})
    store = foreign.opened(path)
    volume = BrickedVolume(store)
    memory = Volume(data, spacing=volume.spacing, origin=volume.origin, declared_range=volume.value_range)
    camera = Camera.looking_at_box(*volume_box(memory), direction=(-0.5, -0.3, -1.0), projection="orthographic")
    ramp = {"transfer_function": foreign.RAMP, "compositing": "mip"}
    want, _, _ = render(memory, camera, "RayCaster", **ramp)
    pixels = max(volume.spacing) * SIZE[1] / (2 * camera.parallel_scale)
    steps = coarseness(store)
    for level in range(len(store.levels)):  # a bias between two levels' coarseness: one level for all
        above = steps[level + 1] if level + 1 < len(steps) else steps[level] + 2
        bias = -16.0 if level == 0 else (steps[level] + above) / 2 + math.log2(pixels)
        got, _, rc = single_pass(volume, camera, lod_bias=bias, **ramp)
        passes, _, _ = render(volume, camera, lod_bias=bias, **ramp)
        assert rc.last_frame["levels"] == [level]
        assert np.abs(got - (want if level == 0 else passes)).max() <= ONE_STEP, level


@pytest.mark.parametrize("mode", ["dvr", "mip"])
def test_clip_planes_cut_the_single_pass_as_the_raycaster(mode):
    volume = odd_volume()
    low, high = volume_box(volume)
    plane = ClipPlane(normal=(1.0, 0.2, 0.1), point=tuple((np.asarray(low) + np.asarray(high)) / 2))
    images = {}
    for processor, extra in (("RayCaster", {}), ("BrickedRayCaster", {"method": "single_pass", "brick_size": 16,
                                                                      "lod_bias": FINEST})):
        network = ray_caster_network(volume, oblique(volume), processor, compositing=mode, early_termination=1.0,
                                     **UNSHADED_RAMP, **extra)
        uncut = np.asarray(network.evaluate("rc.image", size=SIZE))
        network.set("eep.clip_planes", (plane,))
        images[processor] = np.asarray(network.evaluate("rc.image", size=SIZE))
    assert np.abs(images["BrickedRayCaster"] - images["RayCaster"]).max() <= ONE_STEP
    assert np.abs(images["BrickedRayCaster"] - uncut).max() > 0.1  # the plane removed something seen


def without_and_with_skipping(bonsai, properties, frame):
    """(image, depth) of the single pass without and with empty-space skipping, and the last
    processor; ``frame`` "refining": level-1 bricks read first, level 0 then missing (no loads)."""
    outputs = []
    for skipping in (False, True):
        network = ray_caster_network(bonsai, oblique(bonsai), "BrickedRayCaster", method="single_pass",
                                     empty_space_skipping=skipping, **properties)
        context = None
        if frame == "refining":
            network.set("rc.finest_level", 1)
            network.evaluate("rc.image", size=SIZE)  # reads the level-1 bricks
            network.set("rc.finest_level", 0)
            context = FrameContext(load_limit=LoadLimit(bricks=0))
        outputs.append([np.asarray(network.evaluate(f"rc.{port}", size=SIZE, context=context)) for port in ("image", "depth")])
        rc = network["rc"]
        assert rc.last_frame["complete"] is (frame == "complete")
    return outputs[0], outputs[1], rc


@pytest.mark.parametrize("frame", ["complete", "refining"])
@pytest.mark.parametrize("mode", ["dvr", "iso"])
def test_skipping_empty_blocks_inside_the_atlas_bricks_leaves_the_image_and_saves_samples(bonsai, mode, frame):
    """The bonsai's bricks of 32 all hold something; their blocks of 8^3 often do not. iso walks a
    grid of skip radii where bricks are missing (PAGED_WALK: test_paged_iso_refining; where complete
    a grid of blocks of 4 holding their slots: test_paged_iso_grid), shaded dvr jumps by the slots'
    block distances (PAGED_BLOCKS) where bricks are
    missing (where complete it walks a grid of skip radii, as unshaded dvr: test_paged_walk); a
    frame with missing bricks (drawn from level 1 here) so that its rays ask for them."""
    properties = {**UNSHADED_RAMP, "compositing": mode, "brick_size": 32, "lod_bias": FINEST,
                  **({"transfer_function": WINDOW, "shading": "blinn_phong"} if mode == "dvr" else {"iso_level": 0.3})}
    (every, every_depth), (got, got_depth), rc = without_and_with_skipping(bonsai, properties, frame)
    expected = {("dvr", "complete"): "PAGED_WALK", ("iso", "complete"): "PAGED_ISO_GRID",
                ("iso", "refining"): "PAGED_WALK"}.get((mode, frame), "PAGED_BLOCKS")
    assert rc.passes[-1].defines.get(expected)
    assert np.abs(got - every).max() <= 1e-6 and got[..., :3].std() > 0.01
    # depth's b: the samples evaluated (refining: the level-1 bricks drawn under missing cells are not
    # drawn wholly from their slots, whose blocks are then never skipped: block_radii.wholly_drawn)
    assert got_depth[..., 2].sum() <= (0.7 if frame == "complete" else 1.0) * every_depth[..., 2].sum()


@pytest.mark.parametrize("frame", ["complete", "refining"])
def test_mip_skips_blocks_below_the_rays_maximum_with_the_same_image_and_depth(bonsai, frame):
    """A block whose maximum is not above the ray's running maximum holds no sample that changes the
    maximum or its first sample: image and depth as without skipping, fewer samples. Every frame
    walks the grid of its bricks' block maxima, largest first (PAGED_MIP_WALK,
    vgraph.bricks.walk_grids); a frame with missing bricks (drawn from level 1 here) with the blocks
    where its rays ask for them (PAGED_MIP_ASKS: test_paged_mip_refining)."""
    properties = {**UNSHADED_RAMP, "compositing": "mip", "brick_size": 32, "lod_bias": FINEST}
    (every, every_depth), (got, got_depth), rc = without_and_with_skipping(bonsai, properties, frame)
    assert rc.passes[-1].defines.get("PAGED_MIP_WALK")
    assert bool(rc.passes[-1].defines.get("PAGED_MIP_ASKS")) is (frame == "refining")
    assert np.abs(got - every).max() <= 1e-6 and got[..., :3].std() > 0.01
    np.testing.assert_allclose(got_depth[..., :2], every_depth[..., :2], atol=1e-5)
    # depth's b: the samples evaluated
    assert got_depth[..., 2].sum() <= (0.7 if frame == "complete" else 1.0) * every_depth[..., 2].sum()


def sparse_ball() -> Volume:
    """A small ball in the middle of 41 x 29 x 37 voxels, zero around it: most bricks of 8 (and
    their neighbours, which a brick's samples may filter) are empty."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (37, 29, 41)], indexing="ij")
    values = np.clip(1.0 - 4.0 * np.sqrt(x * x + y * y + z * z), 0.0, 1.0) ** 0.5
    return Volume(values.astype(np.float32), spacing=(1.0, 1.1, 0.9))


@pytest.mark.parametrize("compositing", ["dvr", "mip"])
def test_empty_bricks_are_neither_read_nor_drawn_and_the_image_stays(compositing):
    volume = sparse_ball()
    camera = oblique(volume)
    want, _, _ = render(volume, camera, "RayCaster", compositing=compositing, early_termination=1.0)
    _, _, passes = render(volume, camera, compositing=compositing, brick_size=8, lod_bias=FINEST)
    got, _, rc = single_pass(volume, camera, compositing=compositing, brick_size=8, lod_bias=FINEST)
    assert rc.last_frame["bricks"] == passes.last_frame["bricks"] < 0.75 * 6 * 4 * 5  # of level 0's 120
    # (render's second frame, for the depth on demand, reads nothing: every brick was read once)
    assert rc.cache.stats["bricks_read"] == rc.last_frame["bricks"]
    assert np.abs(got - want).max() <= ONE_STEP and want[..., :3].max() > 0.2


def test_a_frame_of_the_same_bricks_places_nothing_again_and_another_plan_places_its_own():
    """PagedSampling.placed: where the last frame placed the same bricks (a nudged sampling rate, a
    turned camera that sees them all), all resident, and the atlas changed nothing since, the frame
    skips its loops over them and draws what placing them again would; a plan of other bricks places them."""
    volume = odd_volume()
    camera = oblique(volume)
    network = ray_caster_network(volume, camera, "BrickedRayCaster", method="single_pass", brick_size=8,
                                 lod_bias=FINEST, early_termination=1.0, **UNSHADED_RAMP)
    first = np.asarray(network.evaluate("rc.image", size=SIZE))
    rc = network["rc"]
    paged = rc.parts[PagedSampling]
    atlas = paged.atlas
    bricks, uploads = paged.kept.placed[0], atlas.stats["uploads"]
    assert bricks == key_set(atlas.slots) and len(bricks.array) == rc.last_frame["bricks"]
    atlas.place_all = None  # frames of the same bricks must not call it
    network.set("rc.sampling_rate", 1.0 + 1e-6)
    again = np.asarray(network.evaluate("rc.image", size=SIZE))
    assert np.abs(again - first).max() < 1e-4  # (the sampling rate nudged by 1e-6 so that the frame is drawn)
    turned = Camera.looking_at_box(*volume_box(volume), direction=(0.3, -0.4, -1.0))
    network.set("eep.camera", turned)  # the same bricks in another order
    image = np.asarray(network.evaluate("rc.image", size=SIZE))
    want, _, _ = render(volume, turned, "RayCaster", early_termination=1.0)
    assert np.abs(image - want).max() <= ONE_STEP and rc.last_frame["complete"]
    assert atlas.stats["uploads"] == uploads and paged.kept.placed[0] == bricks
    del atlas.place_all  # (the class's again)
    network.set("rc.finest_level", 1)  # a plan of level-1 bricks
    coarse = np.asarray(network.evaluate("rc.image", size=SIZE))
    assert rc.last_frame["levels"] == [1] and atlas.stats["uploads"] > uploads
    assert paged.kept.placed[0] != bricks and paged.kept.placed[0] == key_set(key for key in atlas.slots if key[0] == 1)
    assert np.abs(coarse - image).max() > ONE_STEP  # another image: the level-1 bricks were placed and drawn


def test_missing_bricks_are_drawn_from_a_coarser_resident_level():
    volume = odd_volume()
    camera = oblique(volume)
    network = ray_caster_network(volume, camera, "BrickedRayCaster", method="single_pass", brick_size=16,
                                 lod_bias=FINEST, finest_level=1, **UNSHADED_RAMP)
    level_1 = np.asarray(network.evaluate("rc.image", size=SIZE))  # reads the level-1 bricks
    rc = network["rc"]
    assert rc.last_frame["levels"] == [1]
    rc.finest_level = 0  # level 0 wanted, but no brick may be read this frame
    image = np.asarray(network.evaluate("rc.image", size=SIZE, context=FrameContext(load_limit=LoadLimit(bricks=0))))
    frame = rc.last_frame
    assert frame["planned_floor_level"] == 0 and frame["levels"] == [1]
    assert not frame["complete"] and frame["missing"] > 0
    assert rc.frame_summary().startswith("single pass: level 1, 4 bricks") and rc.frame_summary().endswith("refining")
    assert image[..., :3].max() > 0.2  # not black
    assert np.abs(image - level_1).max() <= ONE_STEP  # the level-1 bricks, drawn under the level-0 cells
    full = np.asarray(network.evaluate("rc.image", size=SIZE))  # no limit: level 0 read and drawn
    assert rc.last_frame["levels"] == [0] and rc.last_frame["complete"]
    assert np.abs(full - image).max() > 5 * ONE_STEP  # level 0 is another image


def test_frames_under_a_load_limit_refine_to_the_level_0_image():
    volume = odd_volume()
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass", brick_size=16,
                                 lod_bias=FINEST, **UNSHADED_RAMP)
    want = np.asarray(network.evaluate("rc.image", size=SIZE))
    network["rc"].parts[BrickSampling].cache.clear()  # nothing in memory: read again, 4 bricks a frame
    network["rc"].parts[PagedSampling].atlas.release()
    limited = FrameContext(load_limit=LoadLimit(bricks=4))
    frames = []
    for _ in range(12):
        network.set("rc.sampling_rate", 1.0 + 1e-6 * (len(frames) + 1))  # (a new frame each time)
        image = np.asarray(network.evaluate("rc.image", size=SIZE, context=limited))
        frames.append(dict(network["rc"].last_frame))
        if frames[-1]["complete"]:
            break
    assert not frames[0]["complete"] and frames[0]["levels"][-1] > 0  # coarse first
    assert frames[-1]["complete"] and frames[-1]["levels"] == [0] and len(frames) > 2
    assert all(later["missing"] <= earlier["missing"] for earlier, later in zip(frames, frames[1:]))
    assert np.abs(image - want).max() <= 2 * ONE_STEP  # (the sampling rate moved by 1e-5)


def test_a_frame_with_more_bricks_than_atlas_slots_is_drawn_coarser_and_said_so():
    volume = odd_volume()  # 18 bricks of 16 at level 0, smaller at the far faces: ~0.45 MB in all
    slot = 20 ** 3 * 4     # the largest brick with its apron, float32
    budget = 16 * slot / 2**20  # 16 slots: the bytes of level 0 fit, its bricks not
    with pytest.warns(VGraphWarning, match=r"atlas \(16 slots .* cannot hold the frame's 18 bricks; rendering at level 1"):
        image, _, rc = single_pass(volume, oblique(volume), brick_size=16, lod_bias=FINEST, gl_budget=budget)
    assert rc.last_frame["levels"] == [1] and rc.last_frame["complete"] and image[..., :3].max() > 0.2


# --- refusals ---------------------------------------------------------------------------------------
def test_a_gl_budget_below_one_brick_names_the_processor_and_property():
    volume = odd_volume()
    # the coarsest level (11 x 8 x 10 voxels, 10 KB with its apron) would fit, a 20^3 slot (32 KB) does not
    with pytest.raises(ProcessorError, match=r"rc\.gl_budget: BrickedRayCaster 'rc' .*does not hold one brick"):
        single_pass(volume, oblique(volume), brick_size=16, gl_budget=0.02)


def test_the_leaves_split_is_refused_by_name():
    volume = odd_volume()
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", method="single_pass", brick_size=16)
    with pytest.raises(ProcessorError, match=r"rc\.method: single_pass does not draw the leaves split"):
        network.evaluate("rc.image", size=SIZE, context=FrameContext(leaf=LeafPass(bricks=[])))


def test_an_atlas_past_the_gl_texture_limit_names_the_processor_and_property(monkeypatch):
    volume = odd_volume()
    monkeypatch.setattr(atlas_module, "max_texture_size", lambda ctx: 40)  # 2 slots of 20 per axis
    with pytest.raises(ProcessorError, match=r"rc\.gl_budget: .*larger than this GL's limit of 40 texels"):
        single_pass(volume, oblique(volume), brick_size=16, lod_bias=FINEST)


def test_a_complete_frame_of_coarse_bricks_reports_the_error_bound_of_all_its_bricks():
    """paged_report.drawn_report, every planned brick in the atlas: dvr's error bound (lod_error over
    the plan's coarser bricks alone, level 0 moving nothing) and levels are the pass per brick's,
    which bounds every drawn brick; 0 where every brick is of level 0."""
    volume = odd_volume()
    camera = oblique(volume)
    for lod_bias, levels in ((FINEST, [0]), (1.0, None)):
        reports = {}
        for method in ("passes", "single_pass"):
            _, _, rc = render(volume, camera, method=method, brick_size=8, lod_bias=lod_bias, early_termination=1.0,
                              transfer_function=WINDOW)
            reports[method] = rc.last_frame
        assert reports["single_pass"]["complete"] and reports["single_pass"]["levels"] == reports["passes"]["levels"]
        assert reports["single_pass"]["error_bound"] == reports["passes"]["error_bound"]
        if levels == [0]:
            assert reports["single_pass"]["levels"] == [0] and reports["single_pass"]["error_bound"] == 0.0
        else:  # bricks of several levels, coarse ones among them: a bound above 0
            assert len(reports["single_pass"]["levels"]) > 1 and reports["single_pass"]["error_bound"] > 0.0
