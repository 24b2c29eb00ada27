"""Geometry derived from oriented volumes (issue 28): iso-surfaces and tetrahedra go through the
volume's affine (a sphere stays at its world centre and radius, normals and windings face out for
proper and mirrored directions), the CPU reference ray casters sample oriented volumes in the world
(LPS and RAS copies give the same images; a tilted volume is the untilted one seen by a turned
camera), and the MultiVolumeRayCaster refuses channels whose axes are turned against each other."""

import numpy as np
import pytest

from vgraph import Network, PropertyError, VGraphError
from vgraph.camera import Camera
from vgraph.numerics.multivolume_reference import render_channels
from vgraph.numerics.reference_raycast import Shading, render, volume_box
from vgraph.processors.iso_surface_extractor import IsoSurfaceExtractor
from vgraph.processors.volume_to_tet_mesh import VolumeToTetMesh
from vgraph.testing import GivenVolume
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

CENTRE, RADIUS = np.array([12.0, -30.0, 55.0]), 7.0
SPACING = (0.7, 1.1, 0.9)
SHAPE = (26, 22, 30)  # (z, y, x)


def rotation(axis, degrees: float) -> np.ndarray:
    """The rotation about a unit axis (Rodrigues)."""
    k = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    angle = np.radians(degrees)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


DIRECTIONS = {"proper": rotation((1.0, 2.0, 0.5), 35.0),
              "mirrored": rotation((1.0, 2.0, 0.5), 35.0) @ np.diag([1.0, -1.0, 1.0])}


def centred_grid(direction) -> dict:
    """Grid fields that put the box centre at CENTRE."""
    half = (np.array(SHAPE[::-1]) - 1) * np.array(SPACING) / 2.0
    return {"spacing": SPACING, "origin": tuple(CENTRE - direction @ half), "direction": direction}


def sphere_volume(direction) -> Volume:
    """Signed distance to the sphere (positive inside), sampled at the oriented grid's voxels."""
    grid = centred_grid(direction)
    probe = Volume(np.zeros(SHAPE, np.float32), **grid)
    k, j, i = np.indices(SHAPE)
    world = probe.voxel_to_world(np.stack([i, j, k], axis=-1))
    return probe.with_data((RADIUS - np.linalg.norm(world - CENTRE, axis=-1)).astype(np.float32))


def level_of(volume: Volume, value: float) -> float:
    low, high = volume.value_range
    return (value - low) / (high - low)


# --- iso-surfaces -----------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", list(DIRECTIONS))
def test_the_iso_surface_of_an_oriented_sphere_lies_at_its_world_centre_and_radius(kind):
    volume = sphere_volume(DIRECTIONS[kind])
    assert np.linalg.det(np.asarray(volume.direction)) == pytest.approx(1.0 if kind == "proper" else -1.0)
    geometry = IsoSurfaceExtractor(iso_level=level_of(volume, 0.0)).process(volume, None)
    vertices = geometry.vertices.astype(np.float64)
    radii = np.linalg.norm(vertices - CENTRE, axis=1)
    assert len(geometry.triangles) > 1000
    assert np.abs(radii - RADIUS).max() < 0.5 * min(SPACING)
    np.testing.assert_allclose(vertices.mean(axis=0), CENTRE, atol=0.05)
    outward = (vertices - CENTRE) / radii[:, None]
    cosines = np.einsum("ij,ij->i", geometry.normals, outward)
    assert cosines.min() > 0.99 and np.median(cosines) > 0.999  # normals turned with the grid
    corners = vertices[geometry.triangles]
    faces = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert np.all(np.einsum("ij,ij->i", faces, corners.mean(axis=1) - CENTRE) > 0.0)  # front faces out


def test_an_axis_aligned_volume_still_gives_its_surface_in_place():
    volume = sphere_volume(np.eye(3))
    geometry = IsoSurfaceExtractor(iso_level=level_of(volume, 0.0)).process(volume, None)
    assert np.abs(np.linalg.norm(geometry.vertices - CENTRE, axis=1) - RADIUS).max() < 0.5 * min(SPACING)


def test_the_region_of_an_oriented_volume_keeps_the_surface_inside_it():
    volume = sphere_volume(DIRECTIONS["proper"])
    level = level_of(volume, 0.0)
    whole = IsoSurfaceExtractor(iso_level=level).process(volume, None)
    region_min = (float(CENTRE[0]), -1e9, -1e9)
    half = IsoSurfaceExtractor(iso_level=level, region_min=region_min).process(volume, None)
    assert half.vertices[:, 0].min() >= CENTRE[0] - 1e-4  # the half with x >= the centre
    assert np.abs(np.linalg.norm(half.vertices - CENTRE, axis=1) - RADIUS).max() < 0.5 * min(SPACING)
    assert 0.35 < len(half.triangles) / len(whole.triangles) < 0.55
    with pytest.raises(PropertyError, match="region_min.*none of the surface"):
        IsoSurfaceExtractor("iso", iso_level=level, region_min=(float(CENTRE[0]) + 8.0, -1e9, -1e9),
                            region_max=(float(CENTRE[0]) + 9.0, 1e9, 1e9)).process(volume, None)


# --- tetrahedra ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", list(DIRECTIONS))
def test_tetrahedra_of_an_oriented_volume_sit_on_its_voxel_centres_and_stay_positive(kind):
    volume = sphere_volume(DIRECTIONS[kind])
    mesh = VolumeToTetMesh().process(volume)
    k, j, i = np.unravel_index(np.arange(volume.data.size), SHAPE)
    np.testing.assert_allclose(mesh.points, volume.voxel_to_world(np.stack([i, j, k], axis=1)), atol=1e-5)
    np.testing.assert_array_equal(mesh.scalars, volume.data.reshape(-1))
    volumes, cell = mesh.tet_volumes(), np.prod(SPACING)
    # corner tetrahedra 1/6 of a cell, the central one 1/3
    np.testing.assert_allclose(volumes, cell / 6.0 * np.where(volumes > cell / 5, 2, 1), rtol=1e-4)
    assert volumes.min() > 0.0
    assert mesh.grid is None  # the grid's cell-by-cell drawing holds no direction


# --- the CPU reference ray casters ----------------------------------------------------------------
CLEAR = (0.0, 0.0, 0.0, 0.0)
TF = TransferFunction(points=[(0.0, 0.2, 0.3, 0.9, 0.0), (0.45, 0.9, 0.6, 0.2, 0.05),
                              (1.0, 1.0, 1.0, 0.8, 0.6)])


def head_like(seed: int = 4) -> np.ndarray:
    """A lopsided blob: nothing in it is symmetric, so a mirrored or turned copy would show."""
    z, y, x = np.indices((14, 17, 15)).astype(float)
    blob = np.exp(-((x - 5.0) ** 2 / 18 + (y - 9.0) ** 2 / 30 + (z - 6.0) ** 2 / 12))
    return blob + 0.2 * np.random.default_rng(seed).random(blob.shape)


def ras_and_lps_copies():
    """The same voxels at the same world points, stored RAS (identity direction) and LPS (x and y
    reversed, direction diag(-1, -1, 1), origin at the other corner)."""
    data, spacing, origin = head_like(), (0.9, 1.2, 1.5), np.array([-7.0, 3.0, 11.0])
    ras = Volume(data, spacing=spacing, origin=tuple(origin))
    far = origin + (np.array(ras.dims) - 1) * np.array(spacing) * np.array([1.0, 1.0, 0.0])
    lps = Volume(np.ascontiguousarray(data[:, ::-1, ::-1]), spacing=spacing, origin=tuple(far),
                 direction=np.diag([-1.0, -1.0, 1.0]))
    return ras, lps


@pytest.mark.parametrize("view", ["front", "left", "top"])
@pytest.mark.parametrize("mode, shading", [("dvr", None), ("dvr", Shading()),
                                           ("dvr", Shading(gradients="precomputed")), ("mip", None)])
def test_lps_and_ras_copies_give_the_same_reference_image(view, mode, shading):
    ras, lps = ras_and_lps_copies()
    camera = Camera().viewed_from(view)
    images = [render(volume, camera, TF, (24, 20), mode=mode, shading=shading, background=CLEAR)
              for volume in (ras, lps)]
    assert images[0][..., 3].min() < 0.01 and images[0][..., 3].max() > 0.3  # the blob, and beside it
    np.testing.assert_allclose(images[1], images[0], atol=1e-12, rtol=0)


def test_a_crop_box_cuts_both_copies_alike():
    ras, lps = ras_and_lps_copies()
    crop = (-4.0, 5.0, 12.0, 3.0, 20.0, 28.0)
    camera = Camera().viewed_from("iso")
    images = [render(volume, camera, TF, (24, 20), crop_box=crop) for volume in (ras, lps)]
    assert not np.allclose(images[0], render(ras, camera, TF, (24, 20)))  # it cuts
    np.testing.assert_allclose(images[1], images[0], atol=1e-12, rtol=0)


@pytest.mark.parametrize("fit_to_data", [True, False])
def test_a_tilted_volume_is_the_untilted_one_seen_by_a_turned_camera(fit_to_data):
    turn = rotation((0.3, -1.0, 0.6), 35.0)
    data, spacing, origin = head_like(), (0.9, 1.2, 1.5), np.array([-7.0, 3.0, 11.0])
    tilted = Volume(data, spacing=spacing, origin=tuple(origin), direction=turn)
    untilted = Volume(data, spacing=spacing, origin=tuple(turn.T @ origin))  # every point turned by turn^T
    camera = Camera(position=(40.0, -25.0, 30.0), focus=tuple(tilted.voxel_to_world((7, 8, 6))),
                    up=(0.0, 0.0, 1.0), near=1.0, far=200.0, fit_to_data=fit_to_data)
    turned = Camera(position=tuple(turn.T @ camera.position), focus=tuple(turn.T @ camera.focus),
                    up=tuple(turn.T @ camera.up), near=1.0, far=200.0, fit_to_data=fit_to_data)
    shading = Shading()
    image = render(tilted, camera, TF, (26, 22), shading=shading)
    expected = render(untilted, turned, TF, (26, 22), shading=shading)
    assert expected[..., 3].max() > 0.5
    np.testing.assert_allclose(image, expected, atol=1e-9, rtol=0)
    if fit_to_data:  # framed by the bounding sphere of the tilted box, as the untilted one
        low, high = volume_box(tilted)
        untilted_low, untilted_high = volume_box(untilted)
        np.testing.assert_allclose(np.linalg.norm(high - low), np.linalg.norm(untilted_high - untilted_low))


def test_the_multivolume_reference_unites_lps_and_ras_channels():
    ras, lps = ras_and_lps_copies()
    shifted = Volume(head_like(9)[:, :12], spacing=(1.0, 1.0, 1.0), origin=(-2.0, 0.0, 9.0))
    camera = Camera().viewed_from("front")
    alike = [render_channels([(volume, TF), (shifted, TF)], camera, (24, 20)) for volume in (ras, lps)]
    np.testing.assert_allclose(alike[1], alike[0], atol=1e-12, rtol=0)
    turned = shifted.with_overrides(direction=tuple(map(tuple, rotation((0, 0, 1), 20.0))))
    with pytest.raises(VGraphError, match="channel 2's axes are turned against channel 1's"):
        render_channels([(ras, TF), (turned, TF)], camera, (24, 20))


# --- MultiVolumeRayCaster ------------------------------------------------------------------------------
def multi_volume_network(channels: dict) -> Network:
    """GivenVolume per channel -> MultiVolumeRayCaster 'mv' on the given inports; the EntryExitPoints
    'eep' is fed volume1 alone (so that the raycaster's own check speaks)."""
    network = Network()
    network.add("EntryExitPoints", id="eep", camera=Camera().viewed_from("front"))
    network.add("MultiVolumeRayCaster", id="mv")
    network.link("eep.camera", "mv.camera")
    for port, volume in channels.items():
        network.add(GivenVolume(id=f"src_{port}", volume=volume))
        network.connect(f"src_{port}.volume", f"mv.{port}")
    network.connect("src_volume1.volume", "eep.volume")
    for source, target in (("eep.entry", "mv.entry"), ("eep.exit", "mv.exit")):
        network.connect(source, target)
    return network


def test_the_multi_volume_raycaster_refuses_a_channel_turned_against_volume1_by_its_inport():
    ras, lps = ras_and_lps_copies()
    turn = rotation((0, 0, 1), 20.0) @ np.diag([-1.0, -1.0, 1.0])
    turned = lps.with_overrides(direction=tuple(map(tuple, turn)))
    network = multi_volume_network({"volume1": ras, "volume3": turned})
    with pytest.raises(VGraphError, match=r"mv\.volume3: its axes are turned against volume1's .*"
                                          r"resample one onto the other's grid"):
        network.evaluate("mv.image", size=(24, 20))


def test_the_multi_volume_raycaster_draws_lps_and_ras_channels_together():
    """Axes that differ only in sign are fine: the picture is the CPU reference's."""
    ras, lps = ras_and_lps_copies()
    shifted = Volume(head_like(9)[:, :12], spacing=(1.0, 1.0, 1.0), origin=(-2.0, 0.0, 9.0))
    network = multi_volume_network({"volume1": lps, "volume2": shifted})
    network.connect("src_volume2.volume", "eep.volume2")  # the rays span the union
    network.set("mv.transfer_function1", TF)
    network.set("mv.transfer_function2", TF)
    image = network.evaluate("mv.image", size=(24, 20))
    expected = render_channels([(lps, TF), (shifted, TF)], Camera().viewed_from("front"), (24, 20))
    assert expected[..., :3].max() > 0.3
    np.testing.assert_allclose(image, expected, atol=2e-5)  # float32 GL (tests/helpers/multivolume.py)
