"""What the MultiVolumeRayCaster's tests share: their network and oblique camera, their transfer
functions, the tolerance against the CPU reference, moved copies of a volume, and the check that
clip planes and a crop box of the EntryExitPoints cut every channel as they cut the reference's rays."""

import numpy as np

from vgraph.camera import Camera
from vgraph.network import Network
from vgraph.numerics.multivolume_reference import render_channels
from vgraph.numerics.reference_raycast import Shading, volume_box
from vgraph.testing import GivenVolume
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

# Max |difference| per channel against the CPU reference: float32 sampling and entry points against
# float64 (the RayCaster's tolerance). Measured on llvmpipe: up to ~2e-6.
REFERENCE_TOLERANCE = 2e-5
ORANGE = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.4, 1.0, 0.5, 0.1, 0.0), (0.6, 1.0, 0.6, 0.2, 0.5),
                                  (1.0, 1.0, 0.9, 0.6, 0.8)])
BLUE = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.1, 0.4, 1.0, 0.0), (0.55, 0.2, 0.5, 1.0, 0.4),
                                (1.0, 0.6, 0.8, 1.0, 0.9)])
RED_RAMP = TransferFunction(points=[(0.0, 1, 0, 0, 0), (1.0, 1, 0, 0, 1)])  # alpha = intensity
GREEN_RAMP = TransferFunction(points=[(0.0, 0, 1, 0, 0), (1.0, 0, 1, 0, 1)])


def shifted(volume: Volume, voxels) -> Volume:
    """The same samples moved by whole voxels (x, y, z): B(p) = A(p - shift)."""
    offset = np.asarray(voxels, dtype=np.float64) * np.asarray(volume.spacing)
    return Volume(volume.data, spacing=volume.spacing, origin=tuple(np.asarray(volume.origin) + offset))


def assert_cut_like_the_reference(network, channels, camera, size, planes, crop) -> None:
    """Set ``planes`` and ``crop`` on the network's 'eep' (shaded 'mv'): the GL image equals the
    reference cut the same way, and the cut changes the picture."""
    network.set("eep.clip_planes", planes)
    network.set("eep.crop_box", crop)
    gl = network.evaluate("mv.image", size=size)
    reference = render_channels(channels, camera, size, shading=Shading(), crop_box=crop,
                                clip_planes=network.get("eep.clip_planes"))
    whole = render_channels(channels, camera, size, shading=Shading())
    assert np.abs(reference - whole).max() > 0.3
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


EEP_PORTS = ("volume", "volume2", "volume3", "volume4")


def multivolume_network(volumes, camera, ports=None, **properties) -> Network:
    """GivenVolume 'src{n}' per volume -> MultiVolumeRayCaster 'mv' (on inports ``ports``, by
    default volume1, volume2, ...); all volumes also feed the EntryExitPoints 'eep' (its
    ``volume``, ``volume2``, ...), so the rays span the union of their boxes."""
    network = Network()
    network.add("EntryExitPoints", id="eep", camera=camera)
    network.add("MultiVolumeRayCaster", id="mv", **properties)
    network.link("eep.camera", "mv.camera")
    ports = ports or [f"volume{n}" for n in range(1, len(volumes) + 1)]
    for n, (volume, port) in enumerate(zip(volumes, ports), start=1):
        network.add(GivenVolume(id=f"src{n}", volume=volume))
        network.connect(f"src{n}.volume", f"mv.{port}")
        network.connect(f"src{n}.volume", f"eep.{EEP_PORTS[n - 1]}")
    for source, target in (("eep.entry", "mv.entry"), ("eep.exit", "mv.exit")):
        network.connect(source, target)
    return network


def oblique_camera(volume):
    return Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
