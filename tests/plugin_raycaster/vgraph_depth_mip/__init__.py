from pathlib import Path

from vgraph import ColorProperty, Inport, Outport
from vgraph.gl.raycasting.components import Background, CameraRays, EntryExit, Sampling, VolumeSampling
from vgraph.gl.raycasting.raycaster_base import Binding, RaycasterBase
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import add_shader_dir
from vgraph.image import Image
from vgraph.volume import Volume

add_shader_dir(Path(__file__).parent / "shaders")


class DepthColouredMip(RaycasterBase):
    """Maximum intensity projection coloured by where the maximum lies: near warm, far cool."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]  # entry and exit come with EntryExit
    outports = [Outport("image", Image)]
    components = (EntryExit(), CameraRays(), VolumeSampling(), Sampling(), Background())

    near_colour = ColorProperty((1.0, 0.55, 0.1, 1.0), doc="colour of a maximum at the ray's entry")
    far_colour = ColorProperty((0.1, 0.45, 1.0, 1.0), doc="colour of a maximum at the ray's exit")

    def __init__(self, id=None, **values):
        super().__init__(id, **values)
        self._targets = RenderTargets(1)  # drawn into again each frame

    def process(self, volume, entry, exit):
        frame = self.frame(volume, entry, exit)
        (image,) = self._targets.ensure(frame.ctx, entry.size)
        own = Binding(uniforms={"near_colour": tuple(self.near_colour[:3]),
                                "far_colour": tuple(self.far_colour[:3])})
        self.draw(frame, "depth_mip.frag.glsl", self._targets, own=own)
        return image
