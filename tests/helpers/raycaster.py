"""What the RayCaster's tests against the CPU reference share (tests/test_raycaster.py,
test_volume_precision.py): the tolerance, two transfer functions, the frames' size and an oblique
camera."""

from vgraph.camera import Camera
from vgraph.numerics.reference_raycast import volume_box
from vgraph.transfer_function import TransferFunction

# Tolerance against the CPU reference (max |difference| per channel). Measured on llvmpipe:
# ~1.3e-6 (float32 arithmetic; float-weight trilinear filtering of 16-bit and float textures).
REFERENCE_TOLERANCE = 2e-5
IDENTITY = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 1.0), (1.0, 1.0, 1.0, 1.0, 1.0)])
COLOURED = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.45, 0.2, 0.4, 0.9, 0.0),
                                    (0.55, 1.0, 0.7, 0.2, 0.5), (1.0, 1, 1, 1, 0.8)])
SIZE = (56, 44)


def oblique_camera(volume, **changes):
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    return camera.model_copy(update=changes) if changes else camera
