"""Meshes through the same door as volumes (issue 28, defect 5): `vgraph run MESH` renders the
standard mesh network (vgraph.mesh_network), choosing a point array, else a cell array, and saying
which; a cell array is constant inside each cell, checked against the exact CPU reference, where
averaging it to the points would blur it; 10-node tetrahedra are split into 8 over all their
nodes; a mesh without arrays, or a name it lacks, exits 2 listing what it has."""

from __future__ import annotations

import warnings

import meshio
import numpy as np
import pytest

import vgraph
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
from vgraph.io.meshes import read_mesh
from vgraph.mesh import TetMesh
from vgraph.mesh_network import is_mesh_path, mesh_network
from vgraph.numerics import reference_tetra
from vgraph.processors.projected_tetrahedra import DEFAULT_TRANSFER_FUNCTION, ProjectedTetrahedra
from vgraph.tetrahedralize import split_cells, volume_tetrahedra
from vgraph.transfer_function import TransferFunction

from helpers.paths import DATA, REPO

SIZE = (64, 64)
TETRA10_EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]  # VTK_QUADRATIC_TETRA's mid-nodes


# --- meshes made with meshio -------------------------------------------------------------------------
def box_hexes(n: int, size: float = 2.0, origin=(-1.0, -1.0, -1.0)):
    """Points of an (n+1)^3 grid over a cube and its n^3 hexahedra (VTK corner order)."""
    axis = np.linspace(0.0, size, n + 1)
    points = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3) + origin
    index = lambda i, j, k: (i * (n + 1) + j) * (n + 1) + k  # noqa: E731
    hexes = np.array([[index(i + x, j + y, k + z) for z in (0, 1) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
                      for i in range(n) for j in range(n) for k in range(n)])
    return points, hexes


def write(path, points, cells, **data) -> str:
    meshio.write(path, meshio.Mesh(points, cells, **data))
    return str(path)


def field(p: np.ndarray) -> np.ndarray:
    """Quadratic in x, y, z: what a 10-node tetrahedron holds exactly and its corners cannot."""
    x, y, z = p.T
    return x * x + 0.5 * y * y - 0.8 * z * z + 0.3 * x * z


def quadratic_tetrahedra(n: int):
    """A cube as 6 n^3 10-node tetrahedra (linear ones with a node on every edge, shared between
    neighbours): (points, tetra10 nodes, the linear tetrahedra, the corner points)."""
    corners, hexes = box_hexes(n)
    tets = split_cells("hexahedron", hexes)
    points, mid_of = list(corners), {}
    for t in tets:
        for a, b in TETRA10_EDGES:
            key = tuple(sorted((int(t[a]), int(t[b]))))
            if key not in mid_of:
                mid_of[key] = len(points)
                points.append((corners[t[a]] + corners[t[b]]) / 2.0)
    nodes = np.array([[*t, *(mid_of[tuple(sorted((int(t[a]), int(t[b]))))] for a, b in TETRA10_EDGES)]
                      for t in tets])
    return np.array(points), nodes, tets, corners


def run(args, tmp_path, capsys) -> tuple[int, np.ndarray | None, str]:
    """(exit code, the image as data or None, stderr) of `vgraph run ...` writing --data."""
    out = tmp_path / "image.npy"
    code = main(["run", *map(str, args), "--size", f"{SIZE[0]}x{SIZE[1]}", "--data", str(out)])
    return code, (np.load(out) if out.exists() else None), capsys.readouterr().err


def psnr(a, b) -> float:
    return float(10.0 * np.log10(1.0 / np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)))


def reference_of(path, mesh: TetMesh) -> np.ndarray:
    """The exact CPU image of ``mesh`` seen as the standard mesh network sees the file."""
    camera = mesh_network(path).get("pt.camera")
    return reference_tetra.render(mesh, camera, DEFAULT_TRANSFER_FUNCTION, SIZE)


# --- the door --------------------------------------------------------------------------------------
def test_mesh_files_are_recognised_before_json_and_volumes_keep_theirs(tmp_path):
    for name in ("jaw.vtu", "post.vtk", "part.msh", "cube.mesh", "KIEFER_TETRA10.VTU", "a.xdmf"):
        assert is_mesh_path(tmp_path / name), name
    for name in ("net.json", "head.nii.gz", "neghip.dat", "image.vti", "x.svg"):
        assert not is_mesh_path(tmp_path / name), name


def test_run_renders_point_data_with_the_standard_mesh_network_and_names_the_array(tmp_path, capsys):
    points, hexes = box_hexes(3)
    path = write(tmp_path / "box.vtu", points, [("hexahedron", hexes)],
                 point_data={"T": field(points), "U": points[:, 0]},
                 cell_data={"S": [np.arange(len(hexes), dtype=float)]})
    code, image, err = run([path], tmp_path, capsys)
    assert code == 0, err
    assert "rendering the point array 'T'; the file also has point array 'U'; cell array 'S'" in err
    assert err.count("rendering the") == 1
    network = vgraph.load(path)
    assert [p.type_name for p in network.processors.values()] == ["MeshSource", "ProjectedTetrahedra", "Canvas"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vgraph.VGraphWarning)
        mesh = read_mesh(path)
    assert not mesh.per_cell and mesh.scalar_name == "T"
    reference = reference_of(path, mesh)
    assert (reference[..., :3].max(axis=-1) > 0.05).mean() > 0.2  # the box fills much of the view
    assert psnr(image, reference) > 40.0  # as the projected-tetrahedra tests ask of a mesh


def test_a_mesh_with_only_cell_data_renders_each_cell_constant(tmp_path, capsys):
    """Measured: 77 dB against the exact reference of the per-cell field (max error 1e-3, the
    pre-integration table read on its diagonal); the same data averaged to the points, which is
    what rendering cell arrays did before, is a different picture (27 dB)."""
    points, hexes = box_hexes(3)
    values = np.random.default_rng(0).uniform(0.0, 10.0, len(hexes))
    path = write(tmp_path / "cells.vtu", points, [("hexahedron", hexes)], cell_data={"S": [values]})
    code, image, err = run([path], tmp_path, capsys)
    assert code == 0, err
    assert "rendering the cell array (constant in each cell) 'S', its only array" in err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vgraph.VGraphWarning)
        mesh = read_mesh(path)
        averaged = read_mesh(path, cell_arrays="averaged")
    assert mesh.per_cell and len(mesh.scalars) == len(mesh.tets) == 6 * len(hexes)
    np.testing.assert_array_equal(mesh.scalars, np.repeat(values, 6).astype(np.float32))
    reference = reference_of(path, mesh)
    assert psnr(image, reference) > 60.0 and np.abs(image - reference).max() < 5e-3
    assert psnr(image, reference_of(path, averaged)) < 40.0  # not averaged to the points
    # Asked for, the average is what renders.
    code, blurred, err = run([path, "--set", "source.cell_arrays=averaged"], tmp_path, capsys)
    assert code == 0 and psnr(blurred, reference_of(path, averaged)) > 40.0


@pytest.mark.parametrize("integration", ["averaged", "preintegrated"])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_cell_scalars_match_the_exact_reference_in_both_integrations(integration, projection):
    """A constant per cell has an exact ray integral; measured max error 1.6e-4 averaged, 1.1e-3
    preintegrated (its table interpolates between scalar nodes)."""
    points, hexes = box_hexes(3)
    tets = split_cells("hexahedron", hexes)
    values = np.random.default_rng(1).uniform(0.0, 1.0, len(tets))
    mesh = TetMesh(points, tets, values, per_cell=True)
    tf = TransferFunction(points=[(0.0, 0.1, 0.3, 0.9, 0.05), (0.5, 0.9, 0.9, 0.2, 0.3),
                                  (1.0, 0.9, 0.1, 0.1, 0.7)])
    camera = DEFAULT_CAMERA.model_copy(update={"projection": projection})  # oblique to every face
    renderer = ProjectedTetrahedra(camera=camera, transfer_function=tf, integration=integration,
                                   background=(0.0, 0.0, 0.0, 1.0))
    renderer.render_size = SIZE
    image = renderer.process(mesh)["image"].to_numpy()
    reference = reference_tetra.render(mesh, camera, tf, SIZE)
    assert np.abs(image - reference).max() < (1e-3 if integration == "averaged" else 5e-3)


def test_quadratic_tetrahedra_split_into_eight_over_all_nodes(tmp_path, capsys):
    """10-node tetrahedra: 8 linear ones per cell, through the mid-edge nodes' values. Against a
    fine sampling of the quadratic field the split is measured 4x closer than the corners alone
    (mean error 0.003 against 0.013); the GL image matches the exact reference of the split."""
    points, nodes, linear, corners = quadratic_tetrahedra(2)
    path = write(tmp_path / "kiefer_tetra10.vtu", points, [("tetra10", nodes)],
                 point_data={"f": field(points)})
    code, image, err = run([path], tmp_path, capsys)
    assert code == 0, err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vgraph.VGraphWarning)
        mesh = read_mesh(path)
    assert len(mesh.tets) == 8 * len(nodes) and len(mesh.points) == len(points)  # every node used
    assert mesh.tet_volumes().sum() == pytest.approx(8.0)  # they fill the cube
    assert psnr(image, reference_of(path, mesh)) > 40.0

    # The picture of the quadratic field: a fine linear mesh sampling it.
    lo_hi, length = mesh.value_range, mesh.opacity_length
    m = 17
    axis = np.linspace(-1.0, 1.0, m)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    samples = field(np.stack([x, y, z], -1).reshape(-1, 3)).reshape(m, m, m)
    fine_points, fine_tets, voxel = volume_tetrahedra(samples, (2.0 / (m - 1),) * 3, (-1.0, -1.0, -1.0))
    fine = TetMesh(fine_points, fine_tets, samples.reshape(-1)[voxel], declared_range=lo_hi,
                   reference_length=length)
    cut = TetMesh(corners, linear, field(corners), declared_range=lo_hi, reference_length=length)
    tf = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.05), (0.5, 0.9, 0.9, 0.2, 0.2), (1.0, 0.9, 0.1, 0.1, 0.6)])
    camera = Camera(fit_to_data=True).viewed_from("iso")
    truth, split, reduced = (reference_tetra.render(m_, camera, tf, SIZE) for m_ in (fine, mesh, cut))
    split_error = np.abs(split - truth)[..., :3].mean()
    corner_error = np.abs(reduced - truth)[..., :3].mean()
    assert split_error < 0.5 * corner_error


# --- errors ------------------------------------------------------------------------------------------
def test_a_mesh_without_arrays_exits_2_saying_so(tmp_path, capsys):
    points, hexes = box_hexes(1)
    path = write(tmp_path / "bare.vtu", points, [("hexahedron", hexes)])
    code, image, err = run([path], tmp_path, capsys)
    assert code == 2 and image is None
    assert "source.array: " in err and "bare.vtu: no array to render: the file has no arrays" in err
    assert "Traceback" not in err and "JSON" not in err


def test_a_name_the_mesh_lacks_exits_2_listing_its_arrays(tmp_path, capsys):
    points, hexes = box_hexes(2)
    path = write(tmp_path / "kiefer.vtu", points, [("hexahedron", hexes)],
                 point_data={"Displacement": points}, cell_data={"vonMises": [np.arange(8.0)]})
    code, _, err = run([path, "--set", "source.array=Pressure"], tmp_path, capsys)
    assert code == 2
    assert ("processor 'source' (MeshSource): source.array: " in err
            and "kiefer.vtu: no array 'Pressure'; the file has point array 'Displacement'; "
                "cell array 'vonMises'" in err)
    code, image, err = run([path, "--set", "source.array=vonMises"], tmp_path, capsys)
    assert code == 0 and image[..., :3].max() > 0.05  # a cell array by its plain name


def test_a_shipped_mesh_network_on_another_mesh_lists_the_arrays_it_has(tmp_path, capsys):
    """networks/tets_lox_post.json names "Pressure": applied to a mesh without it, the error names
    the property to change and what to choose from."""
    points, hexes = box_hexes(2)
    path = write(tmp_path / "kiefer.vtu", points, [("hexahedron", hexes)], point_data={"T": points[:, 2]})
    code, _, err = run([REPO / "networks" / "tets_lox_post.json", "--set", f"source.path={path}"],
                       tmp_path, capsys)
    assert code == 2
    assert "source.array: " in err and "no array 'Pressure'; the file has point array 'T'" in err
    code, image, err = run([REPO / "networks" / "tets_lox_post.json", "--set", f"source.path={path}",
                            "--set", "source.array="], tmp_path, capsys)
    assert code == 0 and image[..., :3].max() > 0.05


@pytest.mark.skipif(not (DATA / "tet_lox_post").is_dir(), reason="shared data sets not found")
def test_the_shared_post_mesh_runs_from_its_file(tmp_path, capsys):
    code, image, err = run([DATA / "tet_lox_post" / "post.vtk"], tmp_path, capsys)
    assert code == 0 and "rendering the point array 'Pressure', its only array" in err
    drawn = image[..., :3].max(axis=-1) > 0.02
    assert drawn.mean() > 0.1 and drawn[16:48, 16:48].mean() > drawn.mean()


def test_the_gui_opens_a_mesh_as_an_untitled_network(window, tmp_path):
    points, hexes = box_hexes(2)
    path = write(tmp_path / "part.vtu", points, [("hexahedron", hexes)], point_data={"T": field(points)})
    window.workspace.open(path)
    assert window.workspace.path is None     # Save asks for a name: the mesh is never overwritten
    assert window.workspace.network.get("source.path") == str(tmp_path / "part.vtu")
    outcome = window.evaluation.run(wait=True)
    assert not outcome.failed and "canvas" in outcome.frames
