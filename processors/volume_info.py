"""VolumeInfo: a volume's grid, type, value range, percentiles and time points, as a Python value
(``info``: vgraph.volume_statistics.VolumeStatistics) and in the GUI's inspector.

The GUI shows ``frame_summary()`` (the lines of VolumeStatistics) under the node's data once it
has run; from Python, ``network.update("info.info")`` then ``network.output("info.info")`` gives
the value (``as_dict()`` for JSON). A store (BrickedVolume) is described from its metadata and a
summary level, without reading it whole (its percentiles say so).
"""

from vgraph import Inport, Outport, Processor, VectorProperty
from vgraph.volume import Volume
from vgraph.volume_statistics import VolumeStatistics


class VolumeInfo(Processor):
    """Dimensions, spacing, affine, value range, percentiles and time points of a volume."""

    category = "Statistics"
    inports = [Inport("volume", Volume)]
    outports = [Outport("info", VolumeStatistics, "the description as a Python value")]
    percentiles = VectorProperty((1.0, 25.0, 50.0, 75.0, 99.0), size=5, min=0.0, max=100.0,
                                 doc="the percents whose values are given (of the finite voxels)")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.statistics: VolumeStatistics | None = None

    def process(self, volume: Volume) -> VolumeStatistics:
        self.statistics = None
        self.statistics = VolumeStatistics.of(volume.require_samples(self.id), self.percentiles)
        return self.statistics

    def frame_summary(self) -> str:
        return "\n".join(self.statistics.lines()) if self.statistics is not None else ""
