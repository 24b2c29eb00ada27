"""An analytic sphere picked in iso mode (issue 36): how far the picked point lies from the exact
surface, for the GL's depth with nearest and trilinear interpolation and for the point refined on
the tricubic B-spline surface. Shared by tests/test_picking.py and bench_picking_accuracy.py.

The volume samples f(p) = R - |p - c| (world units; the inside is higher, as CT) on a grid of
``voxel`` world units a side, declared range (-R, R), so the iso level 0.5 is the value 0: the
sphere of radius R. An orthographic camera looks at the centre along -z (front) or +z (back) on
an odd canvas, so the middle pixel's ray passes through the centre: its picks from the front and
the back are antipodal points, and the ruler between them measures the diameter.
"""

from __future__ import annotations

import numpy as np

from vgraph.camera import Camera
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume

RADIUS = 10.0           # world units
CENTRE = (0.3, -0.2, 0.1)  # off the grid's symmetry, so no sample sits exactly on the surface by luck
CANVAS = 65             # odd: pixel 32 is the view's centre
MARGIN = 3.0            # voxels of grid beyond the sphere


def sphere_volume(voxel: float) -> Volume:
    half = RADIUS + MARGIN * voxel
    count = int(np.ceil(2 * half / voxel)) + 1
    axis = -half + voxel * np.arange(count)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    distance = np.sqrt((x - CENTRE[0]) ** 2 + (y - CENTRE[1]) ** 2 + (z - CENTRE[2]) ** 2)
    data = (RADIUS - distance).astype(np.float32)
    return Volume(data, spacing=(voxel,) * 3, origin=(-half,) * 3, declared_range=(-RADIUS, RADIUS))


def sphere_network(voxel: float, interpolation: str = "trilinear", side: str = "front"):
    """The sphere's volume -> EntryExitPoints -> RayCaster (iso at the sphere) -> Canvas 'canvas'."""
    sign = 1.0 if side == "front" else -1.0
    position = (CENTRE[0], CENTRE[1], CENTRE[2] + sign * 4 * RADIUS)
    camera = Camera(projection="orthographic", position=position, focus=CENTRE, up=(0.0, 1.0, 0.0),
                    parallel_scale=1.3 * RADIUS, fit_to_data=False)
    network = ray_caster_network(sphere_volume(voxel), camera, compositing="iso", iso_level=0.5,
                                 interpolation=interpolation, sampling_rate=4.0)
    network.add("Canvas", id="canvas", size=(CANVAS, CANVAS))
    network.connect("rc.image", "canvas.image")
    return network


def radius_error(point) -> float:
    """|p - c| - R, world units."""
    return float(np.linalg.norm(np.subtract(point, CENTRE)) - RADIUS)


def ring_pixels(count: int = 24) -> list[tuple[int, int]]:
    """Pixels on a ring at 0.7 of the sphere's radius around the centre pixel (oblique rays)."""
    middle, reach = (CANVAS - 1) / 2, 0.7 * RADIUS / (1.3 * RADIUS) * CANVAS / 2
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return [(round(middle + reach * np.cos(a)), round(middle + reach * np.sin(a))) for a in angles]


def errors(voxel: float) -> dict[str, float]:
    """Largest |radius error| in voxels over the centre pixel and a ring, by method."""
    worst = {"nearest": 0.0, "linear": 0.0, "tricubic": 0.0}
    for interpolation, methods in (("nearest", ("nearest",)), ("trilinear", ("linear", "tricubic"))):
        network = sphere_network(voxel, interpolation)
        for x, y in [((CANVAS - 1) // 2, (CANVAS - 1) // 2)] + ring_pixels():
            result = network.pick("canvas", x, y)
            found = {"nearest": result.point, "linear": result.point,
                     "tricubic": result.surface.point if result.surface else None}
            for method in methods:
                worst[method] = max(worst[method], abs(radius_error(found[method])) / voxel)
    return worst


def diameter(voxel: float, method: str = "tricubic") -> float:
    """The ruler between the centre pixel's picks from the front and from the back (world units)."""
    interpolation = "nearest" if method == "nearest" else "trilinear"
    ends = []
    for side in ("front", "back"):
        result = sphere_network(voxel, interpolation, side).pick("canvas", CANVAS // 2, CANVAS // 2)
        ends.append(np.asarray(result.surface.point if method == "tricubic" else result.point))
    return float(np.linalg.norm(ends[1] - ends[0]))
