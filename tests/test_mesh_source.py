"""MeshSource and vgraph.io.meshes: real meshes (counts, volumes, faces that match between
neighbouring tetrahedra) and small meshes written with meshio for every kind of bad input."""

import importlib.util
import warnings
from collections import Counter

import meshio
import numpy as np
import pytest

import vgraph
from vgraph import ProcessorError, PropertyError, VGraphWarning
from vgraph.io.meshes import MeshFileError, read_mesh
from vgraph.mesh import TetMesh

HEX_FACES = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]


# --- helpers ---------------------------------------------------------------------------------------
def face_counts(tets: np.ndarray) -> np.ndarray:
    """How many tetrahedra hold each distinct triangle."""
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]])
    return np.unique(np.sort(faces, axis=1), axis=0, return_counts=True)[1]


def boundary_quads(cells: np.ndarray) -> int:
    quads = np.sort(np.concatenate([cells[:, list(f)] for f in HEX_FACES]), axis=1)
    return int(np.sum(np.unique(quads, axis=0, return_counts=True)[1] == 1))


def trilinear_hex_volumes(points: np.ndarray, hexes: np.ndarray) -> np.ndarray:
    """Volumes of hexahedra as trilinear maps of the unit cube: the integral of the Jacobian's
    determinant, exact with 2 x 2 x 2 Gauss points (it is of degree <= 2 in each variable).
    Independent of any split into tetrahedra."""
    corners = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                        [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)
    p = points.astype(np.float64)[hexes]
    total = np.zeros(len(hexes))
    for a in (-1, 1):
        for b in (-1, 1):
            for c in (-1, 1):
                u, v, w = np.array([a, b, c]) / np.sqrt(3.0)
                dn = np.stack([corners[:, 0] * (1 + corners[:, 1] * v) * (1 + corners[:, 2] * w),
                               corners[:, 1] * (1 + corners[:, 0] * u) * (1 + corners[:, 2] * w),
                               corners[:, 2] * (1 + corners[:, 0] * u) * (1 + corners[:, 1] * v)]) / 8
                total += np.linalg.det(np.einsum("dn,cnx->cdx", dn, p))
    return total


def grid(n: int, rng, jitter: float = 0.0):
    """Points of an (n+1)^3 grid numbered in random order, and index(i, j, k) -> point number."""
    ijk = np.stack(np.meshgrid(*[np.arange(n + 1)] * 3, indexing="ij"), -1).reshape(-1, 3).astype(float)
    ijk += rng.uniform(-jitter, jitter, ijk.shape) * (ijk > 0) * (ijk < n)  # a distorted interior
    order = rng.permutation(len(ijk))
    number = np.argsort(order)
    return ijk[order], lambda i, j, k: int(number[(i * (n + 1) + j) * (n + 1) + k])


def hex_cells(n, index):
    return np.array([[index(i + x, j + y, k + z) for z in (0, 1) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
                     for i in range(n) for j in range(n) for k in range(n)])


def write(tmp_path, name, points, cells, **data) -> str:
    path = tmp_path / name
    meshio.write(path, meshio.Mesh(points, cells, **data))
    return str(path)


def check_conforming(mesh: TetMesh) -> Counter:
    counts = Counter(face_counts(mesh.tets).tolist())
    assert set(counts) <= {1, 2}, f"triangles held by more than two tetrahedra: {counts}"
    assert np.all(mesh.tet_volumes() > 0)
    return counts


# --- the shared meshes -------------------------------------------------------------------------------
def test_the_tetrahedral_post_mesh_reads_whole(data_dir):
    mesh = read_mesh(data_dir / "tet_lox_post/post.vtk")
    assert (len(mesh.points), len(mesh.tets)) == (2288, 8750)
    assert mesh.scalar_name == "Pressure"
    reference = meshio.read(data_dir / "tet_lox_post/post.vtk")
    np.testing.assert_array_equal(mesh.scalars, reference.point_data["Pressure"].astype(np.float32))
    counts = check_conforming(mesh)
    assert counts[2] > 0 and counts[1] > 0
    assert mesh.tet_volumes().sum() == pytest.approx(abs(_signed(reference.points, reference.cells[0].data)).sum())


def _signed(points, tets):
    p = points.astype(np.float64)[tets]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6


def test_the_hexahedral_disk_splits_into_six_tetrahedra_per_cell_with_matching_faces(data_dir):
    mesh = read_mesh(data_dir / "hex_disk_out_ref/disk_out_ref.vtu")
    reference = meshio.read(data_dir / "hex_disk_out_ref/disk_out_ref.vtu")
    hexes = reference.cells[0].data
    assert (len(mesh.points), len(mesh.tets)) == (8499, 6 * 7472)
    assert mesh.scalar_name == "Temp"
    assert mesh.value_range == pytest.approx((293.15, 913.15))
    counts = check_conforming(mesh)
    # Each boundary quad of the hexahedra gives two boundary triangles; an interior quad split
    # differently by its two cells would add four more triangles held once.
    assert counts[1] == 2 * boundary_quads(hexes)
    assert mesh.tet_volumes().sum() == pytest.approx(trilinear_hex_volumes(reference.points, hexes).sum(),
                                                     rel=1e-9)


def test_other_arrays_and_cell_arrays_are_chosen_by_name(data_dir):
    path = data_dir / "hex_disk_out_ref/disk_out_ref.vtu"
    reference = meshio.read(path)
    pres = read_mesh(path, array="Pres")
    np.testing.assert_array_equal(pres.scalars, reference.point_data["Pres"].astype(np.float32))
    speed = read_mesh(path, array="V")  # a vector gives its length
    np.testing.assert_allclose(speed.scalars, np.linalg.norm(reference.point_data["V"], axis=1), rtol=1e-6)
    ids = reference.cell_data["ObjectId"][0].astype(float)
    for name in ("cell:ObjectId", "ObjectId"):  # no point array has that name: the cell array
        objects = read_mesh(path, array=name)  # one value per cell, each of its 6 tetrahedra has it
        assert objects.per_cell and objects.scalar_name == "cell:ObjectId"
        np.testing.assert_array_equal(objects.scalars, np.repeat(ids, 6).astype(np.float32))
    averaged = read_mesh(path, array="cell:ObjectId", cell_arrays="averaged")
    assert not averaged.per_cell and len(averaged.scalars) == len(averaged.points)
    assert averaged.scalars.min() >= ids.min() and averaged.scalars.max() <= ids.max()
    with pytest.raises(MeshFileError, match=r"disk_out_ref.vtu \[array\]: no array 'Nope'; the file has "
                                            r"point arrays 'Temp', 'V', 'Pres', .*; cell array 'ObjectId'"):
        read_mesh(path, array="Nope")


def test_exodus_reads_where_netcdf4_is_installed_and_says_to_install_it_elsewhere(data_dir):
    path = data_dir / "hex_disk_out_ref/disk_out_ref.ex2"
    if importlib.util.find_spec("netCDF4") is None:
        with pytest.raises(MeshFileError, match="needs the netCDF4 package.*pip install netCDF4"):
            read_mesh(path)
    else:  # the .vtu copy holds the same points (in another order) and values
        copy = read_mesh(data_dir / "hex_disk_out_ref/disk_out_ref.vtu", array="V")
        mesh = read_mesh(path, array="V")
        assert (len(mesh.points), len(mesh.tets), mesh.scalar_name) == (8499, 6 * 7472, "V")
        check_conforming(mesh)
        ours, theirs = np.lexsort(mesh.points.T), np.lexsort(copy.points.T)
        np.testing.assert_array_equal(mesh.points[ours], copy.points[theirs])
        np.testing.assert_array_equal(mesh.scalars[ours], copy.scalars[theirs])
        assert mesh.tet_volumes().sum() == pytest.approx(copy.tet_volumes().sum())


def test_mesh_source_in_a_network(data_dir):
    net = vgraph.Network()
    net.add("MeshSource", id="ms", path=str(data_dir / "hex_disk_out_ref/disk_out_ref.vtu"),
            array="Pres", value_range=(0.0, 1.0), reference_length=0.5)
    net.update("ms.mesh")
    mesh = net.output("ms.mesh")
    assert isinstance(mesh, TetMesh) and mesh.scalar_name == "Pres"
    assert mesh.value_range == (0.0, 1.0) and mesh.opacity_length == 0.5
    net.set("ms.reference_length", 0.0)  # 0: the mean edge length
    net.set("ms.value_range", None)
    net.update("ms.mesh")
    mesh = net.output("ms.mesh")
    assert mesh.opacity_length == pytest.approx(mesh.mean_edge_length)
    assert type(net.processors["ms"]).category == "Mesh"


# --- synthetic meshes: splitting ---------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(4))
def test_hexahedra_numbered_at_random_split_with_matching_faces(tmp_path, seed):
    rng = np.random.default_rng(seed)
    points, index = grid(3, rng, jitter=0.2)
    hexes = hex_cells(3, index)
    mesh = read_mesh(write(tmp_path, "grid.vtu", points, [("hexahedron", hexes)],
                           point_data={"f": points[:, 0]}))
    assert len(mesh.tets) == 6 * 27
    counts = check_conforming(mesh)
    assert counts[1] == 2 * boundary_quads(hexes)
    assert mesh.tet_volumes().sum() == pytest.approx(27.0)


@pytest.mark.parametrize("seed", range(6))
def test_wedges_and_pyramids_split_into_three_and_two_with_matching_faces(tmp_path, seed):
    """A 3 x 2 x 2 box: prisms (squares cut along a random diagonal, extruded in z) for x < 2, and
    for x > 2 cubes cut into six pyramids from their centres, so that prisms and pyramids meet in
    quads at x = 2, pyramids meet each other in quads at z = 1, prisms each other in triangles."""
    rng = np.random.default_rng(seed)
    ijk = np.stack(np.meshgrid(np.arange(4), np.arange(3), np.arange(3), indexing="ij"), -1).reshape(-1, 3)
    order = rng.permutation(len(ijk))
    number = np.argsort(order)
    points = [*ijk[order].astype(float)]
    at = lambda i, j, k: int(number[(i * 3 + j) * 3 + k])  # noqa: E731
    wedges, pyramids = [], []
    for i in range(2):
        for j in range(2):
            square = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
            if rng.random() < 0.5:
                triangles = [square[:3], [square[0], square[2], square[3]]]
            else:
                triangles = [[square[0], square[1], square[3]], square[1:]]
            for k in range(2):
                wedges += [[at(x, y, k) for x, y in t] + [at(x, y, k + 1) for x, y in t] for t in triangles]
    for j in range(2):
        for k in range(2):
            c = [at(2 + x, j + y, k + z) for z in (0, 1) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
            points.append(np.array([2.5, j + 0.5, k + 0.5]))
            pyramids += [[*[c[v] for v in face], len(points) - 1] for face in HEX_FACES]
    points = np.array(points)
    mesh = read_mesh(write(tmp_path, "mixed.vtu", points,
                           [("wedge", np.array(wedges)), ("pyramid", np.array(pyramids))],
                           point_data={"f": points[:, 2]}))
    assert len(mesh.tets) == 3 * len(wedges) + 2 * len(pyramids)
    counts = check_conforming(mesh)
    assert counts[1] == 2 * 2 * (3 * 2 + 3 * 2 + 2 * 2)  # the box's 32 unit squares, two triangles each
    assert mesh.tet_volumes().sum() == pytest.approx(12.0)


def test_a_quadratic_tetrahedron_splits_into_eight_over_all_its_nodes(tmp_path):
    rng = np.random.default_rng(1)
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]  # VTK_QUADRATIC_TETRA's mid-nodes
    mids = np.array([(corners[a] + corners[b]) / 2 for a, b in edges]) + rng.normal(0, 0.01, (6, 3))
    points = np.concatenate([corners, mids])
    mesh = read_mesh(write(tmp_path, "quadratic.vtu", points, [("tetra10", np.arange(10)[None])],
                           point_data={"f": np.arange(10.0)}))
    assert len(mesh.tets) == 8 and len(mesh.points) == 10
    np.testing.assert_array_equal(np.sort(mesh.scalars), np.arange(10.0))  # mid-node values kept
    check_conforming(mesh)
    corner_tets = [t for t in mesh.tets if np.sum(t < 4) == 1]  # a corner and its three mid-nodes
    assert sorted(int(t[t < 4][0]) for t in corner_tets) == [0, 1, 2, 3]
    # The 8 fill the cell (its curved edges are straightened through the mid-nodes, so the sum of
    # their volumes is the corner tetrahedron's volume only up to the mid-nodes' offsets).
    assert mesh.tet_volumes().sum() == pytest.approx(1 / 6, rel=0.1)


def test_higher_order_cells_other_than_tetra10_say_they_use_their_corners(tmp_path):
    points, index = grid(1, np.random.default_rng(0))
    hexes = hex_cells(1, index)
    extra = np.arange(len(points), len(points) + 12)
    points = np.concatenate([points, np.random.default_rng(1).uniform(0.2, 0.8, (12, 3))])
    path = write(tmp_path, "hex20.vtu", points, [("hexahedron20", np.concatenate([hexes, extra[None]], axis=1))],
                 point_data={"f": np.arange(len(points), dtype=float)})
    with pytest.warns(VGraphWarning, match=r"hexahedron20 cells are drawn as linear cells through their corner nodes"):
        mesh = read_mesh(path, array="f")
    assert len(mesh.tets) == 6 and len(mesh.points) == 8


def test_negative_tetrahedra_are_turned_and_flat_ones_dropped_with_a_count(tmp_path):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]], dtype=float)
    tets = np.array([[0, 2, 1, 3],   # negative
                     [0, 1, 2, 4]])  # flat: four points in z = 0
    with pytest.warns(VGraphWarning, match="1 of 2 tetrahedra have zero volume"):
        mesh = read_mesh(write(tmp_path, "t.vtk", points, [("tetra", tets)], point_data={"f": np.arange(5.0)}))
    assert len(mesh.tets) == 1 and mesh.tet_volumes()[0] == pytest.approx(1 / 6)
    assert len(mesh.points) == 4  # point 4 was used only by the flat tetrahedron
    for p in mesh.tets[0]:  # every point kept its own scalar
        assert mesh.scalars[p] == np.flatnonzero((points == mesh.points[p]).all(axis=1))[0]


def test_lines_and_triangles_beside_the_cells_are_ignored_and_so_are_their_points(tmp_path):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [9, 9, 9]], dtype=float)
    mesh = read_mesh(write(tmp_path, "t.vtu", points, [("triangle", np.array([[0, 1, 4]])),
                                                       ("tetra", np.array([[0, 1, 2, 3]]))],
                           point_data={"f": np.arange(5.0)}))
    assert len(mesh.tets) == 1 and mesh.bounds[1].tolist() == [1, 1, 1]


def write_xdmf(path, points, hexes, values):
    """XDMF with the data inline as XML (meshio's XDMF writer needs h5py; its reader does not)."""
    def text(array):
        return "\n".join(" ".join(repr(v) for v in row) for row in np.atleast_2d(array).tolist())
    path.write_text(f"""<?xml version="1.0"?>
<Xdmf Version="3.0"><Domain><Grid Name="mesh" GridType="Uniform">
<Topology TopologyType="Hexahedron" NumberOfElements="{len(hexes)}">
<DataItem Dimensions="{len(hexes)} 8" NumberType="Int" Format="XML">{text(hexes)}</DataItem></Topology>
<Geometry GeometryType="XYZ">
<DataItem Dimensions="{len(points)} 3" NumberType="Float" Precision="8" Format="XML">{text(points)}</DataItem>
</Geometry>
<Attribute Name="f" AttributeType="Scalar" Center="Node">
<DataItem Dimensions="{len(values)}" NumberType="Float" Precision="8" Format="XML">{text(values)}</DataItem>
</Attribute></Grid></Domain></Xdmf>
""")


@pytest.mark.parametrize("name,kwargs", [("t.msh", {"file_format": "gmsh22"}), ("t.mesh", {}),
                                         ("t.xdmf", None), ("t.vtk", {"binary": False})])
def test_formats_meshio_writes_read_back(tmp_path, name, kwargs):
    rng = np.random.default_rng(0)
    points, index = grid(2, rng)
    hexes = hex_cells(2, index)
    path = tmp_path / name
    if kwargs is None:
        write_xdmf(path, points, hexes, points[:, 1])
        if importlib.util.find_spec("h5py") is None:  # meshio 5.3's XDMF reader imports it always
            with pytest.raises(MeshFileError, match="t.xdmf: reading xdmf files needs the h5py package, "
                                                    "which is not installed: pip install h5py"):
                read_mesh(path)
            return
    else:
        meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"f": points[:, 1]}),
                     **kwargs)
    if name == "t.mesh":  # Medit stores no data arrays, only reference numbers
        with pytest.warns(VGraphWarning, match="no data arrays; rendering the point tags 'medit:ref'"):
            mesh = read_mesh(path)
    else:
        mesh = read_mesh(path, array="f")
    assert len(mesh.tets) == 48
    check_conforming(mesh)
    assert mesh.tet_volumes().sum() == pytest.approx(8.0)


# --- synthetic meshes: bad input ---------------------------------------------------------------------
ONE_TET = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float), np.array([[0, 1, 2, 3]]))


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(MeshFileError, match=r"nothing.vtu: file does not exist"):
        read_mesh(tmp_path / "nothing.vtu")


@pytest.mark.parametrize("name,kwargs", [("t.vtu", {}), ("t.vtk", {"binary": True}), ("t.msh", {"file_format": "gmsh22"})])
def test_a_truncated_file_is_named(tmp_path, name, kwargs):
    rng = np.random.default_rng(0)
    points, index = grid(3, rng)
    path = tmp_path / name
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hex_cells(3, index))], point_data={"f": points[:, 0]}),
                 **kwargs)
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])
    with pytest.raises(MeshFileError, match=rf"{name}: "):
        read_mesh(path)


@pytest.mark.parametrize("content", [b"", b"\x00\xff garbage \x01" * 50, b"# vtk DataFile Version 2.0\nbroken\n"])
def test_an_unreadable_file_is_named(tmp_path, content):
    path = tmp_path / "bad.vtk"
    path.write_bytes(content)
    with pytest.raises(MeshFileError, match=r"bad.vtk: cannot read the mesh"):
        read_mesh(path)


def test_an_unknown_extension_lists_the_known_ones(tmp_path):
    path = tmp_path / "mesh.xyz"
    path.write_text("1 2 3\n")
    with pytest.raises(MeshFileError, match=r"mesh.xyz: unknown mesh format '.xyz': expected one of .vtk, .vtu"):
        read_mesh(path)


def test_a_mesh_without_3d_cells_says_what_it_holds(tmp_path):
    points, _ = ONE_TET
    path = write(tmp_path, "surface.vtu", points, [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))],
                 point_data={"f": np.arange(4.0)})
    with pytest.raises(MeshFileError, match=r"surface.vtu \[cells\]: no 3D cells .*: the file holds triangle"):
        read_mesh(path)


def test_a_missing_array_lists_the_arrays_there_are(tmp_path):
    points, tets = ONE_TET
    path = write(tmp_path, "t.vtu", points, [("tetra", tets)], point_data={"a": np.zeros(4), "b": np.ones(4)},
                 cell_data={"c": [np.array([7.0])]})
    with pytest.raises(MeshFileError, match=r"\[array\]: no array 'z'; the file has point arrays 'a', 'b'; "
                                            r"cell array 'c'"):
        read_mesh(path, array="z")
    with pytest.raises(MeshFileError, match=r"\[array\]: no cell array 'z'; the file has point arrays 'a', 'b'; "
                                            r"cell array 'c'"):
        read_mesh(path, array="cell:z")
    assert read_mesh(path, array="cell:c").scalars.tolist() == [7.0]  # one tetrahedron, its value
    assert read_mesh(path, array="cell:c", cell_arrays="averaged").scalars.tolist() == [7.0] * 4


def test_a_mesh_without_point_arrays_renders_its_first_cell_array_and_says_so(tmp_path):
    points, tets = ONE_TET
    path = write(tmp_path, "t.vtu", points, [("tetra", tets)],
                 cell_data={"c": [np.array([7.0])], "d": [np.array([1.0])]})
    with pytest.warns(VGraphWarning, match=r"t.vtu: rendering the cell array \(constant in each cell\) 'c'; "
                                           r"the file also has cell array 'd'"):
        mesh = read_mesh(path)
    assert mesh.per_cell and mesh.scalar_name == "cell:c" and mesh.scalars.tolist() == [7.0]


def test_a_mesh_without_arrays_is_refused(tmp_path):
    points, tets = ONE_TET
    with pytest.raises(MeshFileError, match=r"t.vtu \[array\]: no array to render: the file has no arrays"):
        read_mesh(write(tmp_path, "t.vtu", points, [("tetra", tets)]))


def test_non_finite_coordinates_are_refused_naming_the_point(tmp_path):
    points, tets = ONE_TET
    points = points.copy()
    points[2, 1] = np.nan
    path = write(tmp_path, "t.vtu", points, [("tetra", tets)], point_data={"f": np.zeros(4)})
    with pytest.raises(MeshFileError, match=r"t.vtu \[points\]: 1 points used by cells have non-finite "
                                            r"coordinates \(the first is point 2"):
        read_mesh(path)


def test_indices_out_of_range_are_refused_naming_the_cell_block(tmp_path):
    points, _ = ONE_TET
    path = write(tmp_path, "t.vtu", points, [("tetra", np.array([[0, 1, 2, 3], [0, 1, 2, 9]]))],
                 point_data={"f": np.zeros(4)})
    with pytest.raises(MeshFileError, match=r"\[cell block 0 \(tetra\)\]: tetra cells refer to points 0 .. 9, "
                                            r"but the file has points 0 .. 3"):
        read_mesh(path)


def test_only_flat_cells_is_an_error(tmp_path):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    path = write(tmp_path, "flat.vtu", points, [("tetra", np.array([[0, 1, 2, 3]]))], point_data={"f": np.zeros(4)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", VGraphWarning)
        with pytest.raises(MeshFileError, match=r"flat.vtu \[cells\]: every tetrahedron has zero volume"):
            read_mesh(path)


def test_mesh_source_errors_name_processor_file_and_property(tmp_path):
    net = vgraph.Network()
    net.add("MeshSource", id="ms")
    with pytest.raises(ProcessorError, match=r"ms.path: no mesh file chosen"):
        net.update("ms.mesh")
    net.set("ms.path", str(tmp_path / "gone.vtk"))
    with pytest.raises(ProcessorError, match=r"processor 'ms' \(MeshSource\): .*gone.vtk: file does not exist"):
        net.update("ms.mesh")
    net.set("ms.value_range", (2.0, 1.0))
    with pytest.raises(PropertyError, match=r"ms.value_range: low must be below high"):
        net.processors["ms"].check()
