"""VolumeToTetMesh and vgraph.tetrahedralize: five tetrahedra per cell with matching faces, the
volume's geometry and values, and cell culling compared with brute-force loops."""

import time
from collections import Counter

import numpy as np
import pytest

import vgraph
from vgraph import ProcessorError, VGraphError
from vgraph.io import read_volume
from vgraph.mesh import TetMesh
from vgraph.processors.volume_to_tet_mesh import VolumeToTetMesh
from vgraph.tetrahedralize import volume_tetrahedra
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

BAND = TransferFunction(points=[(0.0, 0, 0, 0, 0.0), (0.45, 1, 1, 1, 0.0), (0.55, 1, 1, 1, 0.6),
                                (0.65, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 0.0)])


def face_counts(tets: np.ndarray) -> Counter:
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]])
    return Counter(np.unique(np.sort(faces, axis=1), axis=0, return_counts=True)[1].tolist())


def cells_of(mesh: TetMesh, volume: Volume) -> Counter:
    """(k, j, i) of the cell each tetrahedron lies in (its smallest corner), counted."""
    corner = np.round(volume.world_to_voxel(mesh.points.astype(np.float64)[mesh.tets].min(axis=1))).astype(int)
    return Counter(map(tuple, corner[:, ::-1].tolist()))


def cell_values(data, k, j, i):
    return data[k:k + 2, j:j + 2, i:i + 2].astype(np.float64).reshape(-1)


@pytest.fixture
def small_volume():
    rng = np.random.default_rng(7)  # a ramp along x with noise: cells of narrow, varied ranges
    data = (np.arange(7.0)[None, None, :] * 30.0 + rng.normal(0.0, 8.0, (5, 6, 7))).astype(np.float32)
    return Volume(data, spacing=(0.5, 1.5, 2.0), origin=(1.0, -2.0, 3.0), source="random")


def test_every_cell_becomes_five_positive_tetrahedra_that_fill_the_box(small_volume):
    mesh = VolumeToTetMesh().process(volume=small_volume)
    nx, ny, nz = small_volume.dims
    cells = (nx - 1) * (ny - 1) * (nz - 1)
    assert mesh.tets.shape == (5 * cells, 4) and mesh.tets.dtype == np.int32
    assert mesh.points.dtype == np.float32
    volumes = mesh.tet_volumes()
    assert np.all(volumes > 0)
    assert volumes.sum() == pytest.approx(np.prod(small_volume.extent))
    assert set(cells_of(mesh, small_volume).values()) == {5}


def test_faces_match_between_cells(small_volume):
    mesh = VolumeToTetMesh().process(volume=small_volume)
    nx, ny, nz = (d - 1 for d in small_volume.dims)
    counts = face_counts(mesh.tets)
    assert set(counts) == {1, 2}
    # Two triangles per boundary square and nothing else held once: neighbouring cells whose
    # diagonals disagreed would leave four triangles held once inside.
    assert counts[1] == 2 * 2 * (nx * ny + ny * nz + nz * nx)


def test_points_are_voxel_centres_with_their_values(small_volume):
    mesh = VolumeToTetMesh().process(volume=small_volume)
    assert len(mesh.points) == small_volume.data.size
    ijk = np.round(small_volume.world_to_voxel(mesh.points)).astype(int)
    np.testing.assert_allclose(mesh.points, small_volume.voxel_to_world(ijk), atol=1e-5)
    np.testing.assert_array_equal(mesh.scalars, small_volume.data[ijk[:, 2], ijk[:, 1], ijk[:, 0]])
    assert mesh.value_range == small_volume.value_range
    assert mesh.reference_length == 0.5  # the smallest spacing
    assert mesh.opacity_length == 0.5


def test_transfer_function_culling_keeps_exactly_the_cells_whose_range_has_opacity(small_volume):
    processor = VolumeToTetMesh(culling="transfer_function", transfer_function=BAND)
    mesh = processor.process(volume=small_volume)
    alpha = BAND.lut()[:, 3]
    last = len(alpha) - 1
    data = small_volume.data
    expected, visible = set(), set()
    for k in range(data.shape[0] - 1):
        for j in range(data.shape[1] - 1):
            for i in range(data.shape[2] - 1):
                values = small_volume.normalized(cell_values(data, k, j, i))
                low, high = max(values.min(), 0.0), min(values.max(), 1.0)
                entries = alpha[int(np.floor(low * last)):int(np.ceil(high * last)) + 1]
                if low <= high and entries.max() > 0:
                    expected.add((k, j, i))
                # Exactly: the TF's largest opacity over [low, high] (its ends and the points inside).
                inside = [p[0] for p in BAND.points if low <= p[0] <= high]
                if low <= high and BAND([low, high, *inside])[:, 3].max() > 0:
                    visible.add((k, j, i))
    kept = cells_of(mesh, small_volume)
    assert set(kept) == expected and set(kept.values()) == {5}
    assert visible <= set(kept)  # no cell with any opacity is lost
    assert 0 < len(expected) < processor.total_cells
    assert (processor.kept_cells, processor.total_cells) == (len(expected), 4 * 5 * 6)
    assert len(mesh.tets) == 5 * processor.kept_cells
    used = np.unique(mesh.tets)
    assert len(used) == len(mesh.points)  # only the points kept cells use


def test_threshold_culling_keeps_exactly_the_cells_whose_range_meets_the_interval(small_volume):
    processor = VolumeToTetMesh(culling="threshold", threshold=(95.0, 100.0))
    mesh = processor.process(volume=small_volume)
    data = small_volume.data
    expected = {(k, j, i) for k in range(data.shape[0] - 1) for j in range(data.shape[1] - 1)
                for i in range(data.shape[2] - 1)
                if cell_values(data, k, j, i).max() >= 95.0 and cell_values(data, k, j, i).min() <= 100.0}
    assert set(cells_of(mesh, small_volume)) == expected
    assert processor.kept_cells == len(expected) and len(mesh.tets) == 5 * len(expected)
    assert face_counts(mesh.tets).keys() <= {1, 2}
    # A cell whose values straddle the interval (some below, some above, none inside) is kept:
    # the interpolated field passes through the interval inside it.
    straddling = np.zeros((2, 2, 2), dtype=np.float32)
    straddling[1] = 10.0
    volume = Volume(straddling)
    processor = VolumeToTetMesh(culling="threshold", threshold=(4.0, 6.0))
    assert len(processor.process(volume=volume).tets) == 5
    processor.threshold = None  # empty: the value range, every cell
    assert len(processor.process(volume=small_volume).tets) == 5 * 4 * 5 * 6


def test_transfer_functions_in_data_units_and_percentiles_cull_through_the_value_range(small_volume):
    lo, hi = small_volume.value_range
    data_tf = TransferFunction(space="data", points=[(lo + p * (hi - lo), *c) for p, *c in BAND.points])
    normalized = VolumeToTetMesh(culling="transfer_function", transfer_function=BAND).process(volume=small_volume)
    data_units = VolumeToTetMesh(culling="transfer_function", transfer_function=data_tf).process(volume=small_volume)
    assert abs(len(normalized.tets) - len(data_units.tets)) <= 5 * 2  # a LUT entry of rounding at most


def test_non_finite_voxels_become_the_range_ends_as_in_textures():
    data = np.arange(27, dtype=np.float32).reshape(3, 3, 3)
    data[0, 0, 0], data[2, 2, 2], data[1, 1, 1] = np.nan, np.inf, -np.inf
    volume = Volume(data)
    mesh = VolumeToTetMesh().process(volume=volume)
    assert np.all(np.isfinite(mesh.scalars))
    lo, hi = volume.value_range
    assert mesh.scalars.min() == lo and mesh.scalars.max() == hi


def test_nothing_kept_and_too_thin_volumes_are_errors(small_volume):
    processor = VolumeToTetMesh(id="cut", culling="threshold", threshold=(1e6, 2e6))
    with pytest.raises(VGraphError, match=r"cut: culling = threshold leaves none of the 120 cells of random: "
                                          r"no cell's values reach the threshold"):
        processor.process(volume=small_volume)
    with pytest.raises(VGraphError, match=r"at least 2 voxels along every axis"):
        VolumeToTetMesh().process(volume=Volume(np.zeros((1, 4, 4), dtype=np.uint8)))
    processor = VolumeToTetMesh(id="cut", culling="threshold", threshold=(3.0, 1.0))
    with pytest.raises(vgraph.PropertyError, match=r"cut.threshold: low must not be above high"):
        processor.check()


def test_a_mesh_larger_than_memory_is_refused_before_it_is_built():
    with pytest.raises(VGraphError, match=r"8 cells make 40 tetrahedra and 27 points, .* MiB, but only "
                                          r"0 MiB of memory are available: cull more cells"):
        volume_tetrahedra(np.zeros((3, 3, 3)), (1, 1, 1), (0, 0, 0), available_bytes=100)


def test_in_a_network_after_a_volume_source(tmp_path):
    data = np.random.default_rng(3).integers(0, 255, (4, 5, 6)).astype(np.uint8)
    np.save(tmp_path / "v.npy", data)
    net = vgraph.Network()
    net.add("VolumeSource", id="source", path=str(tmp_path / "v.npy"), spacing=(2.0, 1.0, 3.0))
    net.add("VolumeToTetMesh", id="tets", culling="threshold", threshold=(200.0, 255.0))
    net.connect("source.volume", "tets.volume")
    net.update("tets.mesh")
    mesh = net.output("tets.mesh")
    processor = net.processors["tets"]
    assert len(mesh.tets) == 5 * processor.kept_cells and processor.total_cells == 3 * 4 * 5
    assert mesh.reference_length == 1.0 and mesh.value_range == (float(data.min()), float(data.max()))
    assert type(processor).category == "Mesh"
    net.set("tets.threshold", (1000.0, 2000.0))
    with pytest.raises(ProcessorError, match=r"processor 'tets' \(VolumeToTetMesh\): .*leaves none"):
        net.update("tets.mesh")


# Measured here (llvmpipe machine, one core busy): 22.8 % of the bonsai's 16.6 M cells kept under
# 'auto', 3.8 M cells = 18.9 M tetrahedra, in about 3 s (docs/explanations/tetrahedra.md).
def test_the_bonsai_under_the_auto_transfer_function(data_dir):
    volume = read_volume(data_dir / "ct_bonsai/bonsai.nii.gz")
    processor = VolumeToTetMesh(culling="transfer_function", transfer_function="auto")
    start = time.perf_counter()
    mesh = processor.process(volume=volume)
    seconds = time.perf_counter() - start
    assert processor.total_cells == 255 ** 3
    assert processor.kept_cells / processor.total_cells == pytest.approx(0.228, abs=0.005)
    assert len(mesh.tets) == 5 * processor.kept_cells
    assert seconds < 30, f"cutting the bonsai took {seconds:.1f} s"
