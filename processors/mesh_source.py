"""MeshSource: an unstructured mesh from a file, as tetrahedra with one scalar per point or, for a
cell array, per cell (formats, the splitting of hexahedra, wedges, pyramids and 10-node
tetrahedra, the choice of array and the errors: docs/explanations/tetrahedra.md, "Meshes and MeshSource"; the
reader is vgraph.io.meshes)."""

from vgraph import (FilePathProperty, FloatProperty, OptionProperty, Outport, Processor, PropertyError,
                    StringProperty, VectorProperty, VGraphError)
from vgraph.errors import MeshFileError
from vgraph.io.mesh_arrays import CELL_ARRAYS
from vgraph.io.meshes import FILE_FILTERS, read_mesh
from vgraph.mesh import TetMesh


class MeshSource(Processor):
    """Reads an unstructured mesh (VTK, Gmsh, Medit, XDMF, Exodus) as tetrahedra."""

    category = "Mesh"
    outports = [Outport("mesh", TetMesh)]
    path = FilePathProperty("", filters=FILE_FILTERS + ("*",),
                            doc="the mesh file (.vtk, .vtu, .msh, .mesh, .xdmf, .ex2 with netCDF4, ...)")
    array = StringProperty("", doc="the array to render: a point array's name, or a cell array's "
                                   "(also as 'cell:NAME'); empty: the first point array, else the "
                                   "first cell array (a warning names it and the others)")
    cell_arrays = OptionProperty("constant", choices=list(CELL_ARRAYS),
                                 doc="a cell array is constant: one value inside each cell, as the "
                                     "file holds it; averaged: each point gets the mean over the "
                                     "cells that use it, a smooth field blending neighbours")
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

    def awaiting(self) -> str | None:
        return None if self.path else "a mesh file"

    def process(self) -> TetMesh:
        self.check()
        if not self.path:
            raise VGraphError(f"{self.id}.path: no mesh file chosen")
        try:
            return read_mesh(self.resolve_path(self.path), array=self.array, component=self.component,
                             declared_range=self.value_range,
                             reference_length=self.reference_length or None,
                             cell_arrays=self.cell_arrays)
        except MeshFileError as error:
            if error.field != "array":
                raise
            # A name the file does not have (a network made for another mesh): the property to
            # change, the file, and the names to choose from.
            raise PropertyError(f"{self.id}.array", f"{error.file}: {error.reason}") from None
