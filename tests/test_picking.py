"""Network.pick (issue 36): the world point, voxel and values under a canvas pixel, for 3D views
from the ray caster's depth (refined on the tricubic iso-surface in iso mode) and for slice views
from the SliceViewer's plane; nothing drawn is a result, a bad canvas or pixel a PickError.

The accuracy numbers are an analytic sphere's (bench/picking_sphere.py): its tricubic picks lie on
the exact sphere to a few thousandths of a voxel, a ruler between two antipodal picks measures the
diameter within 0.05 voxel, and the GL's depth alone (linear) is within a tenth of a voxel."""

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

import vgraph
from vgraph.camera import Camera
from vgraph.labels import LabelEntry, LabelTable
from vgraph.network import Network
from vgraph.picking import PickError
from vgraph.testing import GivenVolume

from helpers.paths import REPO
from picking_sphere import CANVAS, CENTRE, RADIUS, diameter, radius_error, ring_pixels, sphere_network

MIDDLE = CANVAS // 2


@pytest.fixture(scope="module")
def sphere():
    return sphere_network(1.0)


def test_the_middle_pixel_picks_the_sphere_s_front_pole(sphere):
    result = sphere.pick("canvas", MIDDLE, MIDDLE)
    assert result.hit and result.kind == "3d" and result.renderer == "rc"
    pole = np.add(CENTRE, (0.0, 0.0, RADIUS))
    np.testing.assert_allclose(result.point, pole, atol=0.1)          # the GL depth: within 0.1 voxel
    np.testing.assert_allclose(result.surface.point, pole, atol=0.01)  # on the tricubic surface
    np.testing.assert_allclose(result.surface.normal, (0.0, 0.0, 1.0), atol=1e-3)
    volume = sphere["src"].volume
    assert result.voxel == tuple(int(v) for v in np.rint(volume.world_to_voxel(result.surface.point)))


def test_tricubic_picks_lie_on_the_sphere_with_its_curvature(sphere):
    for x, y in ring_pixels(12):
        result = sphere.pick("canvas", x, y)
        surface = result.surface
        assert abs(radius_error(surface.point)) < 0.01, (x, y)
        assert abs(radius_error(result.point)) < 0.1, (x, y)
        outward = np.subtract(surface.point, CENTRE) / np.linalg.norm(np.subtract(surface.point, CENTRE))
        np.testing.assert_allclose(surface.normal, outward, atol=2e-3)
        # Kindlmann's sign convention: a sphere seen from outside has k1 = k2 = +1/R
        assert surface.k1 == pytest.approx(1 / RADIUS, rel=0.02)
        assert surface.k2 == pytest.approx(1 / RADIUS, rel=0.02)
        assert surface.gaussian == pytest.approx(1 / RADIUS ** 2, rel=0.04)


@pytest.mark.parametrize("voxel", [2.0, 0.5])
def test_a_ruler_between_antipodal_tricubic_picks_measures_the_diameter_within_0_05_voxel(voxel):
    assert abs(diameter(voxel, "tricubic") - 2 * RADIUS) < 0.05 * voxel
    # the GL depth alone (trilinear) is within a tenth of a voxel, nearest within a voxel
    assert abs(diameter(voxel, "linear") - 2 * RADIUS) < 0.1 * voxel
    assert abs(diameter(voxel, "nearest") - 2 * RADIUS) < 1.0 * voxel


def test_the_value_is_the_volume_sampled_trilinearly_at_the_point():
    sphere = sphere_network(1.0)
    sphere.set("rc.compositing", "dvr")  # no iso refinement: the value at the GL's depth point
    result = sphere.pick("canvas", MIDDLE + 5, MIDDLE - 3)
    volume = sphere["src"].volume
    index = volume.world_to_voxel(result.point)
    expected = map_coordinates(volume.data, index[::-1].reshape(3, 1), order=1)[0]
    assert result.hit and result.surface is None
    assert result.value == pytest.approx(float(expected), abs=1e-5)
    assert result.samples[0].source == "src.volume"


def test_a_pixel_beside_the_sphere_is_a_miss_not_an_error(sphere):
    result = sphere.pick("canvas", 0, 0)
    assert not result.hit and result.point is None and "nothing drawn" in result.reason


def test_bad_canvases_and_pixels_are_named_errors(sphere):
    with pytest.raises(PickError, match="outside its 65x65 image"):
        sphere.pick("canvas", CANVAS, 3)
    with pytest.raises(PickError, match="outside"):
        sphere.pick("canvas", 3, float("nan"))
    with pytest.raises(PickError, match="'rc' is a RayCaster, not a canvas"):
        sphere.pick("rc", 3, 3)
    with pytest.raises(PickError, match="no processor 'nowhere'"):
        sphere.pick("nowhere", 3, 3)


def labelled_slice_network() -> Network:
    """A label volume (0 outside, 2 in the left half, 5 in the right) sliced axially, and the same
    volume drawn by a LabelRayCaster whose table names label 2."""
    data = np.zeros((8, 16, 16), np.uint8)
    data[2:6, 4:12, 2:8], data[2:6, 4:12, 8:14] = 2, 5
    volume = vgraph.Volume(data, spacing=(0.5, 0.5, 2.0), origin=(10.0, 20.0, 30.0), holds_labels=True)
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("SliceViewer", id="slice", orientation="axial", cursor=(14.0, 23.0, 36.0))
    network.add("Canvas", id="canvas", size=(64, 64))
    table = LabelTable.default().with_entry(LabelEntry(value=2, name="tumour"))
    network.add("LabelRayCaster", id="labels", label_table=table)
    network.connect("src.volume", "slice.volume")
    network.connect("slice.image", "canvas.image")
    network.connect("src.volume", "labels.labels")
    return network


def test_a_slice_pick_is_the_exact_point_on_the_plane_with_the_label_s_name():
    network = labelled_slice_network()
    result = network.pick("canvas", 20.25, 31.5)
    plane = network["slice"].last_plane
    assert result.kind == "slice" and result.renderer == "slice" and result.hit
    np.testing.assert_allclose(result.point, plane.pixel_to_world(20.25, 31.5, (64, 64)), atol=1e-12)
    assert result.point[2] == pytest.approx(36.0)  # on the cursor's axial plane
    volume = network["src"].volume
    expected_voxel = tuple(int(v) for v in np.rint(volume.world_to_voxel(result.point)))
    assert result.voxel == expected_voxel
    label = int(volume.data[expected_voxel[2], expected_voxel[1], expected_voxel[0]])
    assert result.samples[0].value == label
    assert result.samples[0].label == {0: "label 0", 2: "tumour", 5: "label 5"}[label]


def test_slice_picks_name_both_labels():
    network = labelled_slice_network()
    plane_labels = set()
    for x in range(0, 64, 4):
        sample = network.pick("canvas", x, 32).samples[0]
        if sample.value is not None:
            plane_labels.add(sample.label)
    assert {"tumour", "label 5"} <= plane_labels


def test_a_camera_that_looks_away_misses():
    sphere = sphere_network(1.0)
    camera = Camera(projection="orthographic", position=(100.0, 100.0, 100.0), focus=(200.0, 200.0, 200.0),
                    up=(0.0, 0.0, 1.0), parallel_scale=5.0, fit_to_data=False)
    sphere.set("eep.camera", camera)
    assert not sphere.pick("canvas", MIDDLE, MIDDLE).hit


def test_depth_picks_land_on_the_curvature_raycaster_s_own_hit_positions_and_curvatures():
    """An independent check of the unprojection: the CurvatureRaycaster writes each hit's world
    position and curvature as images; the pick from its depth output finds the same point, and
    the tricubic refinement the same curvatures."""
    network = vgraph.load(REPO / "networks" / "curvature_torus.json")
    network.set("canvas.size", (64, 64))
    for x in (12, 44):
        result = network.pick("canvas", x, 32)
        assert result.hit and result.surface is not None
        renderer = result.renderer
        position = network.output(f"{renderer}.position").to_numpy()[32, x]
        k1, k2 = network.output(f"{renderer}.curvature").to_numpy()[32, x, :2]
        np.testing.assert_allclose(result.point, position[:3], atol=1e-5)
        np.testing.assert_allclose(result.surface.point, position[:3], atol=1e-4)
        assert (result.surface.k1, result.surface.k2) == pytest.approx((k1, k2), rel=2e-3, abs=2e-3)


def test_behind_a_compositor_the_nearer_renderer_s_surface_is_picked():
    """Two ray casters composited: the sphere (radius 10) and a wider sphere 30 units further
    back. Where both are drawn the near one is picked; beside it, the far one."""
    network = sphere_network(1.0)
    near_volume = network["src"].volume
    far_volume = vgraph.Volume(near_volume.data * 1.6, spacing=(1.6,) * 3,  # radius 16, centre 30 back
                               origin=tuple(np.multiply(near_volume.origin, 1.6) + (0.0, 0.0, -30.0)),
                               declared_range=(-16.0, 16.0))
    network.add(GivenVolume(id="far_src", volume=far_volume))
    network.add("EntryExitPoints", id="far_eep", camera=network.get("eep.camera"))
    network.add("RayCaster", id="far_rc", compositing="iso", iso_level=0.5, sampling_rate=4.0)
    network.link("eep.camera", "far_eep.camera")
    network.link("eep.camera", "far_rc.camera")
    for source, target in (("far_src.volume", "far_eep.volume"), ("far_src.volume", "far_rc.volume"),
                           ("far_eep.entry", "far_rc.entry"), ("far_eep.exit", "far_rc.exit")):
        network.connect(source, target)
    network.add("ImageCompositor", id="mix")
    network.disconnect("rc.image", "canvas.image")
    network.connect("rc.image", "mix.front")
    network.connect("far_rc.image", "mix.back")
    network.connect("mix.image", "canvas.image")

    both = network.pick("canvas", MIDDLE, MIDDLE)
    assert both.renderer == "rc" and abs(radius_error(both.surface.point)) < 0.01
    beside = network.pick("canvas", MIDDLE + 26, MIDDLE)  # outside the near sphere, inside the far one
    assert beside.renderer == "far_rc" and beside.hit
    network.set("rc.iso_level", 1.0)  # the near sphere shrinks to its centre: the far one shows there
    behind = network.pick("canvas", MIDDLE, MIDDLE)
    assert behind.renderer == "far_rc" and behind.eye_distance > both.eye_distance + 10


def test_a_projected_tetrahedra_pick_interpolates_the_mesh_in_its_tetrahedron():
    """A linear field cut into tetrahedra (VolumeToTetMesh): the barycentric value at the picked
    point is the field there, exactly (a linear field is what barycentric interpolation keeps)."""
    axis = np.arange(12, dtype=np.float32)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    spacing, origin = (0.5, 0.75, 1.0), (-2.0, 1.0, 3.0)
    world = [origin[i] + spacing[i] * c for i, c in enumerate((x, y, z))]
    field = (1.0 * world[0] + 2.0 * world[1] - 0.5 * world[2]).astype(np.float32)
    network = Network()
    network.add(GivenVolume(id="src", volume=vgraph.Volume(field, spacing=spacing, origin=origin)))
    network.add("VolumeToTetMesh", id="tets")
    network.add("ProjectedTetrahedra", id="pt")
    network.add("Canvas", id="canvas", size=(48, 48))
    for source, target in (("src.volume", "tets.volume"), ("tets.mesh", "pt.mesh"), ("pt.image", "canvas.image")):
        network.connect(source, target)
    for x_pixel, y_pixel in ((24, 24), (20, 30), (30, 18)):
        result = network.pick("canvas", x_pixel, y_pixel)
        assert result.hit and result.renderer == "pt"
        mesh, volume = result.samples[0], result.samples[1]
        assert mesh.source == "tets.mesh" and mesh.note.startswith("in tetrahedron")
        expected = 1.0 * result.point[0] + 2.0 * result.point[1] - 0.5 * result.point[2]
        assert mesh.value == pytest.approx(expected, abs=1e-3)
        assert volume.source == "src.volume" and volume.value == pytest.approx(expected, abs=1e-3)


def test_a_label_ray_caster_pick_names_the_label_on_its_surface():
    """The LabelRayCaster's depth output (first_hit: the refined hit): the point lies on the top
    face of the labelled block, half-way between the last labelled voxel centre (z = 40) and the
    next (z = 42), and the label there is named from its table."""
    network = labelled_slice_network()
    volume = network["src"].volume
    camera = Camera(projection="orthographic", position=(13.75, 23.75, 100.0), focus=(13.75, 23.75, 37.0),
                    up=(0.0, 1.0, 0.0), parallel_scale=5.0, fit_to_data=False)
    network.add("EntryExitPoints", id="eep", camera=camera)
    network.link("eep.camera", "labels.camera")
    network.set("labels.compositing", "first_hit")
    network.add("Canvas", id="view", size=(64, 64))
    for source, target in (("src.volume", "eep.volume"), ("eep.entry", "labels.entry"),
                           ("eep.exit", "labels.exit"), ("labels.image", "view.image")):
        network.connect(source, target)
    left, right = network.pick("view", 21, 32), network.pick("view", 43, 32)
    assert left.renderer == right.renderer == "labels"
    assert (left.samples[0].label, right.samples[0].label) == ("tumour", "label 5")
    for result in (left, right):
        assert result.point[2] == pytest.approx(41.0, abs=0.05)
        assert result.voxel == tuple(int(v) for v in np.rint(volume.world_to_voxel(result.point)))
    assert not network.pick("view", 1, 1).hit


def test_a_volume_drawn_brick_by_brick_is_sampled_at_full_resolution():
    from vgraph.bricks.pyramid import ArrayPyramid
    from vgraph.bricks.volume import BrickedVolume
    plain = sphere_network(1.0)["src"].volume
    pyramid = ArrayPyramid(plain.data, plain.spacing, plain.origin, brick=(8, 8, 8), value_range=(-RADIUS, RADIUS))
    network = sphere_network(1.0)
    network["src"].volume = BrickedVolume(pyramid)
    network.disconnect("rc.image", "canvas.image")
    network.add("BrickedRayCaster", id="brc", compositing="iso", iso_level=0.5)
    network.link("eep.camera", "brc.camera")
    for source, target in (("src.volume", "brc.volume"), ("eep.entry", "brc.entry"), ("eep.exit", "brc.exit"),
                           ("brc.image", "canvas.image")):
        network.connect(source, target)
    result = network.pick("canvas", MIDDLE + 4, MIDDLE - 6)
    assert result.hit and result.renderer == "brc"
    assert abs(radius_error(result.point)) < 0.2 and abs(radius_error(result.surface.point)) < 0.01
    index = plain.world_to_voxel(result.surface.point)  # where the values are sampled
    expected = map_coordinates(plain.data, index[::-1].reshape(3, 1), order=1)[0]
    assert result.value == pytest.approx(float(expected), abs=1e-5)
