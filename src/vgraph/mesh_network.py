"""A rendering network around an unstructured mesh file: what ``vgraph run MESH``, ``vgraph gui
MESH`` and ``vgraph.load(MESH)`` give for a .vtu, .vtk, .msh, .mesh ... instead of a .json network
(the volume's is vgraph.volume_network; docs/guide/own-data.md, "Meshes")::

    MeshSource 'source' -> ProjectedTetrahedra 'pt' -> Canvas 'canvas'

as networks/tets_*.json wire it, with the processors' own defaults, which are made for a first
look at any mesh: MeshSource renders the first point array, else the first cell array (constant
inside each cell), and names it and the others in one line; ProjectedTetrahedra's camera fits
whatever mesh arrives (automatic near/far), here turned to the ``iso`` view, from (1, 1, 1) with z
up as networks/tets_*.json look (a simulation mesh has no patient front, and an oblique view shows
its three extents; ``--view front`` gives the volumes' view), and its transfer function is
placed by percentiles of the scalar (projected_tetrahedra.DEFAULT_TRANSFER_FUNCTION), so it shows
the whole field without knowing its units. Every property can then be changed by id as in any
network (``--set source.array=cell:S``, ``--set pt.transfer_function=rainbow``, ``--view top``).
"""

from __future__ import annotations

from pathlib import Path

from vgraph.file_names import expanded
from vgraph.network import Network

IDS = {"source": "MeshSource", "pt": "ProjectedTetrahedra", "canvas": "Canvas"}
WIRES = (("source.mesh", "pt.mesh"), ("pt.image", "canvas.image"))
# meshio's formats that hold pictures or drawings, never 3D cells: not offered as meshes.
NOT_VOLUME_MESHES = (".svg",)


def mesh_extensions() -> tuple[str, ...]:
    """File name endings read as meshes: vgraph.io.meshes' and meshio's, longest first, without
    those a VolumeSource reads (``.dat`` is a QVis volume) or that never hold 3D cells."""
    # imported when used: the readers' libraries (pydicom, nibabel, meshio) take 0.2 s
    from vgraph.io import SUPPORTED_EXTENSIONS
    from vgraph.io.meshes import MESH_EXTENSIONS, meshio_extensions
    known = set(MESH_EXTENSIONS) | set(meshio_extensions())
    known -= set(SUPPORTED_EXTENSIONS) | set(NOT_VOLUME_MESHES)
    return tuple(sorted(known, key=len, reverse=True))


def is_mesh_path(path: str | Path) -> bool:
    """Whether ``path`` names a mesh file (by its extension) rather than a .json network. Ask
    vgraph.volume_network.is_volume_path first: it claims the extensions both could read."""
    name = Path(path).name.lower()
    return not name.endswith(".json") and any(name.endswith(e) for e in mesh_extensions())


def mesh_network(path: str | Path) -> Network:
    """The standard rendering network for the mesh at ``path`` (read when evaluated)."""
    network = Network(base_dir=Path.cwd())
    network.description = f"Projected tetrahedra of {Path(path).name}"
    for row, (id, type_name) in enumerate(IDS.items()):
        network.add(type_name, id=id).position = (0.0, 120.0 * row)  # a column in the editor
    network.set("source.path", str(expanded(path).resolve()))
    network.set("pt.camera", network.get("pt.camera").viewed_from("iso"))
    for source, target in WIRES:
        network.connect(source, target)
    return network
