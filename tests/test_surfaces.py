"""Surfaces (issue #18 item 4): IsoSurfaceExtractor's marching cubes in world units and
SurfaceSource's surface files, against analytic shapes and the meshio files they were written to."""

import numpy as np
import pytest

import meshio

from vgraph import PropertyError, VGraphError
from vgraph.geometry import Geometry
from vgraph.io.meshes import MeshFileError
from vgraph.io.surfaces import read_surface
from vgraph.processors.iso_surface_extractor import IsoSurfaceExtractor
from vgraph.processors.surface_source import SurfaceSource
from vgraph.volume import Volume

SPACING, ORIGIN, DIMS = np.array([0.7, 1.1, 1.6]), np.array([-5.0, 3.0, 10.0]), (40, 30, 24)
CENTRE, RADIUS = ORIGIN + np.array([19.3, 13.6, 11.2]) * SPACING, 9.0


def world_grid() -> np.ndarray:
    """World (x, y, z) of every voxel centre, [z, y, x, 3]."""
    z, y, x = np.mgrid[0:DIMS[2], 0:DIMS[1], 0:DIMS[0]]
    return np.stack([x, y, z], axis=-1) * SPACING + ORIGIN


def sphere_sdf(scale: float = 1.0) -> Volume:
    """Signed distance to the sphere (positive inside: higher values inside, as CT), anisotropic."""
    distance = RADIUS - np.linalg.norm(world_grid() - CENTRE, axis=-1)
    return Volume((scale * distance).astype(np.float32), spacing=tuple(SPACING), origin=tuple(ORIGIN))


def level_of(volume: Volume, value: float) -> float:
    low, high = volume.value_range
    return (value - low) / (high - low)


def face_normals(geometry: Geometry) -> np.ndarray:
    corners = geometry.vertices[geometry.triangles].astype(np.float64)
    return np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])


# --- IsoSurfaceExtractor ------------------------------------------------------------------------
def test_the_surface_of_a_sphere_sdf_has_its_radius_within_half_a_voxel():
    volume = sphere_sdf()
    geometry = IsoSurfaceExtractor(iso_level=level_of(volume, 0.0)).process(volume, None)
    radii = np.linalg.norm(geometry.vertices - CENTRE, axis=1)
    assert len(geometry.triangles) > 1000
    assert np.abs(radii - RADIUS).max() < 0.5 * SPACING.min()  # measured: 0.034 of 0.35
    # the vertices are in world units: they span the sphere's box along every axis
    low, high = geometry.bounds
    np.testing.assert_allclose(low, CENTRE - RADIUS, atol=0.5 * SPACING.max())
    np.testing.assert_allclose(high, CENTRE + RADIUS, atol=0.5 * SPACING.max())


def test_normals_and_winding_face_outwards():
    volume = sphere_sdf()
    geometry = IsoSurfaceExtractor(iso_level=level_of(volume, 0.0)).process(volume, None)
    outward = (geometry.vertices - CENTRE) / np.linalg.norm(geometry.vertices - CENTRE, axis=1)[:, None]
    cosines = np.einsum("ij,ij->i", geometry.normals, outward)
    # the gradient of the sampled field in world units (measured: min 0.99997; scikit-image's own
    # normals, which ignore the anisotropic spacing, gave 0.90)
    assert cosines.min() > 0.999 and np.median(cosines) > 0.9999
    centroids = geometry.vertices[geometry.triangles].mean(axis=1) - CENTRE
    assert np.all(np.einsum("ij,ij->i", face_normals(geometry), centroids) > 0.0)  # counter-clockwise


def test_the_level_is_a_normalised_intensity_over_the_value_range():
    """A volume in data units (0 .. 1000 over 2 radii): level 0.25 is the data value 250."""
    distance = RADIUS - np.linalg.norm(world_grid() - CENTRE, axis=-1)
    volume = Volume((500.0 + 1000.0 * distance / (2 * RADIUS)).astype(np.float32), spacing=tuple(SPACING),
                    origin=tuple(ORIGIN), declared_range=(0.0, 1000.0))
    geometry = IsoSurfaceExtractor(iso_level=0.25).process(volume, None)
    # value 250 is where distance = -RADIUS / 2: a sphere of radius 1.5 RADIUS, cut by the box
    radii = np.linalg.norm(geometry.vertices - CENTRE, axis=1)
    assert np.abs(radii - 1.5 * RADIUS).max() < 0.5 * SPACING.min()


def test_the_region_cuts_the_surface_open_and_keeps_world_positions():
    volume = sphere_sdf()
    level = level_of(volume, 0.0)
    whole = IsoSurfaceExtractor(iso_level=level).process(volume, None)
    region_min = (float(CENTRE[0]), -1e9, -1e9)  # the half with x >= the centre
    half = IsoSurfaceExtractor(iso_level=level, region_min=region_min).process(volume, None)
    first_voxel = np.ceil((CENTRE[0] - ORIGIN[0]) / SPACING[0])
    assert half.vertices[:, 0].min() >= ORIGIN[0] + first_voxel * SPACING[0] - 1e-4
    assert np.abs(np.linalg.norm(half.vertices - CENTRE, axis=1) - RADIUS).max() < 0.5 * SPACING.min()
    assert 0.3 < len(half.triangles) / len(whole.triangles) < 0.6


def test_a_scalar_volume_colours_the_vertices_with_its_values():
    volume = sphere_sdf()
    height = Volume(world_grid()[..., 2].astype(np.float32), spacing=tuple(SPACING), origin=tuple(ORIGIN))
    geometry = IsoSurfaceExtractor(iso_level=level_of(volume, 0.0)).process(volume, height)
    np.testing.assert_allclose(geometry.scalars, geometry.vertices[:, 2], atol=1e-3)  # trilinear of a linear field


def test_a_level_the_data_never_reaches_is_refused_with_the_range():
    volume = sphere_sdf()
    extractor = IsoSurfaceExtractor("iso", iso_level=1.0)
    with pytest.raises(PropertyError, match=r"iso\.iso_level.*no surface at 1"):
        extractor.process(volume, None)
    with pytest.raises(PropertyError, match=r"iso\.region_min.*fewer than 2 voxels"):
        IsoSurfaceExtractor("iso", region_min=(1e6, 0.0, 0.0)).process(volume, None)


def test_the_extractor_runs_in_a_network_from_a_function_selector():
    from vgraph.network import Network
    network = Network()
    network.add("FunctionSelector", id="f", function="sphere", resolution=32)
    network.add("IsoSurfaceExtractor", id="iso", iso_level=0.5)
    network.connect("f.volume", "iso.volume")
    network.update("iso.geometry")
    geometry = network.output("iso.geometry")
    assert isinstance(geometry, Geometry) and len(geometry.triangles) > 100


# --- SurfaceSource ------------------------------------------------------------------------------
@pytest.mark.parametrize("extension", [".obj", ".stl", ".ply", ".off", ".vtk", ".vtu"])
def test_surface_files_read_back_as_the_mesh_that_was_written(tmp_path, extension):
    sphere = Geometry.sphere((1.0, -2.0, 3.0), 2.5, subdivisions=2)
    path = tmp_path / f"sphere{extension}"
    meshio.write_points_cells(path, sphere.vertices.astype(np.float64), [("triangle", sphere.triangles)],
                              **({"binary": False} if extension in (".stl", ".ply") else {}))
    geometry = SurfaceSource(path=str(path)).process()
    assert len(geometry.triangles) == len(sphere.triangles)
    np.testing.assert_allclose(np.linalg.norm(geometry.vertices - (1.0, -2.0, 3.0), axis=1), 2.5, atol=1e-5)
    centroids = geometry.vertices[geometry.triangles].mean(axis=1) - (1.0, -2.0, 3.0)
    assert np.all(np.einsum("ij,ij->i", face_normals(geometry), centroids) > 0.0)  # winding kept
    normals = geometry.vertex_normals()
    outward = (geometry.vertices - (1.0, -2.0, 3.0)) / 2.5
    assert np.einsum("ij,ij->i", normals, outward).min() > 0.95


def test_quads_become_two_triangles_and_unused_points_are_dropped(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 9 9 9\nf 1 2 3 4\n")
    geometry = read_surface(path)
    assert len(geometry.triangles) == 2 and len(geometry.vertices) == 4
    np.testing.assert_allclose(geometry.bounds[1], (1.0, 1.0, 0.0))
    np.testing.assert_allclose(geometry.vertex_normals(), [[0.0, 0.0, 1.0]] * 4, atol=1e-6)


def test_point_arrays_give_scalars_and_ply_colours_give_vertex_colours(tmp_path):
    sphere = Geometry.sphere((0.0, 0.0, 0.0), 1.0, subdivisions=1)
    count = len(sphere.vertices)
    vtk = tmp_path / "scalars.vtk"
    meshio.write_points_cells(vtk, sphere.vertices.astype(np.float64), [("triangle", sphere.triangles)],
                              point_data={"height": sphere.vertices[:, 2].astype(np.float64),
                                          "flow": np.tile([3.0, 4.0, 0.0], (count, 1))})
    np.testing.assert_allclose(read_surface(vtk).scalars, sphere.vertices[:, 2], atol=1e-6)  # the first
    np.testing.assert_allclose(read_surface(vtk, array="flow").scalars, 5.0)  # a vector's length
    with pytest.raises(MeshFileError, match=r"\[array\].*no point array 'pressure'.*height, flow"):
        read_surface(vtk, array="pressure")
    ply = tmp_path / "colours.ply"
    red = np.arange(count) % 256
    meshio.write_points_cells(ply, sphere.vertices.astype(np.float64), [("triangle", sphere.triangles)],
                              point_data={"red": red.astype(np.uint8), "green": np.zeros(count, np.uint8),
                                          "blue": np.full(count, 255, np.uint8)}, binary=False)
    colours = read_surface(ply).colors
    np.testing.assert_allclose(colours[:, 0], red / 255.0, atol=1e-6)
    np.testing.assert_allclose(colours[:, 2:], 1.0)


def test_bad_surface_files_are_refused_naming_the_file_and_the_problem(tmp_path):
    with pytest.raises(MeshFileError, match="missing.obj: file does not exist"):
        read_surface(tmp_path / "missing.obj")
    odd = tmp_path / "shape.xyz123"
    odd.write_text("nothing")
    with pytest.raises(MeshFileError, match="unknown surface format '.xyz123'"):
        read_surface(odd)
    damaged = tmp_path / "damaged.ply"
    damaged.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n")
    with pytest.raises(MeshFileError, match="damaged.ply: cannot read"):
        read_surface(damaged)
    tets = tmp_path / "tets.vtk"
    meshio.write_points_cells(tets, np.eye(4)[:, :3], [("tetra", np.array([[0, 1, 2, 3]]))])
    with pytest.raises(MeshFileError, match=r"no surface cells.*tetra.*MeshSource"):
        read_surface(tets)
    with pytest.raises(VGraphError, match=r"surf\.path: no surface file chosen"):
        SurfaceSource("surf").process()
