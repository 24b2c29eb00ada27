"""Rays over the union of several volumes' boxes: EntryExitPoints with its optional inports
volume2..volume4 connected, feeding the MultiVolumeRayCaster. Two channels whose boxes only partly
overlap (B = A moved half its width): the entry and exit points are the union box's, in A's
texture space (numbers against numpy, leaving [0, 1]); each channel shows its whole extent (a MIP
per channel in closed form, and every blend against the CPU reference); a clip plane and a crop box
still cut both channels; the camera both processors resolve is the union's; frame_volume frames
the union; without extra volumes nothing changes (tests/test_entry_exit_points.py and the ray
caster tests check that bit for bit)."""

import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.implicit import sample
from vgraph.numerics.multivolume_reference import render_channels
from vgraph.network import Network
from vgraph.numerics.reference_raycast import Shading, volume_box
from vgraph.processors.entry_exit_points import rays_box
from vgraph.testing import GivenVolume
from vgraph.volume import Volume

from helpers.multivolume import (BLUE, GREEN_RAMP, ORANGE, RED_RAMP, REFERENCE_TOLERANCE,
                                 assert_cut_like_the_reference, shifted)

SIZE = (60, 40)


def union_network(a: Volume, b: Volume, camera, union: bool = True, **properties) -> Network:
    """A -> volume1, B -> volume2 of MultiVolumeRayCaster 'mv'; A -> eep.volume and, with
    ``union``, B -> eep.volume2 (without: the rays of A's box alone, as before the union)."""
    network = Network()
    network.add(GivenVolume(id="a", volume=a))
    network.add(GivenVolume(id="b", volume=b))
    network.add("EntryExitPoints", id="eep", camera=camera)
    network.add("MultiVolumeRayCaster", id="mv", **properties)
    network.link("eep.camera", "mv.camera")
    connections = [("a.volume", "eep.volume"), ("a.volume", "mv.volume1"), ("b.volume", "mv.volume2"),
                   ("eep.entry", "mv.entry"), ("eep.exit", "mv.exit")]
    if union:
        connections.append(("b.volume", "eep.volume2"))
    for source, target in connections:
        network.connect(source, target)
    return network


@pytest.fixture(scope="module")
def pair():
    """A random volume and B = A moved half its width along x (their boxes overlap by half)."""
    data = np.random.default_rng(7).random((7, 9, 12)).astype(np.float32)
    a = Volume(data, spacing=(0.8, 0.8, 0.4), origin=(1.0, -2.0, 3.0))
    return a, shifted(a, (6, 0, 0))


def aligned_union_camera(a: Volume, shift: int) -> tuple[Camera, tuple[int, int]]:
    """Orthographic down -z over the union of A and A moved ``shift`` voxels along x, pixel centres
    on the voxel centres: pixel (row, col) sees x = a.x0 + col * sx, y = a.y0 + (ny - 1 - row) * sy.
    Returns the camera and the image size."""
    nx, ny, _ = a.dims
    low, high = volume_box(a)
    high = high + np.array([shift * a.spacing[0], 0.0, 0.0])
    centre = (low + high) / 2
    camera = Camera(projection="orthographic", position=(centre[0], centre[1], high[2] + 5.0),
                    focus=tuple(centre), near=1.0, far=50.0, parallel_scale=ny * a.spacing[1] / 2)
    return camera, (nx + shift, ny)


@pytest.fixture(scope="module")
def torus_pair():
    torus = sample("torus", 28, "float32")
    return torus, shifted(torus, (14, 0, 0))


def union_camera(a: Volume, b: Volume) -> Camera:
    low, high, _ = rays_box([a, b])
    return Camera.looking_at_box(low, high, direction=(-0.5, -0.3, -1.0))


# --- the entry and exit points ------------------------------------------------------------------
def test_entry_and_exit_points_span_the_union_in_the_first_volumes_texture_space(pair):
    a, b = pair
    camera, size = aligned_union_camera(a, 6)
    network = union_network(a, b, camera)
    entry, exit_points = network.evaluate("eep.entry", size=size), network.evaluate("eep.exit", size=size)
    nx, ny, nz = a.dims
    columns, rows = np.meshgrid(np.arange(size[0]), np.arange(size[1]))
    world_x = a.origin[0] + columns * a.spacing[0]
    world_y = a.origin[1] + (ny - 1 - rows) * a.spacing[1]
    low, high = volume_box(a)

    def texture(p, axis):  # A's texture coordinate of world coordinate p along axis
        return ((p - a.origin[axis]) / a.spacing[axis] + 0.5) / a.dims[axis]

    assert np.all(entry[..., 3] == 1.0) and np.all(exit_points[..., 3] == 1.0)  # every ray meets the union
    for image, z in ((entry, high[2]), (exit_points, low[2])):
        np.testing.assert_allclose(image[..., 0], texture(world_x, 0), atol=1e-5)
        np.testing.assert_allclose(image[..., 1], texture(world_y, 1), atol=1e-5)
        np.testing.assert_allclose(image[..., 2], texture(z, 2), atol=1e-5)
    assert entry[..., 0].max() > 1.0  # B's far half: beyond A's texture box, even beyond [0, 1]
    alone = union_network(a, b, camera, union=False).evaluate("eep.entry", size=size)
    assert np.all(alone[:, nx:, 3] == 0.0) and np.all(alone[:, :nx, 3] == 1.0)  # A's box alone


def test_the_camera_both_processors_resolve_is_the_unions(torus_pair):
    """Automatic near/far (and fitting) on the union box, in EntryExitPoints and the ray caster
    alike, so the depth output and the GUI's zoom start from the camera that made the rays."""
    a, b = torus_pair
    camera = Camera(position=(3.0, 2.0, 6.0), focus=(0.5, 0.0, 0.0))  # near and far automatic
    network = union_network(a, b, camera)
    network.evaluate("mv.image", size=SIZE)
    eep, mv = network["eep"].view_camera, network["mv"].view_camera
    assert eep == mv == camera.resolved(*rays_box([a, b])[:2], SIZE[0] / SIZE[1])
    assert eep != camera.resolved(*volume_box(a), SIZE[0] / SIZE[1])  # not A's box


def test_frame_volume_frames_the_union(torus_pair):
    a, b = torus_pair
    network = union_network(a, b, Camera(position=(0.0, 0.0, 9.0), focus=(0.0, 0.0, 0.0)))
    network.evaluate("mv.image", size=SIZE)
    network["eep"].frame_volume()
    width, height = network["eep"].render_size
    fitting = Camera(position=(0.0, 0.0, 9.0), focus=(0.0, 0.0, 0.0), fit_to_data=True)
    assert network.get("mv.camera") == fitting.resolved(*rays_box([a, b])[:2], width / height)


# --- what the MultiVolumeRayCaster draws ---------------------------------------------------------
def test_each_channel_shows_its_whole_extent(pair):
    """maximum with a red ramp on A and a green one on B: red = A's MIP over A's columns, green =
    the same MIP moved 6 columns, including the 6 columns beyond A's box (cut off before the
    union); each is 0 where its own box does not reach."""
    a, b = pair
    camera, size = aligned_union_camera(a, 6)
    nx = a.dims[0]
    properties = dict(blend="maximum", transfer_function1=RED_RAMP, transfer_function2=GREEN_RAMP)
    image = union_network(a, b, camera, **properties).evaluate("mv.image", size=size)
    mip = a.normalized(a.data).max(axis=0)[::-1, :]  # row 0 = largest y
    np.testing.assert_allclose(image[:, :nx, 0], mip, atol=1e-5)
    np.testing.assert_allclose(image[:, nx:, 0], 0.0, atol=1e-7)
    np.testing.assert_allclose(image[:, 6:, 1], mip, atol=1e-5)
    np.testing.assert_allclose(image[:, :6, 1], 0.0, atol=1e-7)
    before = union_network(a, b, camera, union=False, **properties).evaluate("mv.image", size=size)
    np.testing.assert_allclose(before[:, nx:, :3], 0.0, atol=1e-7)  # A's box alone cut B's far half


@pytest.mark.parametrize("blend, shading", [("accumulate", "none"), ("accumulate", "blinn_phong"),
                                            ("nearest_opaque", "blinn_phong"), ("maximum", "none")])
def test_partly_overlapping_channels_match_the_cpu_reference(torus_pair, blend, shading):
    a, b = torus_pair
    camera = union_camera(a, b)
    properties = dict(blend=blend, shading=shading, opacity_threshold=0.3, background=(0.1, 0.2, 0.3, 1.0))
    gl = union_network(a, b, camera, transfer_function1=ORANGE, transfer_function2=BLUE,
                       **properties).evaluate("mv.image", size=SIZE)
    reference = render_channels([(a, ORANGE), (b, BLUE)], camera, SIZE, blend=blend, opacity_threshold=0.3,
                                background=(0.1, 0.2, 0.3, 1.0),
                                shading=Shading() if shading != "none" else None)
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)
    cut = union_network(a, b, camera, union=False, transfer_function1=ORANGE, transfer_function2=BLUE,
                        **properties).evaluate("mv.image", size=SIZE)
    assert np.abs(gl - cut).max() > 0.3  # B's part beyond A's box shows now


def test_a_clip_plane_cuts_both_channels(pair):
    """A plane keeping x >= the 8th column's edge: in the aligned view columns 0..7 (A's and B's)
    show the background, the others what they show unclipped."""
    a, b = pair
    camera, size = aligned_union_camera(a, 6)
    properties = dict(blend="maximum", transfer_function1=RED_RAMP, transfer_function2=GREEN_RAMP)
    whole = union_network(a, b, camera, **properties).evaluate("mv.image", size=size)
    network = union_network(a, b, camera, **properties)
    cut_x = a.origin[0] + 7.5 * a.spacing[0]  # between columns 7 and 8: inside both boxes
    network.set("eep.clip_planes", [{"normal": [1.0, 0.0, 0.0], "point": [cut_x, 0.0, 0.0]}])
    clipped = network.evaluate("mv.image", size=size)
    np.testing.assert_array_equal(clipped[:, :8, :3], 0.0)
    np.testing.assert_array_equal(clipped[:, 8:], whole[:, 8:])
    assert whole[:, :8, 0].max() > 0.5 and whole[:, 6:8, 1].max() > 0.5  # both channels were there


def test_clip_planes_and_a_crop_box_of_the_union_match_the_cpu_reference(torus_pair):
    a, b = torus_pair
    camera = union_camera(a, b)
    planes = [{"normal": [0.2, 1.0, 0.3], "point": [0.0, -0.1, 0.0]}]
    low, high, _ = rays_box([a, b])
    crop = (float(low[0]) + 0.3, -2.0, -2.0, float(high[0]) - 0.4, 2.0, 0.5)  # cuts both x ends
    network = union_network(a, b, camera, transfer_function1=ORANGE, transfer_function2=BLUE,
                            shading="blinn_phong")
    assert_cut_like_the_reference(network, [(a, ORANGE), (b, BLUE)], camera, SIZE, planes, crop)


def test_the_depth_output_lies_on_the_union_rays(pair):
    """nearest_opaque's depth beyond A's box (where B is alone) equals that of B rendered alone
    (one channel, its own box: both start their rays on the same top face)."""
    a, b = pair
    camera, size = aligned_union_camera(a, 6)
    network = union_network(a, b, camera, blend="nearest_opaque", opacity_threshold=0.3,
                            transfer_function1=RED_RAMP, transfer_function2=GREEN_RAMP)
    image, depth = network.evaluate("mv.image", size=size), network.evaluate("mv.depth", size=size)
    alone = Network()
    alone.add(GivenVolume(id="b", volume=b))
    alone.add("EntryExitPoints", id="eep", camera=camera)
    alone.add("MultiVolumeRayCaster", id="mv", blend="nearest_opaque", opacity_threshold=0.3,
              transfer_function1=GREEN_RAMP)
    alone.link("eep.camera", "mv.camera")
    for source, target in (("b.volume", "eep.volume"), ("b.volume", "mv.volume1"), ("eep.entry", "mv.entry"),
                           ("eep.exit", "mv.exit")):
        alone.connect(source, target)
    b_depth = alone.evaluate("mv.depth", size=size)
    nx = a.dims[0]
    hit = depth[..., 3] == 1.0
    np.testing.assert_array_equal(hit, image[..., :3].max(axis=-1) > 0.0)
    assert hit[:, nx:].mean() > 0.2 and np.ptp(depth[:, nx:, 1][hit[:, nx:]]) > 0.5  # hits at several depths
    np.testing.assert_array_equal(hit[:, nx:], b_depth[:, nx:, 3] == 1.0)
    np.testing.assert_allclose(depth[:, nx:, :2], b_depth[:, nx:, :2], atol=1e-6)
