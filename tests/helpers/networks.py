"""Networks the rendering tests build."""

from vgraph.gl.raycasting.components import TransferFunctionLut
from vgraph.testing import ray_caster_network

# What the rendering tests were written against and the CPU reference assumes unless told: no
# shading and the ray casters' normalised ramp. The palette's RayCaster starts shaded with the auto
# transfer function (network format version 3, docs/reference/general/network-format.md), as `vgraph run FILE` does.
UNSHADED_RAMP = {"transfer_function": TransferFunctionLut.DEFAULT, "shading": "none"}


def rendering_network(volume, camera, **raycaster):
    """GivenVolume -> EntryExitPoints -> RayCaster 'rc', cameras linked (vgraph.testing); unshaded
    with the normalised ramp unless ``raycaster`` says otherwise."""
    return ray_caster_network(volume, camera, "RayCaster", id="rc", **{**UNSHADED_RAMP, **raycaster})


def bricked_sphere_network(canvas_size):
    """A FunctionSelector sphere (128^3) -> EntryExitPoints -> BrickedRayCaster 'rc' (mip, 16^3
    bricks, finest level) -> Canvas: savable, so the GUI can open it; big enough to refine."""
    from vgraph.camera import Camera
    from vgraph.network import Network
    network = Network()
    network.add("FunctionSelector", id="source", function="sphere", resolution=128)
    network.add("EntryExitPoints", id="eep", camera=Camera(position=(2.6, 2.0, 5.8), near=4.0, far=9.0))
    network.add("BrickedRayCaster", id="rc", compositing="mip", brick_size=16, lod_bias=-16.0)
    network.add("Canvas", id="canvas", size=canvas_size)
    network.link("eep.camera", "rc.camera")
    for source, target in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit"), ("rc.image", "canvas.image")):
        network.connect(source, target)
    return network
