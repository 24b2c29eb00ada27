"""EntryExitPoints: the stored points against an independent ray-box intersection (slab test in
float64 on Camera.rays), near- and far-plane capping, anisotropic boxes, jitter, output reuse."""

import numpy as np
import pytest

from vgraph import Network, VGraphError
from vgraph.camera import Camera
from vgraph.testing import GivenVolume
from vgraph.volume import Volume

from helpers.networks import rendering_network

SPACING = (0.5, 0.4, 1.0)
ORIGIN = (-3.0, -2.0, -4.0)


def random_volume(shape=(10, 12, 16), spacing=SPACING, origin=ORIGIN, seed=0):
    data = np.random.default_rng(seed).random(shape).astype(np.float32)
    return Volume(data, spacing=spacing, origin=origin)


def expected_points(volume, camera, size):
    """Texture coordinates of the entry and exit points and the hit mask, (H, W), float64: the
    slab test on Camera.rays against the box of the voxel centres, clipped to [near, far]."""
    width, height = size
    origins, directions = camera.rays(width, height)
    spacing, origin = np.array(volume.spacing), np.array(volume.origin)
    lo, hi = origin, origin + (np.array(volume.dims) - 1) * spacing
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - origins) / directions, (hi - origins) / directions
    t_in = np.maximum(np.nanmax(np.minimum(t0, t1), axis=-1), 0.0)
    t_far = (camera.far - camera.near) / (directions @ camera.basis()[2])
    t_out = np.minimum(np.nanmin(np.maximum(t0, t1), axis=-1), t_far)

    def to_texture(t):
        world = origins + t[..., None] * directions
        return ((world - origin) / spacing + 0.5) / np.array(volume.dims)

    return to_texture(t_in), to_texture(t_out), t_out >= t_in


def evaluate_points(volume, camera, size, **properties):
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("EntryExitPoints", id="eep", camera=camera, **properties)
    network.connect("src.volume", "eep.volume")
    return network, network.evaluate("eep.entry", size=size), network.evaluate("eep.exit", size=size)


OUTSIDE = Camera.looking_at_box((-3, -2, -4), (4.5, 2.4, 5), direction=(-0.5, -0.3, -1.0))
CAMERAS = {
    "perspective outside": OUTSIDE,
    "orthographic": Camera(projection="orthographic", position=(0, 0, 10), focus=(0.3, 0.2, 0),
                           parallel_scale=5.0, near=0.5, far=30.0),
    "inside (near capping)": Camera(position=(0.0, 0.0, 0.0), focus=(1.0, 0.5, 0.3), near=0.05,
                                    far=30.0, fov=60.0),
    "near plane cuts the box": OUTSIDE.zoom(4.0),
    "far plane cuts the box": Camera(position=(0.0, 0.0, 20.0), focus=(0, 0, 0), near=1.0,
                                     far=21.0, fov=20.0),
}


@pytest.mark.parametrize("name", CAMERAS)
def test_points_match_an_independent_slab_test(name):
    camera, size = CAMERAS[name], (48, 40)
    volume = random_volume()
    _, entry, exit_points = evaluate_points(volume, camera, size)
    expected_entry, expected_exit, hit = expected_points(volume, camera, size)
    assert hit.sum() > 200  # the set-up really shows the box
    np.testing.assert_array_equal(entry[..., 3], hit.astype(np.float32))
    np.testing.assert_array_equal(exit_points[..., 3], hit.astype(np.float32))
    # float32 slab test: typically 1e-7 to 3e-7 texture units; up to ~2e-6 for rays nearly
    # parallel to the face they cross (1 / d amplifies the rounding of the ray origin).
    np.testing.assert_allclose(entry[..., :3][hit], expected_entry[hit], atol=1e-5)
    np.testing.assert_allclose(exit_points[..., :3][hit], expected_exit[hit], atol=1e-5)
    assert np.all(entry[~hit] == 0.0) and np.all(exit_points[~hit] == 0.0)


COVERED_CAMERAS = {**CAMERAS, "a tile of the view": OUTSIDE.tile(10, 4, 30, 24, 48, 40),
                   "far away": Camera(position=(10.0, 8.0, 60.0), focus=(0.75, 0.2, 0.5), near=1.0, far=200.0)}


@pytest.mark.parametrize("name", COVERED_CAMERAS)
def test_covered_rectangle_holds_every_pixel_whose_ray_meets_the_box(name):
    """Ray casters draw only inside Image.covered (the rest is their miss value), so a hit outside
    it would be a pixel lost."""
    size = (30, 24) if name == "a tile of the view" else (48, 40)
    network, _, _ = evaluate_points(random_volume(), COVERED_CAMERAS[name], size)
    for image in (network.output("eep.entry"), network.output("eep.exit")):
        if image.covered is None:  # a corner of the box at or behind the eye: no bound, all drawn
            assert name in ("inside (near capping)", "near plane cuts the box")
            continue
        x, y, width, height = image.covered  # GL window coordinates: y counts up from the bottom row
        inside = np.zeros(size[::-1], dtype=bool)
        inside[size[1] - (y + height):size[1] - y, x:x + width] = True
        assert image.to_numpy()[..., 3][~inside].max(initial=0.0) == 0.0
    if name == "far away":  # a box far off covers a small part of the view, and so does the rectangle
        assert width * height < 0.25 * size[0] * size[1]


def test_covered_rectangle_is_empty_when_the_crop_box_leaves_nothing():
    network, _, _ = evaluate_points(random_volume(), OUTSIDE, (48, 40), crop_box=(9, 9, 9, 10, 10, 10))
    assert network.output("eep.entry").covered[2:] == (0, 0)


def test_camera_inside_starts_every_ray_on_the_near_plane():
    camera = CAMERAS["inside (near capping)"]
    volume = random_volume()
    _, entry, _ = evaluate_points(volume, camera, (32, 32))
    origins, _ = camera.rays(32, 32)
    near_points = ((origins - ORIGIN) / SPACING + 0.5) / np.array(volume.dims)
    assert np.all(entry[..., 3] == 1.0)
    np.testing.assert_allclose(entry[..., :3], near_points, atol=1e-5)


def test_aligned_orthographic_view_stores_voxel_centres():
    """Pixel centres on voxel centres: the entry of pixel (row, col) is voxel (col, ny-1-row, nz-1)
    at (i + 0.5) / dims, the exit the same column at z = 0."""
    volume = random_volume(shape=(5, 6, 7), spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0))
    nx, ny, nz = volume.dims
    camera = Camera(projection="orthographic", position=(3.0, 2.5, 10.0), focus=(3.0, 2.5, 0.0),
                    parallel_scale=ny / 2, near=1.0, far=20.0)
    _, entry, exit_points = evaluate_points(volume, camera, (nx, ny))
    col, row = np.meshgrid(np.arange(nx), np.arange(ny))
    np.testing.assert_allclose(entry[..., 0], (col + 0.5) / nx, atol=1e-6)
    np.testing.assert_allclose(entry[..., 1], (ny - 1 - row + 0.5) / ny, atol=1e-6)
    np.testing.assert_allclose(entry[..., 2], 1.0 - 0.5 / nz, atol=1e-6)
    np.testing.assert_allclose(exit_points[..., 2], 0.5 / nz, atol=1e-6)
    assert np.all(entry[..., 3] == 1.0)


def test_anisotropic_box_has_its_world_shape():
    """8 x 8 x 8 voxels with spacing (1, 1, 3): seen from the side (along -x) the box is three
    times as tall (z, the image's vertical axis) as wide (y)."""
    volume = random_volume(shape=(9, 9, 9), spacing=(1.0, 1.0, 3.0), origin=(0.0, 0.0, 0.0))
    camera = Camera(projection="orthographic", position=(30.0, 4.0, 12.0), focus=(0.0, 4.0, 12.0),
                    up=(0.0, 0.0, 1.0), parallel_scale=16.0, near=1.0, far=60.0)
    _, entry, _ = evaluate_points(volume, camera, (64, 64))
    rows, cols = np.nonzero(entry[..., 3])
    pixel = 32.0 / 64  # world units per pixel
    assert (rows.max() - rows.min() + 1) * pixel == pytest.approx(24.0, abs=1.0)
    assert (cols.max() - cols.min() + 1) * pixel == pytest.approx(8.0, abs=1.0)


def test_jitter_moves_entries_towards_the_exit_by_at_most_the_jitter():
    volume = random_volume()
    camera, size = CAMERAS["perspective outside"], (48, 40)
    _, entry, exit_points = evaluate_points(volume, camera, size)
    network, jittered, _ = evaluate_points(volume, camera, size, jitter=1.5)
    again = network.evaluate("eep.entry", size=size)
    np.testing.assert_array_equal(again, jittered)  # a fixed pattern: reproducible images
    hit = entry[..., 3] > 0
    world = np.array(volume.dims) * np.array(volume.spacing)  # texture -> world vectors
    moved = (jittered[..., :3] - entry[..., :3])[hit] * world
    along = (exit_points[..., :3] - entry[..., :3])[hit] * world
    length, shift = np.linalg.norm(along, axis=1), np.linalg.norm(moved, axis=1)
    limit = 1.5 * min(volume.spacing)
    assert np.all(shift <= np.minimum(limit, length) + 1e-4)
    assert shift.max() > 0.8 * limit and np.mean(shift) > 0.2 * limit  # a spread of offsets
    forward = np.einsum("ij,ij->i", moved, along) >= -1e-9
    assert np.all(forward)  # along the ray, towards the exit


def test_outputs_are_reused_while_the_size_stays():
    network, entry, _ = evaluate_points(random_volume(), OUTSIDE, (16, 16))
    eep = network["eep"]
    first = eep.outputs["entry"]
    network.set("eep.camera", OUTSIDE.rotate(0.2, 0.1))
    network.evaluate("eep.entry", size=(16, 16))
    assert eep.outputs["entry"] is first and first.texture is not None
    network.evaluate("eep.entry", size=(20, 12))
    assert eep.outputs["entry"].size == (20, 12) and first.texture is None  # the old one freed


def test_canvas_size_drives_the_render_size():
    network = Network()
    network.add(GivenVolume(id="src", volume=random_volume()))
    network.add("EntryExitPoints", id="eep", camera=OUTSIDE)
    network.add("Canvas", id="canvas", size=(30, 20))
    network.connect("src.volume", "eep.volume")
    network.connect("eep.entry", "canvas.image")
    assert network.evaluate("canvas").shape == (20, 30, 4)


def test_frame_volume_fits_the_box_into_the_view():
    volume = random_volume()
    network, _, _ = evaluate_points(volume, Camera(position=(50, 0, 0), focus=(49, 0, 0)), (40, 40))
    eep = network["eep"]
    eep.frame_volume()
    entry = network.evaluate("eep.entry", size=(40, 40))
    hit = entry[..., 3] > 0
    assert hit.sum() > 300
    assert not (hit[0].any() or hit[-1].any() or hit[:, 0].any() or hit[:, -1].any())
    with pytest.raises(VGraphError, match="frame_volume"):
        Network().add("EntryExitPoints", id="lonely").frame_volume()


def test_the_default_camera_frames_each_volume_it_receives():
    from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
    network = rendering_network(random_volume(), DEFAULT_CAMERA)  # a box far from [-1, 1]^3
    network.evaluate("rc.image", size=(32, 32))
    assert network["eep"].camera == DEFAULT_CAMERA  # the property stays "fit to data"
    framed = network["eep"].view_camera
    assert not framed.fit_to_data and network["rc"].view_camera == framed
    hit = network.evaluate("eep.entry", size=(32, 32))[..., 3] > 0
    assert hit.sum() > 200 and not (hit[0].any() or hit[-1].any())
    network["src"].volume = random_volume(spacing=(10.0, 10.0, 10.0))
    network.invalidate_downstream("src")
    hit = network.evaluate("eep.entry", size=(32, 32))[..., 3] > 0  # a 10x larger volume: framed again
    assert hit.sum() > 200 and not (hit[0].any() or hit[-1].any())
    network.set("eep.camera", OUTSIDE)  # a camera the user chose stays
    network.evaluate("rc.image", size=(32, 32))
    assert network["eep"].camera == OUTSIDE == network["rc"].camera == network["rc"].view_camera
