"""Ray bounds from the occupied blocks (vgraph.gl.raycasting.ray_bounds, RAY_BOUNDS): the image and
depth with bounds equal those without them and those without empty-space skipping, bit for bit, for
dvr (also shaded), iso and first_hit on a synthetic tree in air and on the CT bonsai; perspective,
orthographic with rays along block faces, a camera inside, the far plane through the volume and
jittered entry points. Also: rays that meet no occupied block evaluate nothing, a TF change
rebuilds the boxes, the bounds stay out where they cannot pay or are not exact (mip, xray, dense
TFs, scattered blocks, the CurvatureRaycaster; the CurvatureVolumeRaycaster has them, same picture),
and the boxes cover exactly the occupied blocks."""

import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.gl.raycasting import ray_bounds
from vgraph.gl.raycasting.components import EmptySpace
from vgraph.gl.raycasting.ray_bounds import occupied_boxes
from vgraph.implicit import sample
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import rendering_network
from helpers.paths import DATA

SIZE = (64, 48)
TREE_TF = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.2, 0.3, 0.6, 0.2, 0.0),
                                   (0.35, 0.4, 0.8, 0.3, 0.3), (0.75, 0.8, 0.6, 0.4, 0.5),
                                   (1.0, 1.0, 1.0, 1.0, 0.9)])
FOG_TF = TransferFunction(points=[(0.0, 0.5, 0.6, 1.0, 0.004), (1.0, 1.0, 0.9, 0.8, 0.012)])


def tree(shape=(70, 60, 66), seed=3) -> Volume:
    """uint8, mostly air (0-20) like a CT of a plant: a trunk, branches and leaf blobs of
    80-250, so that a quarter of the 8^3 blocks are occupied under TREE_TF."""
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape, dtype=np.float32)
    data = rng.integers(0, 20, shape).astype(np.float32)
    trunk = (x - 33) ** 2 + (y - 30) ** 2 < 16
    data[trunk & (z < 40)] = 160
    for _ in range(14):
        c = rng.uniform([20, 10, 10], [62, 50, 56])
        r = rng.uniform(2.5, 7.0)
        blob = (z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2 < r * r
        data[blob] = np.maximum(data[blob], rng.uniform(80, 250))
    return Volume(data.astype(np.uint8), spacing=(1.0, 0.9, 1.1), origin=(-3.0, 2.0, 1.0))


def cameras(volume):
    lo, hi = volume_box(volume)
    centre, extent = (lo + hi) / 2, hi - lo
    size = float(np.max(extent))
    perspective = Camera.looking_at_box(lo, hi, direction=(-0.5, -0.3, -1.0))
    inside = Camera(position=tuple(centre + extent * np.array([0.1, -0.25, 0.3])),
                    focus=tuple(centre + extent * np.array([0.4, 0.2, -0.3])),
                    near=0.01 * size, far=10.0 * size, fov=70)
    # Looking down -z with rays through voxel centres: block faces lie on voxel centres, so many
    # rays run exactly along them (and along the box's sides).
    aligned = Camera(projection="orthographic", position=(centre[0], centre[1], hi[2] + 5.0),
                     focus=tuple(centre), near=1.0, far=50.0 + size,
                     parallel_scale=volume.dims[1] * volume.spacing[1] / 2)
    # The far plane through the middle of the volume (far-plane capping ends the rays there).
    cut = perspective.model_copy(update={"far": float(np.linalg.norm(np.asarray(perspective.position) - centre))})
    return {"perspective": perspective, "orthographic": Camera.looking_at_box(
        lo, hi, direction=(0.3, -0.6, -1.0), projection="orthographic"),
        "aligned": aligned, "inside": inside, "far_plane_cut": cut}


def aligned_size(volume):
    return (volume.dims[0], volume.dims[1])  # one pixel per voxel column


def render(network, size, bounds):
    network.set("rc.ray_bounds", bounds)
    image = network.evaluate("rc.image", size=size)
    depth = network.evaluate("rc.depth", size=size)
    defines = network["rc"].passes[-1][1]
    network["rc"].invalidate()  # the next render draws anew
    return image, depth, defines


def three_ways(volume, camera, size=SIZE, **properties):
    """(image, depth, defines) with bounds, with skipping but no bounds, and without skipping."""
    network = rendering_network(volume, camera, **properties)
    bounded = render(network, size, True)
    skipped = render(network, size, False)
    network.set("rc.empty_space_skipping", False)
    plain = render(network, size, True)
    assert plain[2].get("RAY_BOUNDS") is not True and skipped[2].get("RAY_BOUNDS") is not True
    return bounded, skipped, plain


def assert_same_picture(a, b):
    np.testing.assert_array_equal(a[0], b[0])
    # depth: window depth, distance, (b = samples evaluated, may differ), has a depth sample
    np.testing.assert_array_equal(a[1][..., [0, 1, 3]], b[1][..., [0, 1, 3]])


@pytest.fixture(scope="module")
def tree_volume():
    return tree()


@pytest.mark.parametrize("camera_name", ["perspective", "orthographic", "aligned", "inside", "far_plane_cut"])
@pytest.mark.parametrize("mode, shading", [("dvr", "none"), ("dvr", "blinn_phong"), ("iso", "none"),
                                           ("first_hit", "none")])
def test_bounds_change_no_pixel(tree_volume, camera_name, mode, shading):
    camera = cameras(tree_volume)[camera_name]
    size = aligned_size(tree_volume) if camera_name == "aligned" else SIZE
    bounded, skipped, plain = three_ways(tree_volume, camera, size, compositing=mode,
                                         shading=shading, transfer_function=TREE_TF, iso_level=0.3)
    assert bounded[2].get("RAY_BOUNDS") is True
    assert np.ptp(plain[0][..., 0]) > 0.1  # something varied is in the picture
    assert_same_picture(bounded, skipped)
    assert_same_picture(bounded, plain)
    # Bounds leave out only samples in empty blocks, which skipping does not evaluate either.
    np.testing.assert_array_equal(bounded[1][..., 2], skipped[1][..., 2])
    assert bounded[1][..., 2].sum() < plain[1][..., 2].sum()


@pytest.mark.parametrize("rate, interpolation", [(0.5, "trilinear"), (2.3, "trilinear"), (1.0, "nearest")])
def test_other_rates_interpolation_and_jitter(tree_volume, rate, interpolation):
    network_properties = dict(compositing="dvr", transfer_function=TREE_TF, sampling_rate=rate,
                              interpolation=interpolation)
    bounded, skipped, plain = three_ways(tree_volume, cameras(tree_volume)["perspective"],
                                         **network_properties)
    assert bounded[2].get("RAY_BOUNDS") is True
    assert_same_picture(bounded, plain)
    network = rendering_network(tree_volume, cameras(tree_volume)["perspective"], **network_properties)
    network.set("eep.jitter", 1.0)
    assert_same_picture(render(network, SIZE, True), render(network, SIZE, False))


def test_a_tile_of_the_view(tree_volume):
    """A tile (Camera.tile, as the distributed renderer draws them) has rays off the view axis."""
    full = cameras(tree_volume)["perspective"]
    camera = full.tile(40, 8, 48, 36, 128, 96)
    bounded, skipped, plain = three_ways(tree_volume, camera, (48, 36), compositing="dvr",
                                         transfer_function=TREE_TF)
    assert bounded[2].get("RAY_BOUNDS") is True
    assert np.ptp(plain[0][..., 0]) > 0.1
    assert_same_picture(bounded, plain)


def bounds_per_pixel(network, size):
    """The bounds target (near, far depth from the near plane) spread to the pixels, row 0 at the top."""
    texture = network["rc"].parts[EmptySpace].bounds._texture
    coarse = np.frombuffer(texture.read(), dtype=np.float32).reshape(texture.size[1], texture.size[0], 2)
    rows = (size[1] - 1 - np.arange(size[1])) // ray_bounds.TILE
    columns = np.arange(size[0]) // ray_bounds.TILE
    texels = coarse[rows[:, None], columns[None, :]]
    return texels[..., 0], -texels[..., 1]


@pytest.mark.parametrize("camera_name", ["perspective", "inside"])
def test_bounds_hold_the_first_contribution_and_leave_out_air(tree_volume, camera_name):
    camera = cameras(tree_volume)[camera_name]
    network = rendering_network(tree_volume, camera, compositing="dvr", transfer_function=TREE_TF)
    size = (128, 96)  # tiles of 4 pixels, a few voxels wide
    bounded = render(network, size, True)
    near, far = bounds_per_pixel(network, size)
    view = network["rc"].view_camera
    _, directions = view.rays(*size)
    hit = bounded[1][..., 3] > 0
    # The depth sample (first opacity > 0) at distance g along the ray is at depth g cos from the plane.
    depth = bounded[1][..., 1] * (directions @ view.basis()[2])
    assert hit.mean() > 0.05
    assert np.all(near[hit] < ray_bounds.FAR)
    assert np.all(near[hit] <= depth[hit] + 1e-4) and np.all(depth[hit] <= far[hit] + 1e-4)
    if camera_name == "perspective":  # rays through air only: no march at all
        covered = network.evaluate("eep.entry", size=size)[..., 3] > 0
        air = covered & (near >= ray_bounds.FAR)
        assert air.sum() > 0.15 * covered.sum()  # 0.25 measured
        assert np.all(bounded[1][..., 2][air] == 0) and np.all(bounded[0][air] == bounded[0][0, 0])


def test_a_tf_change_rebuilds_the_boxes(tree_volume):
    network = rendering_network(tree_volume, cameras(tree_volume)["perspective"], compositing="dvr",
                                transfer_function=TREE_TF)
    first = render(network, SIZE, True)
    bounds = network["rc"].parts[EmptySpace].bounds
    boxes_before = bounds._count
    # Only the brightest blobs stay visible: fewer boxes, and the image follows the TF.
    bright = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.8, 1.0, 0.5, 0.2, 0.0), (1.0, 1.0, 0.6, 0.3, 0.9)])
    network.set("rc.transfer_function", bright)
    bounded = render(network, SIZE, True)
    assert bounded[2].get("RAY_BOUNDS") is True
    assert 0 < bounds._count < boxes_before
    assert not np.array_equal(bounded[0], first[0])
    assert_same_picture(bounded, render(network, SIZE, False))
    network.set("rc.transfer_function", TREE_TF)
    assert_same_picture(render(network, SIZE, True), first)
    assert bounds._count == boxes_before


def test_iso_level_change_rebuilds_the_boxes(tree_volume):
    network = rendering_network(tree_volume, cameras(tree_volume)["perspective"], compositing="iso",
                                iso_level=0.3)
    render(network, SIZE, True)
    low = network["rc"].parts[EmptySpace].bounds._count
    network.set("rc.iso_level", 0.9)
    bounded = render(network, SIZE, True)
    assert network["rc"].parts[EmptySpace].bounds._count < low
    assert_same_picture(bounded, render(network, SIZE, False))


@pytest.mark.parametrize("properties", [dict(compositing="mip"), dict(compositing="xray"),
                                        dict(compositing="dvr", transfer_function=FOG_TF)])
def test_no_bounds_where_they_are_not_exact_or_do_not_pay(tree_volume, properties):
    network = rendering_network(tree_volume, cameras(tree_volume)["perspective"], **properties)
    _, _, defines = render(network, SIZE, True)
    assert defines.get("RAY_BOUNDS") is not True


def test_the_curvature_raycaster_draws_no_bounds():
    """It skips, but its hit search goes on to the exit point after the last sample (iso_hit.glsl),
    so fewer samples would change it."""
    volume = sample("torus", 32, "float32")
    network = ray_caster_network(volume, cameras(volume)["perspective"], "CurvatureRaycaster", id="rc",
                                 derivatives="central")
    network.set("rc.ray_bounds", True)
    network.evaluate("rc.image", size=SIZE)
    passes = [p.defines for p in network["rc"].passes]
    assert any(defines.get("SKIP_EMPTY_SPACE") for defines in passes)
    assert not any(defines.get("RAY_BOUNDS") for defines in passes)


@pytest.mark.parametrize("derivatives", ["central", "tricubic"])
@pytest.mark.parametrize("normalization", ["linear", "exponential"])
def test_the_curvature_volume_raycaster_with_bounds(derivatives, normalization):
    """Its march is the RayCaster's dvr with colour from curvature (also the range pass of the
    linear normalisation): bounds on both passes, the same picture."""
    from helpers.curvature import coefficients_of
    volume = sample("torus", 40, "float32")
    if derivatives == "tricubic":
        volume = coefficients_of(volume)
    surface = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.48, 0.9, 0.6, 0.3, 0.0), (0.52, 1.0, 0.8, 0.5, 0.6),
                                       (0.56, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 0.0)])
    network = ray_caster_network(volume, cameras(volume)["perspective"], "CurvatureVolumeRaycaster", id="rc",
                                 derivatives=derivatives, normalization=normalization, transfer_function=surface)
    bounded = render(network, SIZE, True)
    passes = [p.defines for p in network["rc"].passes]
    assert all(defines.get("RAY_BOUNDS") for defines in passes)
    plain = render(network, SIZE, False)
    assert np.ptp(plain[0][..., 0]) > 0.1
    assert_same_picture(bounded, plain)


def test_bonsai():
    path = DATA / "ct_bonsai" / "bonsai.nii.gz"
    if not path.exists():
        pytest.skip(f"shared data not found at {path}")
    bonsai = read_volume(path)
    for camera_name in ("perspective", "inside"):
        camera = cameras(bonsai)[camera_name]
        for mode in ("dvr", "iso"):
            bounded, skipped, plain = three_ways(bonsai, camera, (96, 96), compositing=mode,
                                                 transfer_function=TREE_TF, iso_level=0.3)
            assert bounded[2].get("RAY_BOUNDS") is True
            assert np.ptp(plain[0][..., 0]) > 0.1
            assert_same_picture(bounded, plain)


def test_boxes_cover_exactly_the_occupied_blocks():
    rng = np.random.default_rng(1)
    for density in (0.05, 0.3, 0.9):
        occupied = rng.random((9, 7, 11)) < density
        occupied[2:6, 1:5, 3:9] = True  # a solid part to merge
        boxes = occupied_boxes(occupied)
        count = np.zeros(occupied.shape, dtype=int)
        for x0, y0, z0, x1, y1, z1 in boxes:
            count[z0:z1, y0:y1, x0:x1] += 1
        np.testing.assert_array_equal(count, occupied.astype(int))  # disjoint, and all of them
        assert len(boxes) < occupied.sum()
    assert occupied_boxes(np.zeros((3, 3, 3), bool)).shape == (0, 6)
    solid = np.zeros((32, 32, 32), bool)
    solid[4:20, 8:30, 1:9] = True
    np.testing.assert_array_equal(occupied_boxes(solid), [[1, 8, 4, 9, 30, 20]])


def test_no_pass_where_it_would_not_pay():
    solid = np.zeros((32, 32, 32), bool)
    solid[4:20, 8:30, 1:9] = True
    assert ray_bounds.worthwhile_boxes(solid) is not None
    assert ray_bounds.worthwhile_boxes(np.zeros_like(solid)) is None  # nothing to draw
    assert ray_bounds.worthwhile_boxes(~solid) is None  # nearly all occupied
    scattered = np.random.default_rng(0).random(solid.shape) < 0.3  # thousands of boxes
    assert ray_bounds.worthwhile_boxes(scattered) is None
