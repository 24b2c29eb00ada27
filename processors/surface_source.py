"""SurfaceSource: a triangle surface from a file (.obj, .stl, .ply, .off, .vtk, ...) as a Geometry
for the GeometryRenderer (formats, what is kept and the errors: vgraph.io.surfaces). Volume meshes
(tetrahedra) are MeshSource's."""

from vgraph import FilePathProperty, Outport, Processor, StringProperty, VGraphError
from vgraph.geometry import Geometry
from vgraph.io.surfaces import FILE_FILTERS, read_surface


class SurfaceSource(Processor):
    """Reads a triangle surface (OBJ, STL, PLY, OFF, VTK) in world units."""

    category = "Geometry"
    outports = [Outport("geometry", Geometry)]
    path = FilePathProperty("", filters=FILE_FILTERS + ("*",),
                            doc="the surface file (.obj, .stl, .ply, .off, .vtk, .vtu, ...)")
    array = StringProperty("", doc="the point array that gives the vertices' scalars (a colour map "
                                   "in the GeometryRenderer); empty: the first one, if any")
    component = StringProperty("", doc="of an array with several values per point: 'magnitude', "
                                       "a component's number (0, 1, ...) or X, Y, Z; empty: the "
                                       "magnitude of a 3-component vector (other counts must "
                                       "choose)")

    def awaiting(self) -> str | None:
        return None if self.path else "a surface file"

    def process(self) -> Geometry:
        if not self.path:
            raise VGraphError(f"{self.id}.path: no surface file chosen")
        return read_surface(self.resolve_path(self.path), array=self.array, component=self.component)
