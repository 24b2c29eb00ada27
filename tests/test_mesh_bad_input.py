"""Meshes held to the promises files keep (issue 27, defect 5): geometry GL's float32 cannot hold is
refused naming the file and field, extreme but valid meshes render the picture an ordinary one
does (the camera is resolved in the mesh's normalised frame), multi-component arrays are chosen
by name or refused, and the readers' rules (regular files, counts checked before reading, no
cells refused) cover meshes. Every refusal reaches `vgraph run` as exit 2 with the message."""

import json
import os
import re
import warnings

import meshio
import numpy as np
import pytest

import vgraph
from vgraph.cli import main
from vgraph.io.meshes import MeshFileError, read_mesh
from vgraph.io.surfaces import read_surface
from vgraph.scheduler import BlankImageWarning
from vgraph.testing import GivenVolume
from vgraph.volume import Volume

CUBE = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
HEX = [("hexahedron", np.array([[0, 1, 3, 2, 4, 5, 7, 6]]))]
VALUES = CUBE @ [1.0, 2.0, 4.0]  # a different value at every corner
SIZE = (40, 40)


def write(folder, name, points=CUBE, cells=HEX, file_format=None, binary=None, **data):
    data.setdefault("point_data", {"f": VALUES})
    path = folder / name
    options = {} if binary is None else {"binary": binary}
    meshio.write(path, meshio.Mesh(points, cells, **data), file_format=file_format, **options)
    return path


def network_file(folder, mesh_name: str, **source) -> str:
    document = {"format": "vgraph-network", "version": 2, "processors": [
        {"id": "source", "type": "MeshSource", "properties": {"path": mesh_name, **source}},
        {"id": "pt", "type": "ProjectedTetrahedra", "properties": {}},
        {"id": "canvas", "type": "Canvas", "properties": {"size": list(SIZE)}}],
        "connections": [{"from": "source.mesh", "to": "pt.mesh"}, {"from": "pt.image", "to": "canvas.image"}]}
    path = folder / "mesh.json"
    path.write_text(json.dumps(document))
    return str(path)


def run(folder, mesh_name: str, capsys, **source) -> tuple[int, str]:
    code = main(["run", network_file(folder, mesh_name, **source), "-o", str(folder / "out.png")])
    return code, capsys.readouterr().err


def render(path, **source) -> np.ndarray:
    network = vgraph.Network()
    network.add("MeshSource", id="source", path=str(path), **source)
    network.add("ProjectedTetrahedra", id="pt")
    network.connect("source.mesh", "pt.mesh")
    return network.evaluate("pt.image", size=SIZE)


# --- geometry: refused by name --------------------------------------------------------------------
def test_coordinates_of_1e30_are_refused_naming_the_file_and_the_limit(tmp_path, capsys):
    write(tmp_path, "big.vtu", CUBE * 1e30)
    code, err = run(tmp_path, "big.vtu", capsys)
    assert code == 2, err
    assert "big.vtu [points]: coordinates reach 1e+30" in err and "+-1e+15" in err
    assert "ValidationError" not in err and "Traceback" not in err


def test_a_mesh_1e_30_across_is_refused_naming_its_scale(tmp_path, capsys):
    write(tmp_path, "tiny.vtu", CUBE * 1e-30)
    code, err = run(tmp_path, "tiny.vtu", capsys)
    assert code == 2, err
    assert re.search(r"tiny.vtu \[points\]: the cells are [\d.]+e-30 across \(their median edge\), "
                     r"below the 1e-15", err)


def test_cells_too_small_for_float32_at_their_distance_from_the_origin_are_refused(tmp_path, capsys):
    """A unit cube 1e14 from the origin: float32 (what the GL draws with) keeps about 7 digits, so
    its corners would collapse; the message says why and what to do, not 'the cells are flat'."""
    write(tmp_path, "far.vtu", CUBE + 1e14)
    code, err = run(tmp_path, "far.vtu", capsys)
    assert code == 2, err
    assert re.search(r"far.vtu \[points\]: the cells \([\d.]+ across\) are too small for the float32 "
                     r"coordinates the GL draws with at 1e\+14 from the origin", err)
    assert "move the mesh nearer the origin" in err


def test_surfaces_get_the_same_geometry_checks(tmp_path):
    triangles = [("triangle", np.array([[0, 1, 2], [1, 3, 2]]))]
    with pytest.raises(MeshFileError, match=r"big.vtk \[points\]: coordinates reach 1e\+30"):
        read_surface(write(tmp_path, "big.vtk", CUBE[:4] * 1e30, triangles, point_data={}))
    with pytest.raises(MeshFileError, match=r"tiny.vtk \[points\]: the cells are [\d.]+e-30 across"):
        read_surface(write(tmp_path, "tiny.vtk", CUBE[:4] * 1e-30, triangles, point_data={}))


# --- geometry: extreme but valid meshes render the ordinary picture -------------------------------
@pytest.mark.parametrize("scale, offset", [(1e-12, 0.0), (1e-12, 5e-12), (3e-15, -2e-15),
                                           (1e13, 5e14), (4e14, 5e14), (1e3, -4e5)])
def test_extreme_but_valid_meshes_render_the_picture_of_the_unit_mesh(tmp_path, scale, offset):
    """The default camera fits the data, so every scaled and moved copy of the cube frames alike.
    Before, 1e-12 rendered a flat image (the camera framed a sphere of at least 1e-6) and 4e14
    raised pydantic's ValidationError (the framed camera lay beyond +-1e15)."""
    expected = render(write(tmp_path, "unit.vtu"))
    assert expected[..., :3].max() > 0.1
    image = render(write(tmp_path, "moved.vtu", CUBE * scale + offset))
    assert np.abs(image - expected).max() < 2e-3


@pytest.mark.parametrize("scale, offset", [(1e-12, 5e-12), (4e14, 5e14)])
def test_extreme_but_valid_surfaces_render_the_picture_of_the_unit_surface(tmp_path, scale, offset):
    """The GeometryRenderer without a volume frames the surface the same way: before, 4e14 raised
    pydantic's ValidationError (exit 1) and 1e-12 rendered only the background."""
    def image(points):
        path = write(tmp_path, "s.vtk", points, [("triangle", np.array([[0, 1, 3], [0, 3, 2], [0, 4, 5]]))],
                     point_data={})
        network = vgraph.Network()
        network.add("SurfaceSource", id="source", path=str(path))
        network.add("GeometryRenderer", id="gr")
        network.connect("source.geometry", "gr.geometry")
        return network.evaluate("gr.image", size=SIZE), network.evaluate("gr.depth", size=SIZE)
    (expected, expected_depth), (moved, depth) = image(CUBE), image(CUBE * scale + offset)
    assert expected[..., :3].max() > 0.1
    assert np.abs(moved - expected).max() < 2e-3
    hit = expected_depth[..., 3] == 1.0
    np.testing.assert_allclose(depth[..., 1][hit], expected_depth[..., 1][hit] * scale, rtol=1e-4)


def test_an_extreme_mesh_gives_depth_and_view_camera_in_world_units(tmp_path):
    """Drawn in its box's normalised frame, the mesh still reports world units: the depth image's
    distance (g) scales with the mesh, the window depth (r) does not, and the view camera (what
    the GUI turns) looks at the mesh where it is."""
    def depth_and_camera(path):
        network = vgraph.Network()
        network.add("MeshSource", id="source", path=str(path))
        network.add("ProjectedTetrahedra", id="pt")
        network.connect("source.mesh", "pt.mesh")
        return network.evaluate("pt.depth", size=SIZE), network["pt"].view_camera
    scale, offset = 1e-12, 5e-12
    expected, _ = depth_and_camera(write(tmp_path, "unit.vtu"))
    depth, camera = depth_and_camera(write(tmp_path, "tiny.vtu", CUBE * scale + offset))
    hit = expected[..., 3] == 1.0
    assert hit.sum() > 100 and np.array_equal(depth[..., 3] == 1.0, hit)
    np.testing.assert_allclose(depth[..., 0][hit], expected[..., 0][hit], atol=1e-5)
    np.testing.assert_allclose(depth[..., 1][hit], expected[..., 1][hit] * scale, rtol=1e-4)
    assert not camera.fit_to_data
    np.testing.assert_allclose(camera.focus, 0.5 * scale + offset, rtol=1e-6)  # float32 points


def test_a_tetrahedralised_volume_of_tiny_spacing_renders_like_an_ordinary_one():
    """VolumeToTetMesh's grid (drawn cell by cell) is moved into the frame with the points."""
    def image(spacing):
        network = vgraph.Network()
        values = np.arange(64, dtype=np.float32).reshape(4, 4, 4)
        network.add(GivenVolume(id="src", volume=Volume(values, spacing=(spacing,) * 3)))
        network.add("VolumeToTetMesh", id="tets")
        network.add("ProjectedTetrahedra", id="pt", transfer_function="grayscale")
        network.connect("src.volume", "tets.volume")
        network.connect("tets.mesh", "pt.mesh")
        return network.evaluate("pt.image", size=SIZE)
    expected = image(1.0)
    assert expected[..., :3].max() > 0.1
    assert np.abs(image(1e-12) - expected).max() < 2e-3


def test_a_stored_camera_far_from_a_tiny_mesh_sees_a_speck_and_says_so(tmp_path):
    """Too far to be held in the mesh's frame, the camera is resolved in world units: no error,
    the mesh is below a pixel, and the blank image is reported."""
    network = vgraph.Network()
    network.add("MeshSource", id="source", path=str(write(tmp_path, "tiny.vtu", CUBE * 1e-14)))
    network.add("ProjectedTetrahedra", id="pt", camera={"position": [0.0, 0.0, 100.0]})
    network.connect("source.mesh", "pt.mesh")
    with pytest.warns(BlankImageWarning, match=r"pt \(ProjectedTetrahedra\) rendered an empty image"):
        network.evaluate("pt.image", size=SIZE)


def test_a_mesh_that_renders_empty_although_visible_warns_naming_the_renderer(tmp_path):
    network = vgraph.Network()
    network.add("MeshSource", id="source", path=str(write(tmp_path, "unit.vtu")))
    network.add("ProjectedTetrahedra", id="pt",
                camera={"position": [0.5, 0.5, 5.0], "focus": [0.5, 0.5, 10.0]})  # looks away
    network.connect("source.mesh", "pt.mesh")
    with pytest.warns(BlankImageWarning, match=r"pt \(ProjectedTetrahedra\) rendered an empty image "
                                               r"although \d+% of the tetrahedra are visible"):
        network.evaluate("pt.image", size=SIZE)


# --- multi-component arrays -----------------------------------------------------------------------
def two_components():
    return np.stack([VALUES, 10.0 - VALUES], axis=1)


def test_two_component_point_data_is_refused_naming_the_array_and_how_to_choose(tmp_path, capsys):
    write(tmp_path, "two.vtu", point_data={"v": two_components()})
    code, err = run(tmp_path, "two.vtu", capsys)
    assert code == 2, err
    assert ("two.vtu [array 'v']: 2 components per point: choose one with the component "
            "property (0 .. 1, X, Y) or 'magnitude'") in err


@pytest.mark.parametrize("component, expected", [
    ("0", lambda v: v[:, 0]), ("1", lambda v: v[:, 1]), ("Y", lambda v: v[:, 1]),
    ("magnitude", lambda v: np.linalg.norm(v, axis=1))])
def test_a_component_is_chosen_by_name_or_index(tmp_path, component, expected):
    path = write(tmp_path, "two.vtu", point_data={"v": two_components()})
    network = vgraph.Network()
    network.add("MeshSource", id="source", path=str(path), component=component)
    network.update("source.mesh")
    mesh = network.output("source.mesh")
    order = np.argsort(mesh.points @ [1.0, 10.0, 100.0])  # the points in the file's order
    np.testing.assert_allclose(mesh.scalars[order], expected(two_components()), rtol=1e-6)


def test_a_three_component_vector_gives_its_magnitude_unless_a_component_is_chosen(tmp_path):
    vectors = np.stack([VALUES, 2 * VALUES, -VALUES], axis=1)
    path = write(tmp_path, "v.vtu", point_data={"v": vectors})
    assert np.allclose(np.sort(read_mesh(path).scalars), np.sort(np.linalg.norm(vectors, axis=1)))
    assert np.allclose(np.sort(read_mesh(path, component="z").scalars), np.sort(-VALUES))


@pytest.mark.parametrize("component", ["2", "-1", "w", "1.5"])
def test_a_component_the_array_does_not_have_is_refused(tmp_path, component):
    path = write(tmp_path, "two.vtu", point_data={"v": two_components()})
    with pytest.raises(MeshFileError, match=rf"\[array 'v'\]: no component {component!r}: the array "
                                            rf"has 2 components per point \(0 .. 1, X, Y\)"):
        read_mesh(path, component=component)


def test_a_component_of_a_scalar_array_is_refused(tmp_path):
    with pytest.raises(MeshFileError, match=r"\[array 'f'\]: the array has one value per point: "
                                            r"leave component empty"):
        read_mesh(write(tmp_path, "one.vtu"), component="1")


def test_multi_component_cell_arrays_follow_the_same_rule(tmp_path):
    path = write(tmp_path, "c.vtu", cell_data={"c": [np.array([[1.0, 2.0]])]})
    with pytest.raises(MeshFileError, match=r"\[array 'cell:c'\]: 2 components per cell: choose one"):
        read_mesh(path, array="cell:c")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vgraph.VGraphWarning)
        assert np.allclose(read_mesh(path, array="cell:c", component="1").scalars, 2.0)


# --- the readers' rules ---------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["fifo", "dev_zero_link", "folder"])
def test_only_regular_files_are_read(tmp_path, capsys, kind):
    name = "m.vtk"
    if kind == "fifo":
        os.mkfifo(tmp_path / name)
    elif kind == "dev_zero_link":
        os.symlink("/dev/zero", tmp_path / name)
    else:
        (tmp_path / name).mkdir()
    code, err = run(tmp_path, name, capsys)
    assert code == 2, err
    assert f"{name}: file is not a regular file" in err


@pytest.mark.parametrize("declaration, field", [
    ("POINTS 100000000000000 float", "POINTS"), ("CELLS 4000000000000 20000000000000", "CELLS")])
def test_counts_a_small_vtk_file_cannot_hold_are_refused_before_reading(tmp_path, declaration, field):
    lines = ["# vtk DataFile Version 4.2", "t", "ASCII", "DATASET UNSTRUCTURED_GRID",
             "POINTS 4 float", "0 0 0 1 0 0 0 1 0 0 0 1", "CELLS 1 5", "4 0 1 2 3",
             "CELL_TYPES 1", "10", ""]
    lines[[i for i, line in enumerate(lines) if line.startswith(field)][0]] = declaration
    path = tmp_path / "lie.vtk"
    path.write_text("\n".join(lines))
    with pytest.raises(MeshFileError, match=rf"lie.vtk \[{field}\]: the file declares "
                                            rf"\d+ .* but holds only {path.stat().st_size} bytes"):
        read_mesh(path)


def test_a_mesh_larger_than_the_memory_available_is_refused_before_reading(tmp_path, monkeypatch):
    path = write(tmp_path, "m.vtu")
    monkeypatch.setattr("vgraph.memory.available_memory", lambda: 100)
    with pytest.raises(MeshFileError, match=r"m.vtu \[NumberOfPoints\]: too large for memory: "
                                            r"loading needs .* but only 100 bytes is available"):
        read_mesh(path)


def test_a_mesh_without_cells_is_refused_by_vgraph_run(tmp_path, capsys):
    write(tmp_path, "none.vtu", cells=[("tetra", np.zeros((0, 4), dtype=int))])
    code, err = run(tmp_path, "none.vtu", capsys)
    assert code == 2, err
    assert 'none.vtu [cells]: no cells: the file declares NumberOfCells 0' in err


def test_nan_coordinates_are_refused_by_vgraph_run(tmp_path, capsys):
    points = CUBE.copy()
    points[3, 2] = np.inf
    write(tmp_path, "nan.vtu", points)
    code, err = run(tmp_path, "nan.vtu", capsys)
    assert code == 2, err
    assert "nan.vtu [points]: 1 points used by cells have non-finite coordinates" in err


# --- found by the mesh fuzz target (bench/fuzz.py --target mesh) ------------------------------------
def gmsh_text(folder, version: str) -> str:
    path = write(folder, "g.msh", file_format="gmsh22" if version == "2.2" else "gmsh", binary=False,
                 point_data={})
    return path.read_text()


def test_a_gmsh_data_block_claiming_two_billion_tags_is_refused_not_read_line_by_line(tmp_path):
    """meshio read 2147483648 string tags one readline() at a time: the case hung."""
    text = gmsh_text(tmp_path, "2.2") + '$NodeData\n2147483648\n"s"\n1\n0.0\n3\n0\n1\n8\n$EndNodeData\n'
    path = tmp_path / "tags.msh"
    path.write_text(text)
    with pytest.raises(MeshFileError, match=r"tags.msh \[\$NodeData\]: the file declares 2147483648 "
                                            r"string tags .* but holds only \d+ bytes"):
        read_mesh(path)


@pytest.mark.parametrize("binary", [False, True])
def test_a_node_tag_far_beyond_the_file_is_refused_before_meshio_builds_its_table(tmp_path, binary):
    """meshio maps Gmsh node tags to points with a table as long as the largest tag: one tag flipped
    to 2^27 in a 1 KB file cost 1 GiB of memory (and 2^32 would have cost 32 GiB)."""
    path = write(tmp_path, "g.msh", file_format="gmsh", binary=binary, point_data={})
    content = path.read_bytes()
    nodes = content.index(b"$Nodes\n") + len(b"$Nodes\n")
    if binary:  # 4 size_t of header, 3 int32 and a size_t of the first block, then its tags
        first_tag = nodes + 32 + 12 + 8
        content = content[:first_tag] + (2**27).to_bytes(8, "little") + content[first_tag + 8:]
    else:  # the first line holding one integer is the first node's tag
        lines = content[nodes:].split(b"\n")
        first = next(i for i, line in enumerate(lines) if line.strip().isdigit())
        lines[first] = str(2**27).encode()
        content = content[:nodes] + b"\n".join(lines)
    path.write_bytes(content)
    with pytest.raises(MeshFileError, match=r"g.msh \[\$Nodes\]: node tag 134217728 is beyond what a "
                                            r"file of \d+ bytes numbers"):
        read_mesh(path)


def test_meshio_warnings_come_back_as_one_shortened_vgraph_warning_naming_the_file(tmp_path, capfd):
    """meshio printed its warnings with rich straight to the terminal, and spent seconds
    highlighting a 5000-digit line of a damaged file (the case failed the 3 s limit)."""
    path = tmp_path / "open.msh"
    path.write_text(gmsh_text(tmp_path, "2.2") + "$" + "9" * 5000 + "\n")  # a section never closed
    capfd.readouterr()
    with pytest.warns(vgraph.VGraphWarning, match=r"open.msh: meshio: \$9{190,} \.\.\.") as record:
        mesh = read_mesh(path)  # only Gmsh's tags: the first is rendered, and a warning says so
    assert mesh.scalar_name == "cell:gmsh:physical"
    assert any("no data arrays; rendering the cell tags 'gmsh:physical'" in str(w.message) for w in record)
    assert all(len(str(w.message)) < 600 for w in record)
    assert capfd.readouterr().err == ""


def test_cells_that_repeat_a_corner_and_split_into_nothing_are_refused(tmp_path):
    degenerate = [("hexahedron", np.array([[0, 4, 6, 2, 1, 5, 0, 3]]))]
    with pytest.raises(MeshFileError, match=r"\[cells\]: no tetrahedra: every cell repeats a corner"):
        read_mesh(write(tmp_path, "d.vtk", cells=degenerate))


@pytest.mark.parametrize("corners, reason", [
    (np.zeros((5, 0), dtype=int), r"expected 4 point numbers per cell, got an array of shape \(5, 0\)"),
    (np.array([[0.5, 1, 2, 3]]), r"point numbers must be integers, got float64 values")])
def test_cell_blocks_meshio_makes_of_damaged_files_are_refused_naming_the_block(tmp_path, monkeypatch,
                                                                                 corners, reason):
    monkeypatch.setattr("vgraph.io.meshes.read_meshio",
                        lambda path: meshio.Mesh(CUBE[:4], [("tetra", corners)]))
    with pytest.raises(MeshFileError, match=r"\[cell block 0 \(tetra\)\]: " + reason):
        read_mesh(write(tmp_path, "m.vtu"))
