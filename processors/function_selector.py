"""FunctionSelector (Cabral 2010, ch. 5.1): a volume sampled from an implicit function, no file."""

from vgraph import DictProperty, IntProperty, OptionProperty, Outport, Processor
from vgraph.implicit import DATA_TYPES, FUNCTIONS, RESOLUTION_RANGE, make_function, sample
from vgraph.volume import Volume


class FunctionSelector(Processor):
    """Samples an implicit function (sphere, torus, ...) into a volume; its surface is at level 0.5."""

    category = "Volume"
    outports = [Outport("volume", Volume)]
    function = OptionProperty("torus", choices=list(FUNCTIONS), doc="the implicit function (docs/reference/general/functions.md)")
    resolution = IntProperty(64, min=RESOLUTION_RANGE[0], max=RESOLUTION_RANGE[1],
                             doc="voxels per axis (2^4 .. 2^9)")
    data_type = OptionProperty("float32", choices=list(DATA_TYPES), doc="how the samples are stored")
    parameters = DictProperty({}, doc="the function's parameters by name; missing ones take their defaults")

    def check(self) -> None:
        make_function(self.function, **self.parameters)

    def process(self) -> Volume:
        return sample(make_function(self.function, **self.parameters), self.resolution, self.data_type)
