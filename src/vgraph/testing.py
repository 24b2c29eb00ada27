"""Networks around a volume held in memory, for code that builds its networks in Python: the tests
(tests/) and the benchmarks (bench/, which run from the repository root and do not import tests).

Conventions:
- ``GivenVolume`` keeps its volume as a Python attribute, not a property, and is not a registered
  processor type: a network holding it can be saved, but the file cannot be loaded again. Networks
  meant for files use VolumeSource or FunctionSelector.
- ``ray_caster_network`` names its processors 'src' (GivenVolume), 'eep' (EntryExitPoints) and
  ``id`` (the ray caster), and links eep.camera to the ray caster's camera.
"""

from __future__ import annotations

from vgraph.camera import Camera
from vgraph.network import Network
from vgraph.ports import Outport
from vgraph.processor import Processor
from vgraph.volume import Volume


class GivenVolume(Processor):
    """Outputs the volume it was made with."""

    outports = [Outport("volume", Volume)]

    def __init__(self, id=None, volume=None, **values):
        super().__init__(id, **values)
        self.volume = volume

    def process(self):
        return self.volume


def ray_caster_network(volume: Volume, camera: Camera, processor: str = "RayCaster",
                       id: str = "rc", inport: str = "volume", **properties) -> Network:
    """GivenVolume 'src' -> EntryExitPoints 'eep' -> ``processor`` ``id`` (made with
    ``properties``): the volume goes to both (the ray caster's ``inport``: 'labels' for the
    LabelRayCaster), the entry and exit points to the ray caster, which takes ``camera`` through
    the link."""
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("EntryExitPoints", id="eep", camera=camera)
    network.add(processor, id=id, **properties)
    network.link("eep.camera", f"{id}.camera")
    for source, target in (("src.volume", "eep.volume"), ("src.volume", f"{id}.{inport}"),
                           ("eep.entry", f"{id}.entry"), ("eep.exit", f"{id}.exit")):
        network.connect(source, target)
    return network
