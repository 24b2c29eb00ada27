"""What the SweepPlaneRenderer's tests share (tests/test_sweep_plane.py, test_sweep_vs_tetrahedra.py):
the frames' size, the transfer function, the cameras of both projections, a smooth and a step
volume, the PSNR and the exact CPU reference (the reference ray caster at 16 samples per
min(spacing), whose own error is far below the tests' bounds)."""

from __future__ import annotations

import numpy as np

from vgraph.camera import Camera
from vgraph.numerics import reference_raycast
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

SIZE = (64, 64)
EXACT_RATE = 16  # samples per min(spacing) of the "exact" reference
TF = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.0), (0.3, 0.2, 0.6, 0.9, 0.05),
                              (0.7, 0.9, 0.7, 0.2, 0.3), (1.0, 1.0, 0.3, 0.1, 0.6)])
PROJECTIONS = ("perspective", "orthographic")


def camera(projection: str) -> Camera:
    return Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(-0.45, -0.35, -1.0),
                                 projection=projection)


def grid(n: int = 24):
    g = np.linspace(-1.0, 1.0, n)
    return np.meshgrid(g, g, g, indexing="ij")  # z, y, x


def smooth_volume() -> Volume:
    """A Gaussian blob with a ripple on an anisotropic grid."""
    n = 24
    z, y, x = grid(n)
    field = np.exp(-(x * x + 1.5 * y * y + z * z) * 2.5) + 0.15 * np.sin(3 * x) * y
    return Volume(field.astype(np.float32), spacing=(2 / (n - 1), 2.4 / (n - 1), 2 / (n - 1)),
                  origin=(-1.0, -1.2, -1.0))


def step_volume() -> Volume:
    """0 on one side of an oblique plane, 1 on the other: the stiffest field a grid holds."""
    n = 24
    z, y, x = grid(n)
    return Volume(np.where(x + 0.3 * y > 0.1, 1.0, 0.0).astype(np.float32), spacing=(2 / (n - 1),) * 3,
                  origin=(-1.0, -1.0, -1.0))


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    return float(10.0 * np.log10(1.0 / np.mean((a[..., :3] - b[..., :3]) ** 2)))


def exact(volume: Volume, projection: str) -> np.ndarray:
    return reference_raycast.render(volume, camera(projection), TF, SIZE, sampling_rate=EXACT_RATE)
