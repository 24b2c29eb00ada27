"""Rendering on a Dask cluster (issue #15, docs/guide/distributed.md): the camera's tile sub-frustum, the
tiles split on two local worker processes, ``vgraph run --cluster`` and its bad input."""

import json
import time

import numpy as np
import PIL.Image
import pytest

import vgraph
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.distributed import ClusterError, TileError, connect, cut, parse_grid, render
from vgraph.distributed.render import prepare
from vgraph.gl.raycasting.geometry import ray_uniforms

from helpers.paths import REPO

SPHERE = REPO / "networks" / "raycast_sphere.json"
TORUS = REPO / "networks" / "curvature_torus.json"
# The ray casters' tiles are the whole picture's pixels bit for bit: a tile's pixels take the
# whole picture's rays (geometry.pixel_rays). ProjectedTetrahedra draws a tile through the whole
# picture's projection and viewport, so it rasterises the same pixels; its tetrahedra's
# interpolated values still differ by float32 rounding (the grid cells' path, whose fragments
# take the whole picture's rays, is bit for bit). Measured on llvmpipe with
# `bench/distributed_tolerances.py --size 64`: 2.2e-6 (tets_lox_post) to 1.1e-5 (tets_disk_out_ref),
# in every integration and order (docs/guide/distributed.md, "Accuracy").
TETRA_TOLERANCE = 2e-5
# GeometryRenderer draws a tile the same way; its surfaces' interpolated normals and positions
# differ by float32 rounding, which shading multiplies: measured 9.6e-6 at 64 x 64, 1.7e-5 at
# 128 x 128 (head_skin_mesh_bone_volume.json in 2 x 2 tiles; before issue 30: 1.3e-5, 2.5e-5).
GEOMETRY_TOLERANCE = 2e-5


# --- the camera's sub-frustum (no cluster) --------------------------------------------------------
def test_tile_camera_has_the_full_image_pixel_centres():
    camera = vgraph.load(SPHERE).get("eep.camera")
    full, (x, y, w, h) = (96, 64), (20, 10, 40, 30)
    tiled = camera.tile(x, y, w, h, *full)
    origins, directions = camera.rays(*full)
    tile_origins, tile_directions = tiled.rays(w, h)
    assert np.abs(tile_origins - origins[y:y + h, x:x + w]).max() < 1e-12
    assert np.abs(tile_directions - directions[y:y + h, x:x + w]).max() < 1e-12
    point = np.array([0.3, 0.2, 0.1, 1.0])  # projects to the same pixel of the full image
    a, b = camera.view_projection(full[0] / full[1]) @ point, tiled.view_projection(w / h) @ point
    full_pixel = ((a[0] / a[3] + 1) / 2 * full[0], (1 - a[1] / a[3]) / 2 * full[1])
    tile_pixel = ((b[0] / b[3] + 1) / 2 * w + x, (1 - b[1] / b[3]) / 2 * h + y)
    assert np.allclose(full_pixel, tile_pixel, atol=1e-9)
    # The ray uniforms (what the shaders use) give the same rays too, centre ray included.
    rays = ray_uniforms(tiled, (w, h))
    u, v = 0.3, -0.2  # a tile NDC, and the full view's NDC of the same point
    full_u = ((u + 1) / 2 * w + x) / full[0] * 2 - 1
    full_v = 1 - ((1 - v) / 2 * h + y) / full[1] * 2
    whole = ray_uniforms(camera, full)
    for name in ("near", "direction"):
        here = np.add(rays[f"{name}_centre"], np.multiply(u, rays[f"{name}_right"])) + np.multiply(v, rays[f"{name}_up"])
        there = np.add(whole[f"{name}_centre"], np.multiply(full_u, whole[f"{name}_right"])) + \
            np.multiply(full_v, whole[f"{name}_up"])
        assert np.allclose(here, there, atol=1e-12), name


def test_window_is_saved_only_when_set_and_a_tile_of_a_tile_is_a_tile():
    camera = Camera()
    assert "window" not in camera.model_dump() and "window" not in json.loads(camera.model_dump_json())
    tiled = camera.tile(0, 0, 50, 25, 100, 100)
    assert tiled.window == (-1.0, 0.0, 0.5, 1.0)
    assert Camera(**json.loads(tiled.model_dump_json())) == tiled
    assert tiled.tile(25, 0, 25, 25, 50, 25).window == camera.tile(25, 0, 25, 25, 100, 100).window
    with pytest.raises(ValueError, match="not inside"):
        camera.tile(90, 0, 20, 10, 100, 100)
    with pytest.raises(ValueError, match="window"):
        Camera(window=(0.5, 0.0, -1.0, 1.0))


def tile_and_crop(network, camera_address, full, rect, halo_rect=None):
    """(the tile rendered through the tiled camera, the same rectangle of the full image)."""
    whole = network.evaluate(size=full)
    camera = network.get(camera_address)
    x, y, w, h = halo_rect or rect
    network.set(camera_address, camera.tile(x, y, w, h, *full))
    tile = network.evaluate(size=(w, h))
    network.set(camera_address, camera)
    rx, ry, rw, rh = rect
    return tile[ry - y:ry - y + rh, rx - x:rx - x + rw], whole[ry:ry + rh, rx:rx + rw]


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_raycaster_tile_equals_the_rectangle_of_the_full_image(projection):
    network = vgraph.load(SPHERE)  # the camera is set on EntryExitPoints; the link carries it on
    network.set("eep.camera", network.get("eep.camera").model_copy(update={"projection": projection}))
    tile, crop = tile_and_crop(network, "eep.camera", (96, 64), (20, 10, 40, 30))
    assert crop[..., 3].min() == 1.0 and np.ptp(crop[..., :3]) > 0.1  # the sphere's edge is in it
    assert np.array_equal(tile, crop)


def test_bricked_raycaster_tile_equals_the_rectangle_of_the_full_image():
    from vgraph.testing import ray_caster_network
    from vgraph.volume import Volume
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (37, 29, 41)], indexing="ij")
    data = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.15 * np.sin(9 * x)
    volume = Volume(data.astype(np.float32), spacing=(1.0, 1.1, 0.9), origin=(-3.0, 2.0, 1.0))
    camera = Camera(position=(0, 0, 1), focus=(0, 0, 0), near=None, far=None, fit_to_data=True)
    # Bricks are chosen per tile (culled and levelled by the tile's own projection).
    network = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=16, lod_bias=0.0,
                                 transfer_function="grayscale")
    whole = network.evaluate("rc.image", size=(96, 64))
    network.set("eep.camera", camera.tile(20, 10, 40, 30, 96, 64))
    tile = network.evaluate("rc.image", size=(40, 30))
    crop = whole[10:40, 20:60]
    assert np.ptp(crop[..., :3]) > 0.1, "the volume is in the rectangle"
    assert np.array_equal(tile, crop)


def test_a_tile_draws_its_bricks_at_the_levels_of_the_full_picture():
    """The level of detail follows the full picture's pixels, not the tile's (a small tile of a big
    frame must not draw coarser bricks)."""
    from vgraph.testing import ray_caster_network
    from vgraph.volume import Volume
    data = np.random.default_rng(4).random((96, 96, 96)).astype(np.float32)
    volume = Volume(data)
    camera = Camera(position=(0, 0, 1), focus=(0, 0, 0), near=None, far=None, fit_to_data=True)
    network = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=16, lod_bias=0.0,
                                 compositing="mip")
    network.evaluate("rc.image", size=(64, 64))
    whole = network["rc"].last_frame["levels"]
    network.set("eep.camera", camera.tile(16, 16, 16, 16, 64, 64))
    network.evaluate("rc.image", size=(16, 16))
    assert whole and network["rc"].last_frame["levels"] == whole


def test_projected_tetrahedra_tile_equals_the_rectangle_of_the_full_image():
    network = vgraph.Network()
    network.add("FunctionSelector", id="source", function="sphere", resolution=16)
    network.add("VolumeToTetMesh", id="tets")
    network.add("ProjectedTetrahedra", id="pt", transfer_function="grayscale")
    network.connect("source.volume", "tets.volume")
    network.add("Canvas", id="canvas")
    network.connect("tets.mesh", "pt.mesh")
    network.connect("pt.image", "canvas.image")
    # The default camera frames the data (fit_to_data) with automatic planes: a tile resolves
    # them for the full image's aspect, not its own.
    assert network.get("pt.camera").fit_to_data
    tile, crop = tile_and_crop(network, "pt.camera", (80, 48), (30, 8, 24, 32))
    assert np.ptp(crop[..., :3]) > 0.1, "the mesh is in the rectangle"
    assert np.array_equal(tile, crop)  # grid cells: the whole picture's rays
    network.set("pt.grid_cells", False)  # its tetrahedra (measured 7.1e-6)
    tile, crop = tile_and_crop(network, "pt.camera", (80, 48), (30, 8, 24, 32))
    assert np.abs(tile - crop).max() <= TETRA_TOLERANCE


@pytest.mark.parametrize("name, integration", [("tets_lox_post", "averaged"), ("tets_lox_post", "partial"),
                                               ("tets_disk_out_ref", "preintegrated"), ("tets_disk_out_ref", "partial")])
def test_projected_tetrahedra_tiles_of_the_shipped_meshes(data_dir, name, integration):
    """Issue 30: a tile was rasterised through its own sub-frustum, whose float32 rounding took or
    left a pixel at a face's edge: tets_disk_out_ref's 2x2 tiles at 128 x 128 differed by 3.7e-4,
    with the mpvonc order (gaps found from the tile's rays only) by 0.016."""
    from distributed_cases import shipped_network
    for order in ("centroid", "mpvonc"):
        network = shipped_network(name, {"pt.integration": integration, "pt.visibility_order": order})
        image, reference = shipped_tiles(network, (64, 64), (2, 2))
        assert np.ptp(reference[..., :3]) > 0.1
        assert np.abs(image - reference).max() <= TETRA_TOLERANCE, (order, np.abs(image - reference).max())


def test_grid_cells_tiles_are_the_single_process_pixels_bit_for_bit(data_dir):
    """tets_bonsai draws grid cells, whose fragments take the whole picture's rays: exact (the
    tiles' own rays differed by 2.8e-5 at 128 x 128)."""
    from distributed_cases import shipped_network
    image, reference = shipped_tiles(shipped_network("tets_bonsai"), (64, 64), (2, 2))
    assert np.ptp(reference[..., :3]) > 0.1
    assert np.array_equal(image, reference)


def test_geometry_renderer_tiles_of_a_shipped_network(data_dir):
    from distributed_cases import shipped_network
    image, reference = shipped_tiles(shipped_network("head_skin_mesh_bone_volume"), (64, 64), (2, 2))
    assert np.ptp(reference[..., :3]) > 0.1
    assert np.abs(image - reference).max() <= GEOMETRY_TOLERANCE


def test_curvature_contour_needs_the_halo():
    network = vgraph.load(TORUS)
    network.set("curvature.normalization", "exponential")  # linear needs the whole image's range
    rect = (20, 10, 40, 30)
    tile, crop = tile_and_crop(network, "eep.camera", (96, 64), rect, (19, 9, 42, 32))
    assert np.array_equal(tile, crop)


def shipped_tiles(network_or_path, size, grid):
    """(the picture assembled from tiles rendered by the workers' code, in this process; the
    single-process picture)."""
    from vgraph.distributed.worker import shipped
    from vgraph.distributed.tiles import assemble
    from vgraph.distributed.worker import render_tile
    plan = prepare(network_or_path, tiles=grid, size=size)
    document, base_dir = shipped(plan.network)
    tiles = [render_tile(document, base_dir, plan.target, plan.size, tile) for tile in plan.tiles]
    return assemble(plan.size, plan.tiles, tiles), plan.network.evaluate(plan.target, size=size)


@pytest.mark.parametrize("name", ["labels_engine", "two_channels_hydrogen_neghip", "clip_engine", "raycast_head"])
def test_ray_caster_tiles_are_the_single_process_pixels_bit_for_bit(name, request):
    """Issue 27: tiles differed from the single process by up to 4 levels in 8 bits (51 at 512 x
    512): a tile's rays were computed from its own window, a last-bit difference that a label
    boundary, a clip plane or early termination turns into a different colour."""
    from vgraph.imagefile import to_uint8
    if name in ("clip_engine", "raycast_head"):
        request.getfixturevalue("data_dir")  # these read the shared data sets
    image, reference = shipped_tiles(REPO / "networks" / f"{name}.json", (128, 128), (2, 3))
    assert np.ptp(reference[..., :3]) > 0.1
    assert np.array_equal(image, reference)
    assert np.array_equal(to_uint8(image), to_uint8(reference))  # the PNG's bytes


def test_jittered_tiles_are_the_single_process_pixels():
    """The jitter noise is a function of the whole picture's pixel, so a tile draws the same."""
    network = vgraph.load(SPHERE)
    network.set("eep.jitter", 1.0)
    image, reference = shipped_tiles(network, (96, 64), (3, 2))
    assert np.array_equal(image, reference)


def test_cut_covers_the_image_once_with_halos_inside_it():
    tiles = cut((10, 7), (3, 2))
    cover = np.zeros((7, 10), int)
    for tile in tiles:
        cover[tile.y:tile.y + tile.height, tile.x:tile.x + tile.width] += 1
        x, y, w, h = tile.rendered
        assert 0 <= x <= tile.x and 0 <= y <= tile.y and x + w <= 10 and y + h <= 7
    assert (cover == 1).all()
    assert parse_grid("4X2") == (4, 2)
    for bad in ("3", "ax2", "0x2", "2x-1"):
        with pytest.raises(TileError, match="tiles"):
            parse_grid(bad)
    with pytest.raises(TileError, match="do not fit"):
        cut((4, 4), (5, 1))


def test_bad_split_and_untileable_networks_are_refused_before_any_cluster():
    with pytest.raises(TileError, match="unknown split 'rows'"):
        prepare(SPHERE, split="rows")
    with pytest.raises(TileError, match="one BrickedRayCaster"):  # (tests/test_distributed_leaves.py)
        prepare(SPHERE, split="leaves")
    with pytest.raises(TileError, match="CurvatureRaycaster 'curvature': linear normalization"):
        prepare(TORUS)
    with pytest.raises(TileError, match="CurvatureVolumeRaycaster 'curvature': linear"):
        prepare(REPO / "networks" / "curvature_volume.json")
    with pytest.raises(TileError, match="ImageSource 'source' reads a whole image file"):
        prepare(REPO / "networks" / "grayscale.json")
    # Issue 27: each tile was the whole slice squeezed into the tile (exit 0, a wrong picture).
    with pytest.raises(TileError, match="SliceViewer 'axial' draws its whole picture into any image size"):
        prepare(REPO / "networks" / "mpr_mri_head.json")
    with pytest.raises(TileError, match="source.volume carries Volume"):
        prepare(SPHERE, target="source.volume")


def test_unreachable_scheduler_is_named_quickly():
    start = time.perf_counter()
    with pytest.raises(ClusterError, match="tcp://127.0.0.1:9: cannot reach a Dask scheduler"):
        with connect("tcp://127.0.0.1:9", timeout=1.0):
            pass
    assert time.perf_counter() - start < 10
    with pytest.raises(ClusterError, match="expected local:N"):
        with connect("udp://nowhere"):
            pass


def test_a_worker_with_several_threads_is_refused_by_name():
    """A worker's GL context is current in the thread that made it: with 2 threads a worker's
    tasks on the other thread failed ('cannot create texture'). Refused before any task."""
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        with pytest.raises(ClusterError, match=r"cluster .*: worker \S+ \(2 threads\): vgraph's tasks need one "
                                               r"thread per worker .*--nthreads 1"):
            render(SPHERE, client, split="tiles", tiles=(2, 1), size=(32, 24))


# --- on two worker processes ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        yield client


def test_tiles_on_two_workers_equal_the_single_process_image(client):
    from vgraph.distributed.worker import worker_info
    image = render(SPHERE, client, split="tiles", tiles=(3, 2), size=(96, 64))
    reference = vgraph.load(SPHERE).evaluate(size=(96, 64))
    assert image.shape == reference.shape and image.dtype == np.float32
    assert np.array_equal(image, reference)
    first = client.run(worker_info)
    # Again: each worker reuses its one GL context and the network it built.
    render(vgraph.load(SPHERE), client, tiles=(2, 2), size=(96, 64))
    second = client.run(worker_info)
    assert len({info["pid"] for info in first.values()}) == 2
    for address, info in first.items():
        if info["has_context"]:
            assert second[address]["context_id"] == info["context_id"]
            assert second[address]["networks"] == 1


def test_tiles_of_an_ome_zarr_store_drawn_brick_by_brick_on_the_workers(client, tmp_path):
    from vgraph.io.convert import convert
    from vgraph.volume_network import volume_network
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, 128)] * 3, indexing="ij")
    ball = np.clip(255 * (1.0 - np.sqrt(x * x + 1.3 * y * y + z * z)), 0, 255).astype(np.uint8)
    np.save(tmp_path / "ball.npy", ball)
    convert(tmp_path / "ball.npy", tmp_path / "ball.zarr", brick=32, progress=False)
    network = volume_network(tmp_path / "ball.zarr")  # the workers read the store themselves
    network.set("source.memory_budget", 1.0)  # 2 MiB at level 0: the ray caster draws by bricks
    image = render(network, client, tiles=(2, 1), size=(48, 40))
    reference = network.evaluate(size=(48, 40))
    assert np.ptp(reference[..., :3]) > 0.1
    assert np.array_equal(image, reference)


def test_a_worker_error_reaches_the_client_naming_processor_and_file(client, tmp_path):
    from vgraph.volume_network import volume_network
    missing = tmp_path / "gone.nrrd"  # the workers read the volume themselves, so they find it missing
    with pytest.raises(vgraph.ProcessorError, match="source.*gone.nrrd"):
        render(volume_network(missing), client, tiles=(1, 1), size=(16, 16))


def test_cli_cluster_local_writes_the_local_image(tmp_path, capsys):
    """The PNG of the cluster is the PNG of one process, byte for byte in its pixels (issue 27:
    labels_engine's differed by up to 4 levels at this size)."""
    labels = REPO / "networks" / "labels_engine.json"
    distributed, local = tmp_path / "tiles.png", tmp_path / "local.png"
    assert main(["run", str(labels), "-o", str(distributed), "--size", "128x128",
                 "--cluster", "local:2", "--split", "tiles", "--tiles", "2x3"]) == 0
    assert "as 2x3 tiles on 2 worker(s) of local:2" in capsys.readouterr().err
    assert main(["run", str(labels), "-o", str(local), "--size", "128x128"]) == 0
    a, b = (np.asarray(PIL.Image.open(p)) for p in (distributed, local))
    assert np.ptp(b[..., :3]) > 25 and np.array_equal(a, b)


@pytest.mark.parametrize("options, message", [
    (["--cluster", "local:2", "--tiles", "3"], "tiles must look like COLUMNSxROWS"),
    (["--cluster", "local:x"], "--cluster local:x: expected local:N"),
    (["--tiles", "2x2"], "need --cluster"),
    (["--cluster", "local:2", "--split", "leaves"], "needs none (use split='tiles')"),
    (["--cluster", "tcp://127.0.0.1:9"], "tcp://127.0.0.1:9: cannot reach a Dask scheduler"),
])
def test_cli_cluster_bad_input(tmp_path, capsys, options, message):
    assert main(["run", str(SPHERE), "-o", str(tmp_path / "x.png"), *options]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()
