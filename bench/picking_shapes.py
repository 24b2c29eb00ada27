"""A torus and two planes at a known angle picked in iso mode (issue 36): distances and an angle
measured between picked points, for the GL's depth with nearest and trilinear interpolation and
for the point refined on the tricubic B-spline surface. Shared by tests/test_picking_shapes.py and
bench_picking_accuracy.py (--shape torus, --shape planes); the sphere is picking_sphere.py.

Both volumes sample an analytic field on a grid of ``voxel`` world units a side, reaching MARGIN
voxels beyond the shape, with a declared range (-H, H), so the iso level 0.5 is the value 0:
- torus: f(p) = r - sqrt((rho - R)^2 + z^2) about CENTRE, rho the distance from the z axis
  through it; R = 10 (the tube's centre line), r = 4 (the tube's radius).
- planes: a roof ridge along y through APEX: the solid below two planes that meet at the ridge
  at ANGLE degrees (the dihedral angle inside the solid), f = the smaller of the two signed
  distances (inside positive); its iso-surface is exactly the two planes.
Orthographic cameras on an odd canvas (CANVAS), so the middle pixel's ray goes through the focus:
- tube diameter: the middle pixels of views along -z and +z focused on the tube's centre line
  (CENTRE + (R, 0, 0)): the ruler between the two picks is 2 r.
- outer diameter: views along -x and +x focused on CENTRE: the ruler is 2 (R + r).
- chords: views along -z and +z over the whole torus; on rays through circles at R - r/2 and
  R + r/2 (oblique to the surface) the ruler between the picks from above and from below,
  against the exact chord of the tube on that ray, 2 sqrt(r^2 - (rho - R)^2).
- angle: a view along -z focused on the ridge: the middle pixel picks the ridge (the vertex), two
  pixels on the middle row a quarter of the canvas to either side pick a point on each plane; the
  angle markup through them measures ANGLE (the three points lie in one plane across the ridge).
"""

from __future__ import annotations

import math

import numpy as np

from vgraph.camera import Camera
from vgraph.markups import angle_between
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume

CENTRE = (0.3, -0.2, 0.1)   # off the grid's symmetry, as the sphere's
MAJOR, MINOR = 10.0, 4.0    # torus: the tube's centre line radius and the tube's radius
APEX = (0.3, -0.2, 0.1)     # a point of the ridge (the planes' common line, along y)
ANGLE = 70.0                # degrees between the planes, inside the solid
ARM = 10.0                  # world units of each plane below the ridge, across it
CANVAS = 65                 # odd: pixel 32 is the view's centre
MARGIN = 3.0                # voxels of grid beyond the shape
METHODS = ("nearest", "linear", "tricubic")


def _grid(voxel: float, low, high):
    """World sample coordinates (z, y, x meshgrids) covering [low, high] plus the margin."""
    low = np.asarray(low, float) - MARGIN * voxel
    counts = np.ceil((np.asarray(high, float) + MARGIN * voxel - low) / voxel).astype(int) + 1
    axes = [low[a] + voxel * np.arange(counts[a]) for a in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return x, y, z, tuple(low)


def torus_volume(voxel: float) -> Volume:
    reach = MAJOR + MINOR
    x, y, z, origin = _grid(voxel, np.subtract(CENTRE, (reach, reach, MINOR)), np.add(CENTRE, (reach, reach, MINOR)))
    rho = np.hypot(x - CENTRE[0], y - CENTRE[1])
    data = (MINOR - np.hypot(rho - MAJOR, z - CENTRE[2])).astype(np.float32)
    return Volume(data, spacing=(voxel,) * 3, origin=origin, declared_range=(-MINOR, MINOR))


def torus_distance(point) -> float:
    """The signed distance of a world point from the exact torus (outside positive)."""
    offset = np.subtract(point, CENTRE)
    return float(math.hypot(math.hypot(offset[0], offset[1]) - MAJOR, offset[2]) - MINOR)


def _plane_directions():
    """(down the plane away from the ridge, outward normal) of each plane, in the x-z plane."""
    half = math.radians(ANGLE) / 2.0
    downs = [np.array([math.sin(half), 0.0, -math.cos(half)]), np.array([-math.sin(half), 0.0, -math.cos(half)])]
    normals = [np.array([math.cos(half), 0.0, math.sin(half)]), np.array([-math.cos(half), 0.0, math.sin(half)])]
    return downs, normals


def planes_volume(voxel: float) -> Volume:
    downs, normals = _plane_directions()
    width, depth = ARM * downs[0][0], -ARM * downs[0][2]
    x, y, z, origin = _grid(voxel, np.subtract(APEX, (width, ARM / 2, depth)), np.add(APEX, (width, ARM / 2, 0.0)))
    offsets = np.stack([x - APEX[0], y - APEX[1], z - APEX[2]], axis=-1)
    data = np.minimum(-(offsets @ normals[0]), -(offsets @ normals[1])).astype(np.float32)
    return Volume(data, spacing=(voxel,) * 3, origin=origin, declared_range=(-ARM, ARM))


def plane_distance(point) -> float:
    """The distance of a world point from the nearer of the two (unbounded) planes."""
    _, normals = _plane_directions()
    offset = np.subtract(point, APEX)
    return float(min(abs(offset @ normals[0]), abs(offset @ normals[1])))


def iso_network(volume: Volume, focus, direction, up, extent: float, interpolation: str):
    """volume -> EntryExitPoints -> RayCaster (iso at value 0) -> Canvas 'canvas', looking along
    ``direction`` at ``focus`` orthographically, ``extent`` world units from the middle to the edge."""
    position = np.asarray(focus, float) - 4.0 * extent * np.asarray(direction, float)
    camera = Camera(projection="orthographic", position=tuple(position), focus=tuple(focus), up=up,
                    parallel_scale=extent, fit_to_data=False)
    network = ray_caster_network(volume, camera, compositing="iso", iso_level=0.5,
                                 interpolation=interpolation, sampling_rate=4.0)
    network.add("Canvas", id="canvas", size=(CANVAS, CANVAS))
    network.connect("rc.image", "canvas.image")
    return network


def picked(result, method: str) -> np.ndarray:
    if not result.hit:
        raise AssertionError(f"the pick missed: {result.reason}")
    return np.asarray(result.surface.point if method == "tricubic" else result.point, float)


def _interpolation(method: str) -> str:
    return "nearest" if method == "nearest" else "trilinear"


MIDDLE = CANVAS // 2


# --- the torus ----------------------------------------------------------------------------------
def torus_views(voxel: float, method: str, volume: Volume | None = None):
    """{name: network}: 'top'/'bottom' on the tube's centre line, 'front'/'back' on the centre,
    'overview'/'underside' the whole torus from above and from below."""
    volume = volume if volume is not None else torus_volume(voxel)
    tube = np.add(CENTRE, (MAJOR, 0.0, 0.0))
    reach = MAJOR + MINOR
    interpolation = _interpolation(method)
    return {"top": iso_network(volume, tube, (0, 0, -1), (0, 1, 0), 1.3 * MINOR, interpolation),
            "bottom": iso_network(volume, tube, (0, 0, 1), (0, 1, 0), 1.3 * MINOR, interpolation),
            "front": iso_network(volume, CENTRE, (-1, 0, 0), (0, 0, 1), 1.3 * reach, interpolation),
            "back": iso_network(volume, CENTRE, (1, 0, 0), (0, 0, 1), 1.3 * reach, interpolation),
            "overview": iso_network(volume, CENTRE, (0, 0, -1), (0, 1, 0), 1.3 * reach, interpolation),
            "underside": iso_network(volume, CENTRE, (0, 0, 1), (0, 1, 0), 1.3 * reach, interpolation)}


def overview_pixels(count: int = 12) -> list[tuple[int, int]]:
    """Pixels over the torus seen from above, on circles at R - r/2 and R + r/2 (oblique rays)."""
    scale = (CANVAS / 2) / (1.3 * (MAJOR + MINOR))
    angles = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False) + 0.2
    return [(round(MIDDLE + rho * scale * np.cos(a)), round(MIDDLE - rho * scale * np.sin(a)))
            for rho in (MAJOR - MINOR / 2, MAJOR + MINOR / 2) for a in angles]


def chord_error(top, bottom) -> float:
    """|top - bottom| of two picks on one vertical ray, against the exact chord of the tube there
    (world units); the two picks' rays must be the same."""
    if np.hypot(*(top - bottom)[:2]) > 1e-6 * MAJOR:
        raise AssertionError(f"the picks {top} and {bottom} are not on one vertical ray")
    offset = (top + bottom) / 2.0 - np.asarray(CENTRE)
    across = math.hypot(offset[0], offset[1]) - MAJOR
    return float(np.linalg.norm(top - bottom) - 2.0 * math.sqrt(MINOR ** 2 - across ** 2))


def torus_errors(voxel: float) -> dict[str, dict[str, float]]:
    """By method: 'surface' (largest |distance| of a pick from the torus over the overview
    pixels), 'chords' (largest |error| of the rulers between the picks from above and from below
    on the same rays), 'tube' (tube diameter error) and 'outer' (outer diameter error); voxels."""
    volume, found = torus_volume(voxel), {}
    for method in METHODS:
        views = torus_views(voxel, method, volume)
        ends = {name: picked(views[name].pick("canvas", MIDDLE, MIDDLE), method)
                for name in ("top", "bottom", "front", "back")}
        tops = [picked(views["overview"].pick("canvas", x, y), method) for x, y in overview_pixels()]
        # seen from below (along +z, y up) the image is mirrored left to right
        bottoms = [picked(views["underside"].pick("canvas", CANVAS - 1 - x, y), method) for x, y in overview_pixels()]
        found[method] = {"surface": max(abs(torus_distance(p)) for p in tops + bottoms) / voxel,
                         "chords": max(abs(chord_error(t, b)) for t, b in zip(tops, bottoms)) / voxel,
                         "tube": (np.linalg.norm(ends["top"] - ends["bottom"]) - 2 * MINOR) / voxel,
                         "outer": (np.linalg.norm(ends["front"] - ends["back"]) - 2 * (MAJOR + MINOR)) / voxel}
    return found


# --- two planes ---------------------------------------------------------------------------------
def planes_view(voxel: float, method: str, volume: Volume | None = None):
    volume = volume if volume is not None else planes_volume(voxel)
    extent = 1.3 * ARM * math.sin(math.radians(ANGLE) / 2.0)
    return iso_network(volume, APEX, (0, 0, -1), (0, 1, 0), extent, _interpolation(method))


ARM_PIXELS = CANVAS // 4   # from the middle pixel to the picks on the planes


def angle_points(network, method: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(first, vertex, last) picked: on the +x plane, on the ridge, on the -x plane."""
    return tuple(picked(network.pick("canvas", MIDDLE + dx, MIDDLE), method) for dx in (ARM_PIXELS, 0, -ARM_PIXELS))


def planes_errors(voxel: float) -> dict[str, dict[str, float]]:
    """By method: 'plane' (largest distance of the two arm picks from their plane, voxels),
    'vertex' (the vertex pick's distance from the ridge line, voxels) and 'angle' (the angle
    markup's error, degrees)."""
    volume, found = planes_volume(voxel), {}
    for method in METHODS:
        first, vertex, last = angle_points(planes_view(voxel, method, volume), method)
        ridge = np.hypot(vertex[0] - APEX[0], vertex[2] - APEX[2])
        found[method] = {"plane": max(plane_distance(first), plane_distance(last)) / voxel,
                         "vertex": float(ridge) / voxel,
                         "angle": angle_between(first - vertex, last - vertex) - ANGLE}
    return found
