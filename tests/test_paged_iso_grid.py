"""The single pass's iso in a complete frame of level-0 bricks (PAGED_ISO_GRID: the RayCaster's walk
over blocks of 4 voxels whose texels also name their cell's atlas slot, vgraph.bricks.walk_grids.iso_grid,
compositing_iso.glsl): image and depth sample as the plain march (no skipping), fewer samples, the
image within an 8-bit step of the in-core RayCaster's, shaded too; the grid's radii those of the
RayCaster's rule on the whole volume's blocks of 4; the frames it does not apply to (coarser bricks,
missing bricks) keep the slots' distances; and the slots' fine
maxima (vgraph.bricks.atlas_blocks.fine_maxima_of) equal block_ranges_of's at blocks of 4."""

import numpy as np
import pytest

from vgraph.bricks import walk_grids
from vgraph.bricks.atlas_blocks import fine_maxima_of
from vgraph.bricks.cache import HALO, LoadLimit, TextureFormat, block_ranges_of
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.frame_context import FrameContext
from vgraph.gl.raycasting.empty_space import skip_radii
from vgraph.implicit import sample
from vgraph.testing import ray_caster_network

from helpers.skipping import SIZE, assert_same_picture, cameras

ISO = {"compositing": "iso", "iso_level": 0.5, "shading": "none"}


def single_pass(volume, camera, brick, **properties):
    return ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=brick, lod_bias=-16.0,
                              method="single_pass", **{**ISO, **properties})


def grid_used(network) -> bool:
    return network["rc"].passes[-1].defines.get("PAGED_ISO_GRID", False)


@pytest.mark.parametrize("n, brick", [(64, 16), (45, 8), (40, 32)])
@pytest.mark.parametrize("camera_name", ["perspective", "orthographic", "inside"])
def test_the_iso_grid_changes_neither_image_nor_depth(n, brick, camera_name):
    volume = sample("torus", n, "float32")
    camera = cameras(volume)[camera_name]
    network = single_pass(volume, camera, brick)
    outputs = []
    for skipping in (True, False):
        network.set("rc.empty_space_skipping", skipping)
        outputs.append((network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)))
        assert grid_used(network) is skipping
    assert np.asarray(outputs[1][1])[..., 3].sum() > 100  # the surface is in the picture
    assert_same_picture(*outputs)
    assert outputs[0][1][..., 2].sum() < 0.8 * outputs[1][1][..., 2].sum()  # fewer samples evaluated
    reference = ray_caster_network(volume, camera, **ISO)
    assert np.abs(np.asarray(outputs[0][0]) - np.asarray(reference.evaluate("rc.image", size=SIZE))).max() <= 1 / 255


@pytest.mark.parametrize("camera_name", ["perspective", "inside"])
def test_shaded_iso_over_the_grid_is_the_ray_casters(camera_name):
    volume = sample("torus", 48, "float32")
    camera = cameras(volume)[camera_name]
    network = single_pass(volume, camera, 16, shading="blinn_phong")
    image = np.asarray(network.evaluate("rc.image", size=SIZE))
    assert grid_used(network)
    reference = ray_caster_network(volume, camera, **{**ISO, "shading": "blinn_phong"})
    want = np.asarray(reference.evaluate("rc.image", size=SIZE))
    assert np.ptp(want[..., 0]) > 0.2  # lit: the shading varies
    assert np.abs(image - want).max() <= 1 / 255


@pytest.mark.parametrize("block, most", [(4, walk_grids.MAX_TEXELS), (8, 6 ** 3), (16, 3 ** 3)])
def test_the_grid_holds_the_ray_casters_radii_and_each_cells_slot(block, most, monkeypatch):
    """Blocks of 4 voxels, or (fewer texels allowed, as past 512^3 voxels) of 8 and 16, whose maxima
    are those of their blocks of 4 together."""
    monkeypatch.setattr(walk_grids, "MAX_TEXELS", most)
    volume = sample("torus", 45, "float32")
    network = single_pass(volume, cameras(volume)["perspective"], 16)
    image = np.asarray(network.evaluate("rc.image", size=SIZE))
    assert grid_used(network)
    paged = network["rc"].parts[PagedSampling]
    n = -(-45 // block)
    grid = np.frombuffer(paged.kept.walk.value.textures["blocks"].read(), dtype=np.float32).reshape(n, n, n, 4)
    # block k holds the samples at t * dims in [b k, b k + b), which filter voxels b k - 1 .. b k + b
    data = volume.normalized(volume.data)
    high = np.zeros((n, n, n))
    for k in np.ndindex(high.shape):
        high[k] = data[tuple(slice(max(block * i - 1, 0), block * i + block + 1) for i in k)].max()
    np.testing.assert_array_equal(grid[..., 0], skip_radii(high >= 0.5))
    atlas, table = paged.atlas, paged.resolved.table
    for key, slot in atlas.slots.items():  # a drawn block's slot: its cell's leaf entry
        cell = table[key[1], key[2], key[3]]
        first = grid[16 // block * key[1], 16 // block * key[2], 16 // block * key[3], 1:]
        np.testing.assert_allclose(first * np.asarray(atlas.size), cell[:3] - 0.5, atol=1e-3)
    reference = ray_caster_network(volume, cameras(volume)["perspective"], **ISO)
    assert np.abs(image - np.asarray(reference.evaluate("rc.image", size=SIZE))).max() <= 1 / 255


def test_frames_with_coarser_or_missing_bricks_keep_the_slots_distances():
    volume = sample("torus", 40, "float32")
    camera = cameras(volume)["perspective"]
    network = single_pass(volume, camera, 8)
    network.set("rc.finest_level", 1)  # level-1 bricks
    network.evaluate("rc.image", size=SIZE)
    assert not grid_used(network) and network["rc"].passes[-1].defines.get("PAGED_BLOCKS")
    assert network["rc"].last_frame["levels"] == [1]
    network.set("rc.finest_level", 0)  # level 0 missing, drawn from level 1 (no loads)
    network.evaluate("rc.image", size=SIZE, context=FrameContext(load_limit=LoadLimit(bricks=0)))
    assert not grid_used(network) and not network["rc"].last_frame["complete"]
    image = np.asarray(network.evaluate("rc.image", size=SIZE))  # loaded: complete, the grid
    assert grid_used(network) and network["rc"].last_frame["complete"]
    reference = np.asarray(ray_caster_network(volume, camera, **ISO).evaluate("rc.image", size=SIZE))
    assert np.abs(image - reference).max() <= 1 / 255


@pytest.mark.parametrize("dtype, fmt", [(np.uint8, TextureFormat("f1", 1, 1 / 255, 0.0, True)),
                                        (np.uint16, TextureFormat("nu2", 2, 2.0, -0.5, True)),
                                        (np.float32, TextureFormat("f4", 4, 0.5, 0.25, False))])
@pytest.mark.parametrize("core", [(64, 64, 64), (13, 4, 9), (1, 7, 3)])
def test_fine_maxima_are_block_ranges_of_at_blocks_of_4(dtype, fmt, core):
    shape = tuple(n + 2 * HALO for n in core)
    data = np.random.default_rng(sum(core)).integers(0, 60000, shape).astype(dtype)
    want = block_ranges_of(data, fmt, 4)[..., 1]
    full = 65535.0 if fmt.gl_dtype == "nu2" else 1.0
    got = fine_maxima_of(data).astype(np.float64) / full * fmt.scale + fmt.offset
    np.testing.assert_allclose(got, want, rtol=1e-6)
