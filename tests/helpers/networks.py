"""Networks the rendering tests build."""

from vgraph.testing import ray_caster_network


def rendering_network(volume, camera, **raycaster):
    """GivenVolume -> EntryExitPoints -> RayCaster 'rc', cameras linked (vgraph.testing)."""
    return ray_caster_network(volume, camera, "RayCaster", id="rc", **raycaster)
