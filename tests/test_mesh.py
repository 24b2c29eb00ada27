"""The TetMesh type: its checks name the problem, its value range and percentiles follow the
volume's rules (a percentile TF asks for them every frame: they come from one sort)."""

import numpy as np
import pytest

from vgraph.errors import VGraphError
from vgraph.mesh import TetMesh
from vgraph.transfer_function import TransferFunction

UNIT_TET = ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]])


def test_percentiles_are_numpys_and_nan_is_left_out():
    rng = np.random.default_rng(3)
    scalars = rng.normal(size=500).astype(np.float32)
    scalars[7] = np.nan
    mesh = TetMesh(rng.random((500, 3)), [[0, 1, 2, 3]], scalars)
    wanted = [0, 0.5, 13.3, 50, 99.5, 100]
    np.testing.assert_allclose(mesh.percentiles(wanted),
                               np.percentile(scalars[np.isfinite(scalars)].astype(np.float64), wanted), rtol=0, atol=1e-12)
    lo, hi = mesh.value_range
    assert lo == np.nanmin(scalars) and hi == np.nanmax(scalars)
    resolved = TransferFunction(space="percentile", points=[(50, 0, 0, 0, 0), (100, 1, 1, 1, 1)]).for_volume(mesh)
    assert resolved.points[0][0] == 0.0 and resolved.points[-1][0] == 1.0


def test_a_constant_mesh_still_maps_somewhere_and_a_declared_range_wins():
    points, tets = UNIT_TET
    assert TetMesh(points, tets, [5, 5, 5, 5]).value_range == (5.0, 6.0)
    assert TetMesh(points, tets, [5, 5, 5, 5], declared_range=(0, 10)).value_range == (0.0, 10.0)


@pytest.mark.parametrize("change, problem", [
    ({"tets": [[0, 1, 2, 4]]}, "indices must lie in 0 .. 3"),
    ({"points": [[0, 0, np.inf], [1, 0, 0], [0, 1, 0], [0, 0, 1]]}, "non-finite coordinates"),
    ({"scalars": [1, 2, 3]}, "3 scalars for 4 points"),
    ({"declared_range": (2, 1)}, "value_range must be finite with low < high"),
    ({"reference_length": 0.0}, "reference_length must be positive"),
])
def test_impossible_meshes_are_refused_naming_the_problem(change, problem):
    points, tets = UNIT_TET
    fields = {"points": points, "tets": tets, "scalars": [0, 1, 2, 3], "source": "m.vtk", **change}
    with pytest.raises(VGraphError, match=f"mesh from m.vtk: .*{problem}"):
        TetMesh(**fields)
