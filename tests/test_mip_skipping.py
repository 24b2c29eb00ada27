"""MIP with empty-space skipping (shaders/raycasting/compositing_mip.glsl: the ray's largest block
first, then only blocks that can still change the result) against the plain march: the same
image and the same depth sample, bit for bit, on a smooth volume whose maxima lie inside (torus),
CT data (bonsai), noise, plateaus with exact ties and values outside the value range (clamped),
plateaus far from zero; perspective, orthographic and a camera inside; and far fewer samples
evaluated on the torus."""

import numpy as np
import pytest

from vgraph.implicit import sample
from vgraph.io import read_volume
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import rendering_network
from helpers.paths import DATA
from helpers.skipping import SIZE, assert_same_picture, block_ranges, cameras, noise

RAMP = TransferFunction(points=[(0.0, 0.0, 0.0, 0.2, 0.0), (0.4, 0.2, 0.5, 0.9, 0.3),
                                (1.0, 1.0, 0.9, 0.6, 1.0)])


def plateaus():
    """Four values only (many exact ties along every ray, 1.0 among them) and a declared range
    that leaves some voxels above 1 and below 0 (clamped before the maximum is taken)."""
    data = np.random.default_rng(7).integers(0, 4, (30, 26, 34)).astype(np.uint8)
    data[:, :, 20:] = 1  # a slab of one value: ties everywhere and maxima equal to block maxima
    return Volume(data, declared_range=(0.5, 2.5))


def far_from_zero():
    """Plateaus around 1000 with a range of 1: intensities carry float32 rounding of the offset
    (6e-5), which the block maxima, computed in float64, do not."""
    steps = np.random.default_rng(8).integers(0, 4, (30, 26, 34))
    return Volume((1000.0 + steps / 3.0).astype(np.float32))


def spike_in_a_margin():
    """A constant volume with one bright voxel at x = 15, the last of block 1 and in the margin of
    block 2: rays through block 2 see only the constant under a block maximum of 1, so the block
    with the ray's largest maximum yields the constant, and the first sample holding it lies in
    the blocks in front, whose maximum equals it (the tie rule before the depth sample)."""
    data = np.full((24, 24, 24), 0.5, dtype=np.float32)
    data[12, 12, 15] = 1.0
    return Volume(data, declared_range=(0.0, 1.0))


VOLUMES = {"torus": lambda: sample("torus", 64, "float32"), "noise": noise, "plateaus": plateaus,
           "far_from_zero": far_from_zero, "spike_in_a_margin": spike_in_a_margin}


def with_and_without_skipping(volume, camera, size=SIZE, **properties):
    """(image, depth) with empty-space skipping, then without."""
    network = rendering_network(volume, camera, compositing="mip", transfer_function=RAMP, **properties)
    outputs = []
    for skipping in (True, False):
        network.set("rc.empty_space_skipping", skipping)
        outputs.append((network.evaluate("rc.image", size=size), network.evaluate("rc.depth", size=size)))
    assert network["rc"].passes[-1][1].get("SKIP_EMPTY_SPACE") is not True  # the second one did not skip
    return outputs


@pytest.mark.parametrize("camera_name", ["perspective", "orthographic", "inside"])
@pytest.mark.parametrize("volume_name", list(VOLUMES))
def test_skipping_changes_neither_image_nor_depth(volume_name, camera_name):
    volume = VOLUMES[volume_name]()
    skipped, plain = with_and_without_skipping(volume, cameras(volume)[camera_name])
    assert np.ptp(plain[0][..., 0]) > 0.1  # something varied is in the picture
    assert_same_picture(skipped, plain)
    assert skipped[1][..., 2].sum() <= plain[1][..., 2].sum()


@pytest.mark.parametrize("rate", [0.5, 2.3])
def test_other_sampling_rates_and_nearest_interpolation(rate):
    volume = sample("torus", 48, "float32")
    for interpolation in ("trilinear", "nearest"):
        skipped, plain = with_and_without_skipping(volume, cameras(volume)["perspective"],
                                                   sampling_rate=rate, interpolation=interpolation)
        assert_same_picture(skipped, plain)


def test_the_torus_takes_far_fewer_samples():
    """The torus's maxima lie inside: skipping blocks front to back against the running maximum
    kept 70 % of the samples here (the maximum rises slowly along a ray); starting with the ray's
    largest block keeps 35 %."""
    volume = sample("torus", 128, "float32")
    camera = cameras(volume)["perspective"]
    skipped, plain = with_and_without_skipping(volume, camera)
    covered = plain[1][..., 3] > 0
    ratio = skipped[1][..., 2][covered].sum() / plain[1][..., 2][covered].sum()
    assert ratio < 0.45, ratio


@pytest.fixture(scope="module")
def bonsai():
    path = DATA / "ct_bonsai" / "bonsai.nii.gz"
    if not path.exists():
        pytest.skip(f"shared data not found at {path}")
    return read_volume(path)


@pytest.mark.parametrize("camera_name", ["perspective", "orthographic", "inside"])
def test_bonsai(bonsai, camera_name):
    skipped, plain = with_and_without_skipping(bonsai, cameras(bonsai)[camera_name], size=(96, 96))
    assert_same_picture(skipped, plain)
    assert skipped[1][..., 2].sum() < 0.8 * plain[1][..., 2].sum()


# --- the BrickedRayCaster's MIP (shaders/bricks/composite_mip.glsl), brick by brick -------------
@pytest.mark.parametrize("volume_name", list(VOLUMES))
def test_bricked_skipping_changes_neither_image_nor_depth(volume_name):
    from vgraph.testing import ray_caster_network
    volume = VOLUMES[volume_name]()
    for camera_name in ("perspective", "inside"):
        network = ray_caster_network(volume, cameras(volume)[camera_name], "BrickedRayCaster",
                                     compositing="mip", transfer_function=RAMP, brick_size=16, lod_bias=-16.0,
                                     method="passes")  # (auto draws mip in one pass: the tests below)
        outputs = []
        for skipping in (True, False):
            network.set("rc.empty_space_skipping", skipping)
            outputs.append((network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)))
        assert np.ptp(outputs[1][0][..., 0]) > 0.1
        np.testing.assert_array_equal(outputs[0][0], outputs[1][0])
        np.testing.assert_array_equal(outputs[0][1], outputs[1][1])


# --- the single-pass bricked ray caster's MIP (PAGED_MIP_WALK: vgraph.bricks.walk_grids) -----------
@pytest.mark.parametrize("brick", [8, 16])
@pytest.mark.parametrize("volume_name", list(VOLUMES))
def test_single_pass_walk_changes_neither_image_nor_depth(volume_name, brick):
    """The single pass walks a grid of its bricks' block maxima in the RayCaster's order (largest
    first): image and depth sample as its plain march (no skipping), where ties and margins decide
    the depth sample; the image within an 8-bit step of the in-core RayCaster's (its depth sample
    may differ on plateaus: the two textures round a tie differently, far_from_zero)."""
    from vgraph.testing import ray_caster_network
    volume = VOLUMES[volume_name]()
    for camera_name in ("perspective", "inside"):
        camera = cameras(volume)[camera_name]
        network = ray_caster_network(volume, camera, "BrickedRayCaster", compositing="mip", transfer_function=RAMP,
                                     brick_size=brick, lod_bias=-16.0, method="single_pass")
        outputs = []
        for skipping in (True, False):
            network.set("rc.empty_space_skipping", skipping)
            outputs.append((network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)))
            assert network["rc"].passes[-1].defines.get("PAGED_MIP_WALK", False) is skipping
        assert np.ptp(outputs[1][0][..., 0]) > 0.1
        assert_same_picture(*outputs)
        assert outputs[0][1][..., 2].sum() <= outputs[1][1][..., 2].sum()  # no more samples (noise: as many)
        image, depth = with_and_without_skipping(volume, camera)[1]  # the RayCaster's plain march
        assert np.abs(np.asarray(outputs[0][0]) - np.asarray(image)).max() <= 1 / 255
        np.testing.assert_array_equal(outputs[0][1][..., 3] > 0, depth[..., 3] > 0)


@pytest.mark.parametrize("brick", [16, 12])
def test_the_walk_grid_bounds_every_sample_and_equals_the_bricks_blocks_at_level_0(brick):
    """Each block of the grid bounds every sample in it, trilinear from the level drawn (random
    positions; level 0, and level 1 whose bricks cover 2^3 level-0 cells); at level 0 in bricks
    of a multiple of 8 it is exactly its brick's block: the maximum over the voxels its samples
    filter. Bricks of 12 (another tool's chunks): the grid's blocks straddle cells."""
    from scipy.ndimage import map_coordinates
    from vgraph.bricks.cache import texture_format
    from vgraph.bricks.pyramid import ArrayPyramid
    from vgraph.bricks.brick_geometry import BrickGeometry
    from vgraph.bricks.walk_grids import walk_grid
    data = noise((40, 27, 35)).data
    source = ArrayPyramid(data, brick=(brick,) * 3)
    geometry = BrickGeometry(source)
    fmt = texture_format(source.dtype, source.value_range)
    lo, hi = source.value_range
    points = np.random.default_rng(3).random((20000, 3)) * np.asarray(data.shape)  # t * dims0, [z, y, x]
    for level in (0, 1):
        keys = [(level, z, y, x) for z in range(geometry.grids[level][2]) for y in range(geometry.grids[level][1])
                for x in range(geometry.grids[level][0])]
        ranges = np.stack([block_ranges(source, key, fmt) for key in keys])
        grid, block = walk_grid(source, geometry, keys, {key: i for i, key in enumerate(keys)}.__getitem__, ranges)
        assert block == 8 and grid.shape == (5, 4, 5)
        voxels = (source.read(level, (0, 0, 0), source.levels[level].shape).astype(np.float64) - lo) / (hi - lo)
        values = map_coordinates(voxels, (points.T - 0.5) / 2 ** level - (0.5 - 0.5 / 2 ** level), order=1, mode="nearest")
        blocks = tuple((points // 8).astype(int).T)
        assert np.all(values <= grid[blocks] + 1e-6)
        if level == 0 and brick % 8 == 0:
            padded = np.pad(voxels, 1, mode="edge")
            truth = [padded[8 * z:8 * z + 10, 8 * y:8 * y + 10, 8 * x:8 * x + 10].max() for z, y, x in np.ndindex(grid.shape)]
            np.testing.assert_allclose(grid.ravel(), truth, atol=1e-6)
