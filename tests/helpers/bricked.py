"""The bricked ray caster's test volumes, cameras and transfer function, and its picture beside the
RayCaster's: what tests/test_bricked_raycaster.py and the bricks' other tests (paged, leaf, mask,
method, level-of-detail, ray requests) share.

- ``SIZE``, ``FINEST``, ``WINDOW``, ``FLAT``: the frames' size, the lod_bias that keeps every brick
  at level 0, a windowed transfer function and one of constant opacity (a uniform medium)
- ``field``, ``odd_volume``, ``big_volume``: synthetic volumes whose features cross brick borders
- ``oblique``: a camera looking at a volume's box obliquely
- ``render``: a ray caster's image, depth and processor (the pass per brick unless told)
- ``psnr``: of two images in [0, 1]
- ``bonsai``: the fixture of the CT bonsai at 64^3 (import it into the test module, as a fixture)
"""

import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.io import read_volume
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import UNSHADED_RAMP
from helpers.paths import DATA

SIZE = (64, 56)
FINEST = -16.0  # lod_bias that keeps every brick at level 0
WINDOW = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.4, 0.9, 0.0),
                                  (0.6, 1.0, 0.7, 0.2, 0.3), (1.0, 1, 1, 1, 0.6)])
FLAT = TransferFunction(points=[(0.0, 0.2, 0.7, 0.9, 0.03), (1.0, 0.2, 0.7, 0.9, 0.03)])  # a uniform medium


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0.0 else 10.0 * np.log10(1.0 / mse)


def field(shape, dtype=np.float32) -> np.ndarray:
    """A ball with ripples, crossing brick borders everywhere, in [0, 1]."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in shape], indexing="ij")
    values = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.15 * np.sin(9 * x) * np.cos(7 * z)
    values = (values - values.min()) / (values.max() - values.min())
    return values.astype(dtype)


def odd_volume() -> Volume:
    return Volume(field((37, 29, 41)), spacing=(1.0, 1.1, 0.9), origin=(-3.0, 2.0, 1.0))


def big_volume() -> Volume:
    return Volume(field((128, 128, 128)))


def oblique(volume, **changes) -> Camera:
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    return camera.model_copy(update=changes) if changes else camera


def render(volume, camera, processor="BrickedRayCaster", size=SIZE, **properties):
    # Both ray casters unshaded with the normalised ramp unless told (the palette's RayCaster starts
    # shaded with the auto transfer function): the comparisons are of one configuration. These are the
    # pass per brick's tests: ``method`` passes unless told (auto draws dvr and iso in one pass,
    # tests/test_paged_bricks.py and tests/test_bricked_method.py).
    if processor == "BrickedRayCaster":
        properties = {"method": "passes", **properties}
    network = ray_caster_network(volume, camera, processor, **{**UNSHADED_RAMP, **properties})
    image = np.asarray(network.evaluate("rc.image", size=size))
    depth = np.asarray(network.evaluate("rc.depth", size=size))
    return image, depth, network["rc"]


@pytest.fixture(scope="module")
def bonsai():
    path = DATA / "ct_bonsai" / "bonsai.nii.gz"
    if not path.exists():
        pytest.skip(f"shared data not found at {path}")
    full = read_volume(path)
    return Volume(np.ascontiguousarray(full.data[::4, ::4, ::4]), spacing=(4.0, 4.0, 4.0), origin=full.origin)
