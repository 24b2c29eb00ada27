"""MeshSource: an unstructured mesh from a file, as tetrahedra with one point scalar (formats, the
splitting of hexahedra, wedges and pyramids, and the errors: docs/tetrahedra.md, "Meshes and
MeshSource"; the reader is vgraph.io.meshes)."""

from vgraph import (FilePathProperty, FloatProperty, Outport, Processor, PropertyError, StringProperty,
                    VectorProperty, VGraphError)
from vgraph.io.meshes import FILE_FILTERS, read_mesh
from vgraph.mesh import TetMesh


class MeshSource(Processor):
    """Reads an unstructured mesh (VTK, Gmsh, Medit, XDMF, Exodus) as tetrahedra."""

    category = "Mesh"
    outports = [Outport("mesh", TetMesh)]
    path = FilePathProperty("", filters=FILE_FILTERS + ("*",),
                            doc="the mesh file (.vtk, .vtu, .msh, .mesh, .xdmf, .ex2 with netCDF4, ...)")
    array = StringProperty("", doc="the point array to render; empty: the first point array; "
                                   "'cell:NAME' takes a cell array, averaged to the points")
    component = StringProperty("", doc="of an array with several values per point: 'magnitude', "
                                       "a component's number (0, 1, ...) or X, Y, Z; empty: the "
                                       "magnitude of a 3-component vector (other counts must "
                                       "choose)")
    value_range = VectorProperty(None, size=2, optional=True,
                                 doc="scalar values mapped to intensities 0 and 1; empty: the "
                                     "array's min..max")
    reference_length = FloatProperty(0.0, min=0.0,
                                     doc="world length over which a transfer function's opacity "
                                         "is that of one sample; 0: the mean edge length")

    def check(self) -> None:
        if self.value_range is not None and not self.value_range[0] < self.value_range[1]:
            raise PropertyError(f"{self.id}.value_range", f"low must be below high, got "
                                f"({self.value_range[0]:g}, {self.value_range[1]:g})")

    def process(self) -> TetMesh:
        self.check()
        if not self.path:
            raise VGraphError(f"{self.id}.path: no mesh file chosen")
        return read_mesh(self.resolve_path(self.path), array=self.array, component=self.component,
                         declared_range=self.value_range,
                         reference_length=self.reference_length or None)
