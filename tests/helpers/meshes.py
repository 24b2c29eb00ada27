"""The tetrahedral meshes' test volume (tests/test_mesh_lod.py, test_gui_mesh_lod.py): a smooth
blob on a grid, and a network that writes it to disk, cuts it into tetrahedra and projects them."""

import nibabel as nib
import numpy as np

import vgraph


def blob(n: int) -> np.ndarray:
    """[z, y, x] float32: a smooth blob on an n^3 grid."""
    z, y, x = np.mgrid[0:n, 0:n, 0:n] / (n - 1)
    return np.exp(-((x - 0.45) ** 2 + (y - 0.5) ** 2 + (z - 0.55) ** 2) / 0.12).astype(np.float32)


def blob_network(tmp_path, n: int = 48, coarse: int = 20_000) -> vgraph.Network:
    """A volume on disk cut into tetrahedra and projected onto a 64 x 64 canvas."""
    path = tmp_path / "blob.nii.gz"
    nib.save(nib.Nifti1Image(np.ascontiguousarray(blob(n).T), np.eye(4)), str(path))
    network = vgraph.Network()
    network.add("VolumeSource", id="source", path=str(path))
    network.add("VolumeToTetMesh", id="tets")
    network.add("ProjectedTetrahedra", id="pt", coarse_tetrahedra=coarse)
    network.add("Canvas", id="canvas", size=[64, 64])
    network.connect("source.volume", "tets.volume")
    network.connect("tets.mesh", "pt.mesh")
    network.connect("pt.image", "canvas.image")
    return network
