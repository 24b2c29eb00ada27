"""A geometry held in memory as a network's source (as vgraph.testing.GivenVolume holds a volume),
for the surface tests (test_geometry_renderer.py, test_geometry_depth_mixing.py)."""

from vgraph.geometry import Geometry
from vgraph.ports import Outport
from vgraph.processor import Processor


class GivenGeometry(Processor):
    """Outputs the geometry it was made with."""

    outports = [Outport("geometry", Geometry)]

    def __init__(self, id=None, geometry=None, **values):
        super().__init__(id, **values)
        self.geometry = geometry

    def process(self):
        return self.geometry
