"""Configurations of the ray casters whose outputs are fingerprinted (SHA-256 of every output
array), so that a refactoring can show its images are bit-identical: tests/test_raycaster_fingerprints.py
compares them with tests/data/raycaster_fingerprints.json, recorded on one GL renderer."""

from __future__ import annotations

import hashlib

import numpy as np

from vgraph.camera import Camera
from vgraph.network import Network
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume

from helpers.networks import UNSHADED_RAMP

SIZE = (48, 40)
OBLIQUE = Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(-0.45, -0.35, -1.0))
ORTHO = Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(0.3, -0.5, -1.0), projection="orthographic")


def ball(dtype: str) -> Volume:
    grid = np.linspace(-1.0, 1.0, 20)
    z, y, x = np.meshgrid(grid, grid, grid, indexing="ij")
    field = np.clip(1.2 - np.sqrt(x * x + 1.5 * y * y + z * z), 0.0, 1.0) + 0.1 * np.sin(7 * x) * y
    field = (field - field.min()) / (field.max() - field.min())
    data = {"uint8": np.round(field * 255).astype(np.uint8), "uint16": np.round(field * 65535).astype(np.uint16),
            "float32": field.astype(np.float32)}[dtype]
    return Volume(data, spacing=(2 / 19, 2 / 19 * 1.2, 2 / 19), origin=(-1.0, -1.2, -1.0))


RAYCASTER = [
    {"compositing": mode} for mode in ("dvr", "mip", "iso", "first_hit", "xray")
] + [
    {"compositing": "dvr", "shading": "blinn_phong", "derivatives": g} for g in ("forward", "backward", "central", "sobel")
] + [
    {"compositing": "iso", "shading": "blinn_phong", "light": "direction", "light_direction": [1, -2, 0.5]},
    {"compositing": "dvr", "interpolation": "nearest"},
    {"compositing": "dvr", "empty_space_skipping": False, "sampling_rate": 2.0},
    {"compositing": "mip", "empty_space_skipping": False, "sampling_rate": 0.5},
    {"compositing": "iso", "iso_level": 0.3, "background": [0.2, 0.1, 0.0, 1.0]},
]


# The defaults the fingerprints were recorded with: the palette's RayCaster has started with the
# auto transfer function and shading since (network format version 3); the cases keep the recorded
# configurations, which is what the fingerprints compare.
RECORDED_DEFAULTS = UNSHADED_RAMP


def raycaster_cases():
    for index, properties in enumerate(RAYCASTER):
        for dtype in ("uint8", "float32") if index < 5 else ("uint16",):
            for camera_name, camera in (("oblique", OBLIQUE), ("ortho", ORTHO)) if index < 5 else (("oblique", OBLIQUE),):
                yield (f"RayCaster {properties} {dtype} {camera_name}",
                       lambda p=properties, d=dtype, c=camera: ray_caster_network(
                           ball(d), c, "RayCaster", **{**RECORDED_DEFAULTS, **p}),
                       ("image", "depth"))


def curvature_network(kind: str, derivatives: str, camera: Camera, **properties) -> Network:
    network = Network()
    network.add("FunctionSelector", id="f", function="torus", resolution=24, data_type="float32")
    spline = derivatives.startswith("tricubic")
    if spline:
        network.add("CubicSplineProcessor", id="spline")
        network.connect("f.volume", "spline.volume")
    source = "spline.volume" if spline else "f.volume"
    network.add("EntryExitPoints", id="eep", camera=camera)
    network.add(kind, id="rc", derivatives=derivatives, **properties)
    network.link("eep.camera", "rc.camera")
    for a, b in ((source, "eep.volume"), (source, "rc.volume"), ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit")):
        network.connect(a, b)
    return network


CURVATURE = [
    {"derivatives": d} for d in ("forward", "central", "filtered", "tricubic", "tricubic_fast")
] + [
    {"derivatives": "tricubic", "curvature": m, "normalization": n}
    for m, n in (("k1", "exponential"), ("k2", "linear"), ("mean", "linear"), ("curvedness", "exponential"),
                 ("shape_index", "linear"))
] + [
    {"derivatives": "central", "shading": "none", "empty_space_skipping": False, "sampling_rate": 2.0},
    {"derivatives": "tricubic", "colormap": "viridis", "contour_width": 0.0, "light": "direction"},
]


def curvature_cases():
    for properties in CURVATURE:
        level = {k: v for k, v in properties.items() if k != "derivatives"}
        yield (f"CurvatureRaycaster {properties}",
               lambda p=properties, l=level: curvature_network("CurvatureRaycaster", p["derivatives"], OBLIQUE, **l),
               ("image", "curvature", "position", "depth"))
        volume_level = {k: v for k, v in level.items() if k != "contour_width"}
        yield (f"CurvatureVolumeRaycaster {properties}",
               lambda p=properties, l=volume_level: curvature_network("CurvatureVolumeRaycaster", p["derivatives"],
                                                                      OBLIQUE, **l),
               ("image", "depth"))


def all_cases():
    from helpers.more_raycaster_cases import more_cases
    yield from raycaster_cases()
    yield from curvature_cases()
    yield from more_cases()


def fingerprint(network: Network, outports) -> dict[str, str]:
    found = {}
    for outport in outports:
        pixels = np.ascontiguousarray(network.evaluate(f"rc.{outport}", size=SIZE))
        found[outport] = hashlib.sha256(pixels.tobytes()).hexdigest()[:20]
    return found


def fingerprints() -> dict[str, dict[str, str]]:
    return {name: fingerprint(make(), outports) for name, make, outports in all_cases()}


if __name__ == "__main__":  # record: cd tests && python -m helpers.raycaster_cases
    import json
    import sys
    from pathlib import Path

    from vgraph.gl_context import get_context
    info = get_context().info
    target = Path(__file__).parents[1] / "data" / "raycaster_fingerprints.json"
    target.write_text(json.dumps({"renderer": info["GL_RENDERER"], "version": info["GL_VERSION"],
                                  "fingerprints": fingerprints()}, indent=1, sort_keys=True))
    print(f"recorded {target}", file=sys.stderr)
