"""BrickedRayCaster: the RayCaster's images brick by brick (dvr, mip, iso, shading; synthetic volumes
with odd dimensions and features across 16^3 bricks, and the bonsai), the brick cache under budgets
(evictions, re-reads, pinned bricks), TF-empty bricks never read, the level-of-detail fallback with
its warning, and refused property values."""

import warnings

import numpy as np
import pytest

from vgraph import ProcessorError, PropertyError, VGraphWarning
from vgraph.bricks.cache import (HALO, MB, BrickCache, block_ranges_of, read_with_halo, texture_format,
                                 to_texture_values)
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.camera import Camera
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

import helpers.bricked
from helpers.bricked import FINEST, SIZE, WINDOW, big_volume, field, oblique, odd_volume, psnr, render
from helpers.networks import UNSHADED_RAMP

# PSNR against the RayCaster (images in [0, 1]); measured 140-150 dB on llvmpipe for the cases
# below (float rounding of the brick coordinates and of the regrouped sums), inf where identical.
MIN_PSNR = 50.0


def reference(volume, camera, size=SIZE, **properties):
    """The RayCaster without early termination (the bricked sum has none: see the docs)."""
    extra = {"early_termination": 1.0} if properties.get("compositing", "dvr") == "dvr" else {}
    return render(volume, camera, "RayCaster", size, **properties, **extra)


def assert_like_raycaster(volume, camera, size=SIZE, brick_size=16, **properties):
    want, want_depth, _ = reference(volume, camera, size, **properties)
    got, got_depth, rc = render(volume, camera, size=size, brick_size=brick_size, lod_bias=FINEST, **properties)
    assert rc.last_frame["levels"] == [0]
    assert psnr(got, want) >= MIN_PSNR, psnr(got, want)
    hit = want_depth[..., 3] > 0
    np.testing.assert_array_equal(got_depth[..., 3] > 0, hit)
    np.testing.assert_allclose(got_depth[..., :2][hit], want_depth[..., :2][hit], atol=1e-3 * volume.dims[0])
    return got, rc


# --- equality with the RayCaster --------------------------------------------------------------------
@pytest.mark.parametrize("properties", [
    {"compositing": "dvr", "transfer_function": WINDOW},
    {"compositing": "dvr", "transfer_function": WINDOW, "shading": "blinn_phong", "sampling_rate": 2.0},
    {"compositing": "mip"},
    {"compositing": "iso", "iso_level": 0.55},
    {"compositing": "iso", "iso_level": 0.55, "shading": "blinn_phong", "derivatives": "sobel"},
], ids=["dvr", "dvr-shaded-rate2", "mip", "iso", "iso-sobel"])
def test_synthetic_volume_with_odd_dims_matches_the_raycaster(properties):
    assert_like_raycaster(odd_volume(), oblique(odd_volume()), **properties)


def test_orthographic_view_matches_the_raycaster():
    volume = odd_volume()
    camera = Camera.looking_at_box(*volume_box(volume), direction=(0.3, -0.5, -1.0), projection="orthographic")
    assert_like_raycaster(volume, camera, compositing="dvr", transfer_function=WINDOW)


bonsai = helpers.bricked.bonsai  # the fixture: the CT bonsai at 64^3


@pytest.mark.parametrize("mode", ["dvr", "mip", "iso"])
def test_bonsai_matches_the_raycaster(bonsai, mode):
    properties = {"dvr": {"transfer_function": WINDOW, "shading": "blinn_phong"},
                  "mip": {}, "iso": {"iso_level": 0.3}}[mode]
    image, _ = assert_like_raycaster(bonsai, oblique(bonsai), brick_size=16, compositing=mode, **properties)
    assert image[..., :3].std() > 0.01  # something is shown


def test_early_termination_is_the_difference_to_the_default_raycaster():
    """The RayCaster stops rays at opacity 0.99; blended bricks (early_termination 1, the
    default) sum all: at most 1% per channel."""
    volume = odd_volume()
    opaque = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 1.0, 0.5, 0.2, 0.5), (1.0, 1, 1, 1, 1.0)])
    default, _, _ = render(volume, oblique(volume), "RayCaster", compositing="dvr", transfer_function=opaque)
    got, _, _ = render(volume, oblique(volume), brick_size=16, lod_bias=FINEST, transfer_function=opaque)
    assert np.abs(got - default).max() <= 0.0101
    assert psnr(got, default) >= 40.0


@pytest.mark.parametrize("early_termination", [0.99, 0.6])
def test_bricks_reading_the_accumulation_terminate_rays_where_the_raycaster_does(early_termination):
    volume = odd_volume()
    opaque = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 1.0, 0.5, 0.2, 0.5), (1.0, 1, 1, 1, 1.0)])
    properties = dict(compositing="dvr", transfer_function=opaque, shading="blinn_phong",
                      early_termination=early_termination)
    want, want_depth, _ = render(volume, oblique(volume), "RayCaster", **properties)
    got, got_depth, rc = render(volume, oblique(volume), brick_size=16, lod_bias=FINEST, **properties)
    assert psnr(got, want) >= MIN_PSNR  # measured 142-146 dB
    np.testing.assert_allclose(got_depth[..., :2], want_depth[..., :2], atol=1e-4)
    assert [p.shader for p in rc.passes] == ["bricks/brick.frag.glsl", "bricks/resolve.frag.glsl"]
    assert rc.passes[0][1]["READ_ACCUMULATION"] and rc.passes[0][1]["EARLY_TERMINATION"]


# --- the brick cache ---------------------------------------------------------------------------------
def test_halo_replicates_the_border_and_reads_neighbours():
    data = np.arange(20 * 18 * 17, dtype=np.float32).reshape(20, 18, 17)
    pyramid = ArrayPyramid(data, brick=(8, 8, 8))
    padded = np.pad(data, HALO, mode="edge")
    block = read_with_halo(pyramid, (0, 1, 2, 0))  # z 8..16, y 16..18 (last, partial), x 0..8
    np.testing.assert_array_equal(block, padded[8:16 + 2 * HALO, 16:18 + 2 * HALO, 0:8 + 2 * HALO])


def test_block_ranges_cover_every_voxel_their_samples_filter():
    data = np.random.default_rng(3).random((21, 17, 30)).astype(np.float32)
    pyramid = ArrayPyramid(data, brick=(16, 16, 16))
    fmt = texture_format(pyramid.dtype, pyramid.value_range)
    block = to_texture_values(read_with_halo(pyramid, (0, 1, 0, 1)), fmt, pyramid.value_range)
    ranges = block_ranges_of(block, fmt)
    assert ranges.shape == (1, 2, 2, 2)  # core 5 x 16 x 14 voxels in blocks of 8
    for k in np.ndindex(*ranges.shape[:3]):  # voxels 8k - 1 .. 8k + 8 of the core, + HALO in the array
        part = block[tuple(slice(8 * i + HALO - 1, 8 * i + 9 + HALO) for i in k)]
        normalised = part * np.float64(fmt.scale) + fmt.offset
        np.testing.assert_allclose(ranges[k], (normalised.min(), normalised.max()), rtol=1e-6)


@pytest.mark.parametrize("properties", [{"compositing": "dvr", "transfer_function": WINDOW},
                                        {"compositing": "mip"}, {"compositing": "iso", "iso_level": 0.55}],
                         ids=["dvr", "mip", "iso"])
def test_skipping_empty_blocks_inside_bricks_leaves_the_image_unchanged(properties):
    volume = odd_volume()
    images = [render(volume, oblique(volume), brick_size=16, lod_bias=FINEST, empty_space_skipping=skip,
                     **properties)[0] for skip in (False, True)]
    np.testing.assert_array_equal(images[0], images[1])


def test_cache_evicts_least_recently_used_but_never_pinned_bricks():
    pyramid = ArrayPyramid(np.zeros((32, 32, 32), np.float32), brick=(8, 8, 8))
    one = (8 + 2 * HALO) ** 3 * 4
    cache = BrickCache(ram_budget_mb=3.5 * one / MB, gl_budget_mb=1.0)
    cache.use_source(pyramid)
    keys = [(0, 0, 0, i) for i in range(4)]
    cache.begin_frame(keys[:1])
    for key in keys:
        cache.brick(key)
    assert list(cache.ram) == [keys[0], keys[2], keys[3]]  # pinned kept, oldest unpinned gone
    assert cache.stats["ram_evictions"] == 1 and cache.stats["bricks_read"] == 4
    cache.brick(keys[1])
    assert cache.stats["bricks_read"] == 5 and cache.stats["ram_misses"] == 5


def corner_camera(volume, right: bool) -> Camera:
    """Orthographic, looking down -z at the first or last column of 32^3 bricks (at CORNER_SIZE
    the view is 24 voxels wide: the neighbouring column is culled)."""
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    x = lo[0] + (112.0 if right else 16.0)
    return Camera(projection="orthographic", position=(x, centre[1], hi[2] + 10.0),
                  focus=(x, centre[1], centre[2]), near=1.0, far=200.0,
                  parallel_scale=(hi[1] - lo[1]) / 2)


CORNER_SIZE = (12, 64)


def test_a_budget_of_a_few_bricks_evicts_and_reads_again_but_frames_stay_complete():
    volume = big_volume()
    network = ray_caster_network(volume, corner_camera(volume, False), "BrickedRayCaster", compositing="mip",
                                 brick_size=32, lod_bias=FINEST, ram_budget=4.0, gl_budget=4.0, method="passes",
                                 **UNSHADED_RAMP)
    rc = network["rc"]
    frames = []
    for right in (False, True, False):
        network.set("eep.camera", corner_camera(volume, right))
        frames.append(np.asarray(network.evaluate("rc.image", size=CORNER_SIZE)))
        assert rc.last_frame["levels"] == [0] and rc.last_frame["bricks"] == 16
        want, _, _ = reference(volume, corner_camera(volume, right), size=CORNER_SIZE, compositing="mip")
        assert psnr(frames[-1], want) >= MIN_PSNR
    stats = rc.cache.stats
    held = int(4.0 * MB // (32 + 2 * HALO) ** 3 // 4)  # 22 float32 bricks with halo in 4 MB
    assert stats["ram_evictions"] == stats["gl_evictions"] == 2 * (32 - held)
    assert stats["bricks_read"] == 32 + 16 - (held - 16)  # the first view's evicted bricks read again
    ram, gl = rc.cache.resident_bytes()
    assert ram == gl == held * (32 + 2 * HALO) ** 3 * 4  # the totals the budgets are checked against


def test_a_budget_too_small_for_level_0_renders_a_coarser_level_and_says_which():
    volume = big_volume()
    camera = oblique(volume)
    with pytest.warns(VGraphWarning, match="rendering at level 1"):
        image, _, rc = render(volume, camera, size=(48, 48), compositing="mip", brick_size=32,
                              lod_bias=FINEST, ram_budget=4.0, gl_budget=4.0)
    assert rc.last_frame["levels"] == [1] and rc.last_frame["floor_level"] == 1
    want, _, _ = reference(volume, camera, size=(48, 48), compositing="mip")
    assert psnr(image, want) >= 30.0  # complete: a smooth field one level coarser
    with warnings.catch_warnings():  # said once, not every frame
        warnings.simplefilter("error")
        rc.set_property("sampling_rate", 1.5)
        rc.process(**rc.inputs, context=rc.evaluated_context)


def test_a_budget_below_one_coarsest_brick_is_an_error_naming_both_budgets():
    volume = big_volume()
    with pytest.raises(ProcessorError, match=r"rc\.ram_budget / rc\.gl_budget: .*coarsest level"):
        render(volume, oblique(volume), compositing="mip", brick_size=32, ram_budget=0.05)


def test_lod_bias_picks_levels_from_the_projected_voxel_size():
    volume = big_volume()
    _, _, rc = render(volume, oblique(volume), size=(32, 32), compositing="mip", brick_size=32)
    assert rc.last_frame["levels"] and min(rc.last_frame["levels"]) >= 1  # voxels of 1/4 pixel
    _, _, rc = render(volume, oblique(volume), size=(32, 32), compositing="mip", brick_size=32, lod_bias=FINEST)
    assert rc.last_frame["levels"] == [0]


def test_finest_level_draws_no_brick_finer_and_without_a_budget_warning():
    """finest_level L with lod_bias -16 draws every brick at level L (how the accuracy report
    compares levels); the level was asked for, so nothing warns of a raised one."""
    volume = big_volume()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        level_1, _, rc = render(volume, oblique(volume), size=(32, 32), brick_size=32, lod_bias=FINEST,
                                finest_level=1)
    assert rc.last_frame["levels"] == [1] and rc.last_frame["floor_level"] == 1
    level_0, _, _ = render(volume, oblique(volume), size=(32, 32), brick_size=32, lod_bias=FINEST)
    assert 0 < np.abs(level_1 - level_0).max() < 0.5  # the same picture, coarser


def test_a_camera_inside_the_volume_matches_the_raycaster():
    """Bricks behind the eye get the whole viewport; rays start on the near plane."""
    volume = big_volume()
    camera = Camera(position=(64.0, 64.0, 100.0), focus=(60.0, 50.0, 0.0), fov=60.0, near=0.5, far=400.0)
    got, _, rc = render(volume, camera, compositing="mip", brick_size=32, lod_bias=FINEST)
    want, _, _ = reference(volume, camera, compositing="mip")
    assert psnr(got, want) >= MIN_PSNR and rc.last_frame["bricks"] < 64


def test_mixed_levels_tile_the_volume_without_cracks():
    """Near bricks at level 0, far ones at level 1 (lod_bias 1): a complete frame close to the
    RayCaster's (a missing or doubled brick would cost tens of dB)."""
    volume = big_volume()
    camera = Camera(position=(-20.0, -20.0, 150.0), focus=(127.0, 127.0, 0.0), fov=40.0)
    got, _, rc = render(volume, camera, size=(64, 64), compositing="dvr", transfer_function=WINDOW,
                        brick_size=16, lod_bias=1.0)
    want, _, _ = reference(volume, camera, size=(64, 64), compositing="dvr", transfer_function=WINDOW)
    assert rc.last_frame["levels"] == [0, 1]
    assert psnr(got, want) >= 45.0  # measured 54.8 dB


# --- empty bricks --------------------------------------------------------------------------------------
class RecordingPyramid(ArrayPyramid):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.reads = []

    def read(self, level, start, stop):
        self.reads.append((level, tuple(start)))
        return super().read(level, start, stop)


class CarryingVolume(Volume):
    """A volume with its own pyramid, as a BrickedVolume has."""

    pyramid = None

    @property
    def bricks(self):
        return self.pyramid


def test_bricks_empty_under_the_transfer_function_are_never_read():
    data = np.zeros((48, 48, 48), np.float32)
    data[4:14, 30:44, 6:12] = 1.0  # one block in a corner: bricks (0, 1|2, 0) and their halo
    volume = CarryingVolume(data)
    volume.pyramid = RecordingPyramid(data, brick=(16, 16, 16))
    tf = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.2, 0, 0, 0, 0), (0.5, 1, 1, 1, 0.5), (1.0, 1, 1, 1, 0.5)])
    image, _, rc = render(volume, oblique(volume), transfer_function=tf, lod_bias=FINEST)
    read = {start for level, start in volume.pyramid.reads if level == 0}
    assert 0 < len(read) == rc.last_frame["bricks"] < 27
    assert all(start[0] < 32 - HALO for start in read)  # z bricks beyond the block's neighbours: never read
    want, _, _ = reference(volume, oblique(volume), transfer_function=tf)
    assert psnr(image, want) >= MIN_PSNR


# --- properties ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, value", [("ram_budget", 0), ("gl_budget", 0.0), ("brick_size", 24),
                                         ("brick_size", 4), ("brick_size", 0)])
def test_bad_property_values_are_refused_naming_processor_and_field(name, value):
    from vgraph.registry import registry
    with pytest.raises(PropertyError, match=rf"rc\.{name}"):
        registry.get("BrickedRayCaster")(id="rc", **{name: value})


def test_a_bricked_volume_from_an_ome_zarr_store_renders_like_its_array(tmp_path):
    """The BrickedVolume's own pyramid (vgraph convert) is used: its bricks, not brick_size."""
    pytest.importorskip("zarr")
    from vgraph.io.convert import convert
    data = (field((45, 38, 51)) * 65535).astype(np.uint16)
    np.save(tmp_path / "v.npy", data)
    convert(tmp_path / "v.npy", tmp_path / "v.zarr", brick=16, progress=False)
    bricked, memory = read_volume(tmp_path / "v.zarr"), read_volume(tmp_path / "v.npy")
    want, _, _ = reference(memory, oblique(memory), compositing="dvr", transfer_function=WINDOW)
    got, _, rc = render(bricked, oblique(memory), compositing="dvr", transfer_function=WINDOW,
                        brick_size=64, lod_bias=FINEST)
    assert rc.last_frame["bricks"] == 3 * 3 * 4 and rc.cache.stats["bricks_read"] == 36
    assert psnr(got, want) >= MIN_PSNR


def test_the_raycaster_draws_a_volume_wider_than_the_texture_limit_brick_by_brick(gl):
    """Wider than GL_MAX_3D_TEXTURE_SIZE on one axis: the RayCaster hands the frame to a
    BrickedRayCaster with its own settings (the same image the BrickedRayCaster draws)."""
    limit = gl.info["GL_MAX_3D_TEXTURE_SIZE"]
    volume = Volume(field((6, 5, limit + 40)), spacing=(0.01, 1.0, 1.0))
    with pytest.raises(Exception, match="3D texture limit"):
        volume.texture(gl)  # what the RayCaster would otherwise hit
    camera = oblique(volume)
    got, _, rc = render(volume, camera, "RayCaster", compositing="mip")
    want, _, _ = render(volume, camera, compositing="mip", brick_size=64, early_termination=0.99)
    assert rc.passes and rc.frame_summary().startswith("single pass")  # auto: mip in one pass (bricks/methods.py)
    assert got[..., :3].max() > 0.5 and psnr(got, want) >= MIN_PSNR
    with pytest.raises(ProcessorError, match="rc.compositing: .* offers dvr, mip, iso, not xray"):
        render(volume, camera, "RayCaster", compositing="xray")


def test_the_raycaster_draws_a_store_over_its_memory_budget_brick_by_brick(tmp_path):
    """A BrickedVolume whose whole array exceeds its budget never loads it: the RayCaster's frame
    is drawn from bricks, like the in-memory volume's."""
    pytest.importorskip("zarr")
    from vgraph.io.convert import convert
    from vgraph.bricks.volume import BrickedVolume
    data = (field((45, 38, 51)) * 65535).astype(np.uint16)
    np.save(tmp_path / "v.npy", data)
    convert(tmp_path / "v.npy", tmp_path / "v.zarr", brick=16, progress=False)
    bricked = BrickedVolume.open(tmp_path / "v.zarr", memory_budget_mb=0.05)
    memory = read_volume(tmp_path / "v.npy")
    camera = oblique(memory)
    got, _, _ = render(bricked, camera, "RayCaster", compositing="dvr", transfer_function=WINDOW,
                       early_termination=1.0)
    want, _, _ = reference(memory, camera, compositing="dvr", transfer_function=WINDOW)
    assert got[..., :3].max() > 0.2
    assert psnr(got, want) >= MIN_PSNR
    with pytest.raises(Exception, match="memory budget"):
        bricked.data


# --- coarse first under a load limit (the GUI's; scripts have none) ------------------------------------
def refine(network, size, limit, frames=40):
    """Render the same state until the frame is complete; (last_frame, image) per frame."""
    from vgraph.frame_context import FrameContext
    rc = network["rc"]
    seen = []
    while not seen or not seen[-1][0]["complete"]:
        assert len(seen) < frames, [frame for frame, _ in seen]
        network.invalidate_downstream("rc")  # what the render server does for an incomplete frame
        image = np.asarray(network.evaluate("rc.image", size=size, context=FrameContext(load_limit=limit)))
        seen.append((dict(rc.last_frame), image))
    return seen


def test_scripts_draw_the_planned_frame_at_once():
    volume = big_volume()
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", compositing="mip", brick_size=16,
                                 lod_bias=FINEST)
    network.evaluate("rc.image", size=(48, 40))
    rc = network["rc"]
    assert rc.evaluated_context.load_limit is None and rc.last_frame["complete"] and rc.last_frame["levels"] == [0]
    assert rc.last_frame["bricks_read"] == rc.last_frame["bricks"] == rc.cache.stats["bricks_read"]


def test_a_load_limit_draws_coarse_first_and_refines_to_the_planned_frame():
    """Nothing read yet (the reading speed is unknown): the coarsest bricks first; then each frame
    reads ahead within the limit, the levels get finer, and the last frame is the planned one,
    pixel for pixel."""
    from vgraph.bricks.cache import LoadLimit
    volume = big_volume()
    make = lambda: ray_caster_network(volume, oblique(volume), "BrickedRayCaster", transfer_function=WINDOW,
                                      brick_size=16, lod_bias=FINEST, method="passes")
    planned = np.asarray(make().evaluate("rc.image", size=(48, 40)))
    network = make()
    seen = refine(network, (48, 40), LoadLimit(seconds=0.005))
    first, _ = seen[0]
    assert first["levels"] == [3] and first["bricks"] == 1 and not first["complete"]  # the coarsest: one brick
    # Every incomplete frame makes progress; the complete one may find all it needs read ahead
    # by the frame before (how much a frame reads ahead depends on how fast this machine reads).
    assert all(frame["bricks_read"] > 0 for frame, _ in seen[:-1])
    floors = [frame["floor_level"] for frame, _ in seen]
    assert floors == sorted(floors, reverse=True) and floors[-1] == 0 and len(seen) >= 2
    np.testing.assert_array_equal(seen[-1][1], planned)
    assert psnr(seen[0][1], planned) < 100.0  # the coarse frame is not the planned one yet
    # (How many frames lie between, and how fine each is, depends on how fast this machine reads.)


def test_a_budget_that_cannot_hold_a_coarse_frame_and_the_planned_bricks_draws_the_plan_whole():
    """A budget of one brick more than the plan: a coarse frame (the 8 bricks of level 1, read
    by a first frame allowed 8 bricks) and the planned bricks read so far soon do not fit together.
    Refining must not evict what it read ahead (it would never end), so from then on the plan is
    drawn whole, beyond the limit."""
    from vgraph.bricks.cache import LoadLimit
    from vgraph.frame_context import FrameContext
    volume = big_volume()
    _, _, planned = render(volume, oblique(volume), compositing="mip", brick_size=32, lod_bias=FINEST)
    count = planned.last_frame["bricks"]
    budget = (count + 1) * (32 + 2 * HALO) ** 3 * 4 / MB
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", compositing="mip", brick_size=32,
                                 lod_bias=FINEST, ram_budget=budget, gl_budget=budget, method="passes",
                                 **UNSHADED_RAMP)
    network.evaluate("rc.image", size=SIZE, context=FrameContext(load_limit=LoadLimit(bricks=8)))
    assert network["rc"].last_frame["levels"] == [1] and network["rc"].last_frame["bricks_read"] == 9
    seen = refine(network, SIZE, LoadLimit(bricks=2))
    assert seen[0][0]["levels"] == [1] and not seen[0][0]["complete"] and seen[0][0]["bricks_read"] == 2
    assert seen[-1][0]["levels"] == [0] and seen[-1][0]["bricks"] == count
    assert seen[-1][0]["bricks_read"] > 2 and len(seen) < count  # drawn whole before the limit would allow
    ram, gl = network["rc"].cache.resident_bytes()
    assert ram <= budget * MB and gl <= budget * MB
    want, _, _ = reference(volume, oblique(volume), compositing="mip")
    assert psnr(seen[-1][1], want) >= MIN_PSNR


def test_a_raycaster_drawing_a_store_brick_by_brick_refines_under_a_load_limit(tmp_path):
    """The RayCaster hands the frame context's load limit to the BrickedRayCaster that draws a store over its
    memory budget, and its last_frame says whether the frame was complete (the render process asks)."""
    pytest.importorskip("zarr")
    from vgraph.bricks.cache import LoadLimit
    from vgraph.io.convert import convert
    from vgraph.bricks.volume import BrickedVolume
    np.save(tmp_path / "v.npy", (field((45, 38, 51)) * 65535).astype(np.uint16))
    convert(tmp_path / "v.npy", tmp_path / "v.zarr", brick=16, progress=False)
    bricked = BrickedVolume.open(tmp_path / "v.zarr", memory_budget_mb=0.05)
    camera = oblique(bricked)
    planned, _, rc = render(bricked, camera, "RayCaster", compositing="mip")
    assert rc.evaluated_context.load_limit is None and rc.last_frame["complete"]
    network = ray_caster_network(bricked, camera, "RayCaster", compositing="mip", **UNSHADED_RAMP)
    seen = refine(network, SIZE, LoadLimit(bricks=6))
    assert not seen[0][0]["complete"] and len(seen) > 1
    # (auto draws mip in one pass: the still frame walks the block maxima, a refining one marches
    # front to back, and a sample at a cell's face may read either slot: a rounding apart)
    np.testing.assert_allclose(seen[-1][1], planned, atol=1e-5)
    small = Volume(field((20, 20, 20)))                  # one texture holds it: no bricks, no last frame
    network["src"].volume = small
    network.invalidate_downstream("src")
    network.evaluate("rc.image", size=SIZE)
    assert network["rc"].last_frame == {}


def test_a_raycaster_drawing_brick_by_brick_uses_its_own_brick_properties():
    """A volume wider than the GL's texture limit: the RayCaster's brick_size and lod_bias are those
    of its brick sampling (smaller bricks, more of them, the same picture; a positive lod_bias draws
    coarser levels), as the BrickedRayCaster's are."""
    from helpers.more_raycaster_cases import oblique as framing, wide
    volume = wide()
    frames = {}
    for brick_size, lod_bias in ((32, FINEST), (64, FINEST), (64, 3.0)):
        network = ray_caster_network(volume, framing(volume), "RayCaster", compositing="mip",
                                     brick_size=brick_size, lod_bias=lod_bias, **UNSHADED_RAMP)
        image = np.asarray(network.evaluate("rc.image", size=SIZE))
        frames[brick_size, lod_bias] = image, dict(network["rc"].last_frame)
    (fine_small, small), (fine, large), (_, coarse) = frames.values()
    assert small["levels"] == large["levels"] == [0] and small["bricks"] > large["bricks"]
    assert psnr(fine_small, fine) >= MIN_PSNR and fine[..., :3].max() > 0.5
    assert min(coarse["levels"]) >= 1 and coarse["bricks"] < large["bricks"]
