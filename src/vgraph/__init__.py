"""vgraph: a node-graph framework for volume visualization.

Scripts meet vgraph through a few names::

    import vgraph
    net = vgraph.load("networks/grayscale.json")
    net.set("gray.saturation", 0.5)
    image = net.evaluate("gray.image")          # float32 (H, W, 4), row 0 at the top
    net.save("mine.json")
"""

from vgraph.errors import (CycleError, NetworkFileError, OutputFileError, PortError, ProcessorError, PropertyError,
                           ShaderError, VGraphError, VGraphWarning, VolumeFileError, WritePathError)
from vgraph.frame_context import FrameContext
from vgraph.network import Network
from vgraph.network_services import bind_services as _bind_services
from vgraph.ports import Inport, Outport
from vgraph.processor import Processor
from vgraph.properties import (BoolProperty, CameraProperty, ColorProperty, DictProperty, FilePathProperty,
                               FloatProperty, IntProperty, Invalidation, LabelTableProperty, MarkupsProperty,
                               OptionProperty, StringProperty, TransferFunctionProperty, VectorProperty)
from vgraph.registry import registry
from vgraph.volume import Volume

__version__ = "0.1.0"


class _Services:
    """network_services.NetworkServices as ``vgraph.services``, imported when a network is first evaluated or
    saved: importing the model (``vgraph.network``, which runs this file first) must import neither
    the scheduler (and with it GL) nor the file format, which both import the model."""

    def __getattr__(self, name):
        from vgraph import services  # imported when first used (this class's docstring)
        return getattr(services, name)


_bind_services(_Services())


def load(path, allow_write=(), render_as=None) -> Network:
    """Load a saved .json network (raises NetworkFileError naming the JSON path of each problem).
    Its writers may write inside the file's folder and the folders in ``allow_write``. A data file
    gives the standard network for what it holds (vgraph.volume_network); ``render_as``
    ("labels" or "intensity") overrides that choice for a volume."""
    from vgraph.fileformat import load_network  # imported when called: the model needs no file format
    return load_network(path, allow_write, render_as)


def register(processor_class):
    """Register a processor class defined in a script (usable as a decorator)."""
    return registry.register(processor_class, origin=processor_class.__module__)


__all__ = [
    "load", "register", "registry", "Network", "Processor", "FrameContext", "Inport", "Outport", "Volume",
    "Invalidation", "BoolProperty", "CameraProperty", "ColorProperty", "DictProperty", "FilePathProperty",
    "FloatProperty", "IntProperty", "LabelTableProperty", "MarkupsProperty", "OptionProperty", "StringProperty",
    "TransferFunctionProperty", "VectorProperty", "VGraphError", "NetworkFileError", "PortError", "CycleError",
    "ProcessorError", "OutputFileError", "PropertyError", "ShaderError", "VGraphWarning", "VolumeFileError",
    "WritePathError",
]
