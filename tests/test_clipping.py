"""Clip planes and the crop box of EntryExitPoints (vgraph.clipping): the GL images against the CPU
reference ray caster with the same planes (dvr, mip, shaded; oblique planes, several planes, a crop
box, perspective and orthographic); a clipped render equals the render of the volume with the
removed part set to its lowest value (exactly where samples lie on voxel centres, within a
one-voxel band elsewhere); rays with nothing left are misses; ray bounds, the BrickedRayCaster and
the curvature ray casters respect the planes; bad values are refused naming processor and field;
planes and crop box survive a .json round trip; no planes compiles no clipping code."""

import numpy as np
import pytest

from vgraph import PropertyError
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.clipping import MAX_CLIP_PLANES, ClipPlane, clip_intervals, cropped_box, kept_voxels
from vgraph.fileformat import load_network
from vgraph.implicit import sample
from vgraph.numerics.reference_raycast import Shading, render, volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import rendering_network
from helpers.paths import DATA, REPO

REFERENCE_TOLERANCE = 2e-5  # as tests/test_raycaster.py: float32 against float64 (measured ~1.3e-6)
# sparse_volume()'s blobs have sharp walls (0.05 -> 1 within a voxel), which turn float32 rounding
# of the cut's position into larger colour differences than on the smooth torus (measured <= 5e-5).
SHARP_TOLERANCE = 1e-4
COLOURED = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.45, 0.2, 0.4, 0.9, 0.0),
                                    (0.55, 1.0, 0.7, 0.2, 0.5), (1.0, 1, 1, 1, 0.8)])
SIZE = (56, 44)
BACKGROUND = (0.1, 0.2, 0.3, 1.0)


@pytest.fixture(scope="module")
def torus():
    return sample("torus", 32, "float32")


def centre_of(volume):
    lo, hi = volume_box(volume)
    return tuple(float(v) for v in (lo + hi) / 2)


def oblique_camera(volume, **changes):
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    return camera.model_copy(update=changes) if changes else camera


def render_gl(volume, camera, size=SIZE, output="image", clip_planes=(), crop_box=None, **properties):
    network = rendering_network(volume, camera, **properties)
    network.set("eep.clip_planes", clip_planes)
    network.set("eep.crop_box", crop_box)
    return network.evaluate(f"rc.{output}", size=size)


def zeroed(volume, planes=(), crop_box=None):
    """The volume with what the planes and crop box remove set to its lowest value (normalised 0)."""
    low = volume.value_range[0]
    data = np.where(kept_voxels(volume, planes, crop_box), volume.data, low).astype(volume.data.dtype)
    return volume.with_data(data, declared_range=volume.value_range)


# --- GL against the CPU reference with the same planes ----------------------------------------------
CASES = {
    "one oblique plane": dict(clip_planes=(ClipPlane(normal=(1.0, 0.3, -0.2), point=(0.0, 0.0, 0.0)),)),
    "two planes, a wedge": dict(clip_planes=(ClipPlane(normal=(0.0, 1.0, 0.0), point=(0.0, -0.2, 0.0)),
                                             ClipPlane(normal=(-1.0, 0.0, 0.5), point=(0.3, 0.0, 0.0)))),
    "crop box": dict(crop_box=(-0.6, -0.9, -0.1, 0.5, 0.4, 0.3)),
    "plane and crop box": dict(clip_planes=(ClipPlane(normal=(0.0, 0.0, 1.0), point=(0.0, 0.0, 0.1)),),
                               crop_box=(-0.5, -1.0, -1.0, 1.0, 0.6, 1.0)),
}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("mode, shaded", [("dvr", False), ("mip", False), ("dvr", True)])
def test_clipped_render_matches_the_cpu_reference(torus, case, mode, shaded):
    clipping = CASES[case]
    camera = oblique_camera(torus)
    gl = render_gl(torus, camera, compositing=mode, transfer_function=COLOURED, background=BACKGROUND,
                   shading="blinn_phong" if shaded else "none", **clipping)
    shading = Shading() if shaded else None
    reference = render(torus, camera, COLOURED, SIZE, mode=mode, shading=shading, background=BACKGROUND,
                       **clipping)
    whole = render(torus, camera, COLOURED, SIZE, mode=mode, shading=shading, background=BACKGROUND)
    assert np.abs(reference - whole).max() > 0.3  # the clipping shows
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


@pytest.mark.parametrize("projection", ["orthographic", "perspective"])
def test_a_camera_inside_the_kept_part_and_orthographic_views(torus, projection):
    planes = (ClipPlane(normal=(-0.2, 1.0, 0.4), point=(0.0, 0.1, 0.0)),)
    if projection == "perspective":  # inside the volume: near-plane capping and a clip plane together
        camera = Camera(position=(0.0, 0.6, 0.1), focus=(0.4, -0.2, 0.0), near=0.01, far=10.0, fov=70)
    else:
        camera = Camera.looking_at_box(*volume_box(torus), direction=(0.3, -0.6, -1.0), projection="orthographic")
    gl = render_gl(torus, camera, transfer_function=COLOURED, clip_planes=planes)
    reference = render(torus, camera, COLOURED, SIZE, clip_planes=planes)
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


def test_a_tile_of_the_view_is_that_part_of_the_clipped_picture(torus):
    """Tiles (Camera.tile, as vgraph.distributed draws them) cut with the same world planes."""
    planes = (ClipPlane(normal=(1.0, 0.3, -0.2), point=(0.0, 0.0, 0.0)),)
    full = oblique_camera(torus)
    whole = render_gl(torus, full, (64, 48), transfer_function=COLOURED, clip_planes=planes)
    tile = render_gl(torus, full.tile(24, 8, 32, 28, 64, 48), (32, 28), transfer_function=COLOURED,
                     clip_planes=planes)
    np.testing.assert_allclose(tile, whole[8:36, 24:56], atol=REFERENCE_TOLERANCE)


# --- clipped = the volume with the clipped part zeroed ------------------------------------------------
def aligned_volume(seed=0, shape=(9, 6, 10)):
    data = np.random.default_rng(seed).random(shape).astype(np.float32)
    return Volume(data, spacing=(0.8, 0.8, 0.4), origin=(1.0, -2.0, 3.0))


def aligned_camera(volume):
    """Orthographic down -z with one pixel per voxel column: the samples are voxel centres."""
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    return Camera(projection="orthographic", position=(centre[0], centre[1], hi[2] + 5.0),
                  focus=tuple(centre), near=1.0, far=50.0, parallel_scale=volume.dims[1] * volume.spacing[1] / 2)


@pytest.mark.parametrize("mode", ["dvr", "mip"])
def test_where_samples_are_voxel_centres_clipping_equals_zeroing_exactly(mode):
    """A plane across the view through slice 4 (keeps z <= z_4: the rays start on it) and one
    along the view between columns 2 and 3 (removes columns 0-2 whole)."""
    volume = aligned_volume()
    origin, spacing = np.asarray(volume.origin), np.asarray(volume.spacing)
    planes = (ClipPlane(normal=(0.0, 0.0, -1.0), point=tuple(origin + 4 * spacing)),
              ClipPlane(normal=(1.0, 0.0, 0.0), point=tuple(origin + 2.5 * spacing)))
    camera, size = aligned_camera(volume), tuple(volume.dims[:2])
    clipped = render_gl(volume, camera, size, compositing=mode, transfer_function=COLOURED,
                        background=BACKGROUND, clip_planes=planes)
    expected = render_gl(zeroed(volume, planes), camera, size, compositing=mode, transfer_function=COLOURED,
                         background=BACKGROUND)
    np.testing.assert_allclose(clipped, expected, atol=REFERENCE_TOLERANCE)
    np.testing.assert_array_equal(clipped[:, :3], np.broadcast_to(np.float32(BACKGROUND), clipped[:, :3].shape))
    # The cut shows the inside: slice 4 is what the rays meet first.
    assert np.abs(clipped - render_gl(volume, camera, size, compositing=mode, transfer_function=COLOURED,
                                      background=BACKGROUND)).max() > 0.1


# Oblique planes cut between voxel centres: zeroing blurs the cut over one voxel by trilinear
# interpolation, clipping cuts sharp. Measured on the torus: mean |difference| 0.5e-3 - 1.0e-3,
# 1% of the pixels (the band along the cut) above 0.05.
@pytest.mark.parametrize("mode, shaded", [("dvr", False), ("mip", False), ("dvr", True)])
def test_oblique_clipping_equals_zeroing_but_for_the_band_along_the_cut(torus, mode, shaded):
    planes = (ClipPlane(normal=(1.0, 0.3, -0.2), point=centre_of(torus)),)
    camera = oblique_camera(torus)
    properties = dict(compositing=mode, transfer_function=COLOURED, shading="blinn_phong" if shaded else "none")
    clipped = render_gl(torus, camera, clip_planes=planes, **properties)
    expected = render_gl(zeroed(torus, planes), camera, **properties)
    whole = render_gl(torus, camera, **properties)
    difference = np.abs(clipped - expected).max(axis=-1)
    assert np.abs(clipped - whole).max(axis=-1).mean() > 0.01  # much of the picture changes
    assert difference.mean() < 3e-3
    assert np.mean(difference > 0.05) < 0.03


@pytest.mark.filterwarnings("ignore:rc \\(RayCaster\\) rendered an empty image")  # uniform grey counts as empty
def test_shading_at_the_cut_keeps_the_volumes_gradient():
    """The documented choice: the cut face is lit by the volume's gradient, not the plane's normal.
    A volume varying along x only, cut by a plane facing the camera (z): the plane's normal would
    light it fully (headlight), the gradient (along x, across the view) gives the ambient term."""
    x = np.linspace(0.2, 0.8, 12, dtype=np.float32)
    volume = Volume(np.broadcast_to(x, (10, 12, 12)).copy(), spacing=(1.0, 1.0, 1.0))
    opaque = TransferFunction(points=[(0.0, 1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0, 1.0)])
    camera = aligned_camera(volume)
    planes = (ClipPlane(normal=(0.0, 0.0, -1.0), point=(0.0, 0.0, 4.0)),)
    image = render_gl(volume, camera, tuple(volume.dims[:2]), transfer_function=opaque,
                      shading="blinn_phong", clip_planes=planes, ambient=0.3, diffuse=0.7, specular=0.0)
    np.testing.assert_allclose(image[2:-2, 2:-2, :3], 0.3, atol=1e-4)


# --- misses, crop boxes, interval model ---------------------------------------------------------------
@pytest.mark.parametrize("jitter", [0.0, 1.0])
def test_rays_with_nothing_left_are_misses_in_both_images(torus, jitter):
    """Jittered entry points move towards the exit point, so they stay on the kept side too."""
    planes = (ClipPlane(normal=(1.0, 0.0, 0.0), point=(0.2, 0.0, 0.0)),)
    network = rendering_network(torus, oblique_camera(torus), transfer_function=COLOURED)
    network.set("eep.clip_planes", planes)
    network.set("eep.jitter", jitter)
    entry, exit_points = network.evaluate("eep.entry", size=SIZE), network.evaluate("eep.exit", size=SIZE)
    np.testing.assert_array_equal(entry[..., 3] > 0, exit_points[..., 3] > 0)
    assert 0.1 < np.mean(entry[..., 3] > 0) < 0.6
    # Every entry and exit point left lies on the kept side (texture -> world).
    for image in (entry, exit_points):
        hit = image[..., 3] > 0
        world = np.asarray(torus.origin) + (image[..., :3][hit] * torus.dims - 0.5) * np.asarray(torus.spacing)
        assert world[:, 0].min() >= 0.2 - 1e-5


@pytest.mark.filterwarnings("ignore:rc \\(RayCaster\\) rendered an empty image")  # as it should
def test_a_crop_box_that_leaves_nothing_renders_the_background(torus):
    image = render_gl(torus, oblique_camera(torus), transfer_function=COLOURED, background=BACKGROUND,
                      crop_box=(2.0, 2.0, 2.0, 3.0, 3.0, 3.0))
    np.testing.assert_array_equal(image, np.broadcast_to(np.float32(BACKGROUND), image.shape))
    assert cropped_box(*volume_box(torus), (2.0, 2.0, 2.0, 3.0, 3.0, 3.0)) is None


def test_interval_model_on_rays_along_and_across_a_plane():
    plane = ClipPlane(normal=(0.0, 0.0, 2.0), point=(0.0, 0.0, 1.0))  # keeps z >= 1
    origins = np.array([[0.0, 0, 0], [0, 0, 0], [0, 0, 0.5], [0, 0, 1.5]])
    directions = np.array([[0.0, 0, 1], [0, 0, -1], [1, 0, 0], [1, 0, 0]])
    enter, leave = clip_intervals(origins, directions, np.zeros(4), np.full(4, 5.0), (plane,))
    np.testing.assert_allclose(enter[[0, 3]], [1.0, 0.0])
    np.testing.assert_allclose(leave[[0, 3]], [5.0, 5.0])
    assert leave[1] < enter[1] and leave[2] < enter[2]  # away from the kept side; parallel, outside


# --- the ray casters that read the entry and exit points ----------------------------------------------
def sparse_volume(shape=(48, 44, 52), seed=5):
    """Mostly air with blobs, so that ray bounds (RAY_BOUNDS) are drawn."""
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape, dtype=np.float32)
    data = rng.uniform(0.0, 0.05, shape).astype(np.float32)
    for _ in range(8):
        c, r = rng.uniform([10, 10, 10], [38, 34, 42]), rng.uniform(3.0, 7.0)
        data[(z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2 < r * r] = rng.uniform(0.5, 1.0)
    data[0, 0, 0] = 1.0
    return Volume(data, spacing=(1.0, 0.9, 1.1), origin=(-3.0, 2.0, 1.0))


@pytest.mark.parametrize("shaded", [False, True])
def test_ray_bounds_compose_with_clipping(shaded):
    volume = sparse_volume()
    camera = oblique_camera(volume)
    planes = (ClipPlane(normal=(0.4, -1.0, 0.3), point=centre_of(volume)),)
    network = rendering_network(volume, camera, transfer_function=COLOURED,
                                shading="blinn_phong" if shaded else "none")
    network.set("eep.clip_planes", planes)
    images = {}
    for bounds in (True, False):
        network.set("rc.ray_bounds", bounds)
        images[bounds] = network.evaluate("rc.image", size=SIZE)
        assert bool(network["rc"].passes[-1][1].get("RAY_BOUNDS")) is bounds
        network["rc"].invalidate()
    np.testing.assert_array_equal(images[True], images[False])
    reference = render(volume, camera, COLOURED, SIZE, shading=Shading() if shaded else None, clip_planes=planes)
    np.testing.assert_allclose(images[True], reference, atol=SHARP_TOLERANCE)
    assert np.abs(reference - render(volume, camera, COLOURED, SIZE, shading=Shading() if shaded else None)).max() > 0.2


@pytest.mark.parametrize("mode", ["dvr", "mip"])
def test_the_bricked_raycaster_respects_the_planes(mode):
    volume = sparse_volume((37, 29, 41))
    camera = oblique_camera(volume)
    planes = (ClipPlane(normal=(1.0, 0.2, 0.1), point=centre_of(volume)),)
    images = {}
    for processor, extra in (("RayCaster", {"early_termination": 1.0}),
                             ("BrickedRayCaster", {"brick_size": 16, "lod_bias": -16.0})):
        network = ray_caster_network(volume, camera, processor, compositing=mode, transfer_function=COLOURED,
                                     shading="none",
                                     **(extra if mode == "dvr" or processor == "BrickedRayCaster" else {}))
        network.set("eep.clip_planes", planes)
        images[processor] = np.asarray(network.evaluate("rc.image", size=SIZE), dtype=np.float64)
    np.testing.assert_allclose(images["BrickedRayCaster"], images["RayCaster"], atol=1e-4)
    reference = render(volume, camera, COLOURED, SIZE, mode=mode, early_termination=1.0, clip_planes=planes)
    np.testing.assert_allclose(images["RayCaster"], reference, atol=SHARP_TOLERANCE)


def test_the_curvature_raycaster_finds_surfaces_only_on_the_kept_side(torus):
    plane = ClipPlane(normal=(0.3, 1.0, 0.0), point=(0.0, 0.1, 0.0))
    network = ray_caster_network(torus, oblique_camera(torus), "CurvatureRaycaster", id="cr",
                                 derivatives="central")
    positions = {}
    for planes in ((), (plane,)):
        network.set("eep.clip_planes", planes)
        position = network.evaluate("cr.position", size=SIZE)
        positions[len(planes)] = position[..., :3][position[..., 3] > 0]
    heights = {n: (points - plane.point) @ plane.unit_normal() for n, points in positions.items()}
    assert heights[0].min() < -0.3  # unclipped, the surface reaches far into the removed part
    assert heights[1].min() >= -1e-4 and len(heights[1]) > 0.2 * len(heights[0])


def test_the_curvature_volume_raycaster_shows_nothing_where_all_is_removed(torus):
    plane = ClipPlane(normal=(1.0, 0.0, 0.0), point=(0.0, 0.0, 0.0))
    network = ray_caster_network(torus, oblique_camera(torus), "CurvatureVolumeRaycaster", id="cr",
                                 transfer_function=COLOURED, derivatives="central")
    whole = network.evaluate("cr.image", size=SIZE)
    network.set("eep.clip_planes", (plane,))
    clipped = network.evaluate("cr.image", size=SIZE)
    entry = network.evaluate("eep.entry", size=SIZE)
    removed = entry[..., 3] == 0
    assert np.abs(whole[removed] - whole[0, 0]).max() > 0.2  # the torus was there
    np.testing.assert_array_equal(clipped[removed], np.broadcast_to(clipped[0, 0], clipped[removed].shape))
    np.testing.assert_array_equal(clipped[~removed & (whole[..., 3] == whole[0, 0, 3])][..., 3],
                                  whole[0, 0, 3])  # nothing new appears where there was nothing


# --- properties, files, shaders ---------------------------------------------------------------------
@pytest.mark.parametrize("name, value, words", [
    ("clip_planes", [{"normal": [0, 0, 0], "point": [1, 2, 3]}], "normal must not be zero"),
    ("clip_planes", [{"normal": [1, 0, 0]}] * (MAX_CLIP_PLANES + 1), "at most 8"),
    ("clip_planes", [{"normal": [1, 0]}], "normal"),
    ("clip_planes", [{"normal": [1, 0, 0], "offset": 2}], "offset"),
    ("crop_box", [0, 0, 0, 1, -1, 1], "each min <= its max"),
    ("crop_box", [0, 0, 0, 1, 1], "Field required"),
])
def test_bad_values_are_refused_naming_processor_and_field(torus, name, value, words):
    network = rendering_network(torus, oblique_camera(torus))
    with pytest.raises(PropertyError, match=rf"eep\.{name}") as error:
        network.set(f"eep.{name}", value)
    assert words in str(error.value)


def test_planes_and_crop_box_survive_a_json_round_trip(tmp_path):
    from vgraph.network import Network
    network = Network()
    network.add("FunctionSelector", id="source", function="torus", resolution=16)
    network.add("EntryExitPoints", id="eep", clip_planes=[{"normal": [1, 0, 0], "point": [0.1, 0, 0]},
                                                         {"normal": [0, -2, 1]}],
                crop_box=[-1, -1, -0.5, 1, 1, 0.5])
    network.connect("source.volume", "eep.volume")
    network.save(tmp_path / "clip.json")
    loaded = load_network(tmp_path / "clip.json")
    assert loaded["eep"].clip_planes == network["eep"].clip_planes
    assert loaded["eep"].clip_planes[1].point == (0.0, 0.0, 0.0)
    assert loaded["eep"].crop_box == (-1.0, -1.0, -0.5, 1.0, 1.0, 0.5)


def test_the_example_network_cuts_the_engine(tmp_path):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    path = REPO / "networks" / "clip_engine.json"
    assert main(["run", str(path), "--size", "96x72", "--npy", str(tmp_path / "clipped.npy"),
                 "-o", str(tmp_path / "clipped.png")]) == 0
    network = load_network(path)
    assert len(network["eep"].clip_planes) == 1
    network.set("eep.clip_planes", [])
    whole = np.asarray(network.evaluate("rc.image", size=(96, 72)))
    clipped = np.load(tmp_path / "clipped.npy")
    assert np.ptp(clipped[..., :3]) > 0.2
    assert np.abs(clipped - whole).max(axis=-1).mean() > 0.05  # the cut changes much of the picture


def test_no_planes_compiles_no_clipping_code(torus):
    network = rendering_network(torus, oblique_camera(torus))
    network.evaluate("rc.image", size=SIZE)
    # One pass writes both images (no cap: the far plane does not cut the box).
    assert [defines.get("CLIP_PLANES") for _, defines in network["eep"].passes] == [None]
    network.set("eep.clip_planes", [{"normal": [1, 0, 0]}, {"normal": [0, 1, 0]}])
    network.evaluate("rc.image", size=SIZE)
    assert [defines.get("CLIP_PLANES") for _, defines in network["eep"].passes] == [2]
