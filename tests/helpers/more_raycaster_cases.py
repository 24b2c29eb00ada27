"""Configurations of the LabelRayCaster, the MultiVolumeRayCaster and the BrickedRayCaster (and the
RayCaster drawing a volume brick by brick) fingerprinted like the three ray casters of
helpers.raycaster_cases, recorded before they were rebuilt on the shared components."""

from __future__ import annotations

import numpy as np

from vgraph.camera import Camera
from vgraph.implicit import sample
from vgraph.labels import LabelEntry, LabelTable
from vgraph.network import Network
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.volume import Volume

from helpers.networks import UNSHADED_RAMP


def oblique(volume: Volume) -> Camera:
    low = np.asarray(volume.origin, dtype=float) - 0.5 * np.asarray(volume.spacing)
    high = low + np.asarray(volume.dims) * np.asarray(volume.spacing)
    return Camera.looking_at_box(tuple(low), tuple(high), direction=(-0.5, -0.3, -1.0))


def labels() -> Volume:
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (14, 12, 16)], indexing="ij")
    classes = (np.sin(3 * x) * np.cos(2 * y) + z > 0).astype(np.uint8) + 2 * (x * x + y * y + z * z < 0.4)
    return Volume(np.array([0, 1, 2, 5], dtype=np.uint8)[classes], spacing=(0.8, 1.0, 0.5), origin=(1.0, -2.0, 3.0))


TABLE = LabelTable(labels=[LabelEntry(value=0, opacity=0.0, visible=False),
                           LabelEntry(value=1, color=(0.9, 0.6, 0.2), opacity=0.3),
                           LabelEntry(value=2, color=(0.2, 0.5, 0.9), opacity=0.6)])
LABEL = [{"compositing": "composite"}, {"compositing": "composite", "sampling_rate": 2.5},
         {"compositing": "composite", "shading": "blinn_phong"}, {"compositing": "first_hit"},
         {"compositing": "first_hit", "shading": "blinn_phong", "sampling_rate": 0.7}]


def label_cases():
    for properties in LABEL:
        yield (f"LabelRayCaster {properties}",
               lambda p=properties: ray_caster_network(labels(), oblique(labels()), "LabelRayCaster", "rc",
                                                        inport="labels", label_table=TABLE,
                                                        **{"shading": "none", **p}),
               ("image",))


def multivolume_network(count: int, **properties) -> Network:
    torus = sample("torus", 28, "float32")
    sphere = Volume(sample("sphere", 20, "uint16").data, spacing=(0.13, 0.09, 0.11), origin=(-1.3, -0.7, -0.9))
    volumes = [torus, sphere, Volume(torus.data, spacing=torus.spacing,
                                     origin=tuple(np.asarray(torus.origin) + 0.2))][:count]
    network = Network()
    network.add("EntryExitPoints", id="eep", camera=oblique(torus))
    network.add("MultiVolumeRayCaster", id="rc", **properties)
    network.link("eep.camera", "rc.camera")
    for n, volume in enumerate(volumes, start=1):
        network.add(GivenVolume(id=f"src{n}", volume=volume))
        network.connect(f"src{n}.volume", f"rc.volume{n}")
        network.connect(f"src{n}.volume", "eep.volume" if n == 1 else f"eep.volume{n}")
    network.connect("eep.entry", "rc.entry")
    network.connect("eep.exit", "rc.exit")
    return network


MULTIVOLUME = [{"blend": "accumulate"}, {"blend": "nearest_opaque", "opacity_threshold": 0.2}, {"blend": "maximum"}] + [
    {"blend": "accumulate", "sampling_rate": 2.0, "shading": "blinn_phong"},
    {"blend": "nearest_opaque", "opacity_threshold": 0.2, "shading": "blinn_phong"}]


def multivolume_cases():
    for properties in MULTIVOLUME:
        for count in (1, 3):
            yield (f"MultiVolumeRayCaster {properties} x{count}",
                   lambda p=properties, c=count: multivolume_network(c, **p), ("image", "depth"))


def field(shape) -> Volume:
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in shape], indexing="ij")
    values = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.15 * np.sin(9 * x) * np.cos(7 * z)
    values = (values - values.min()) / (values.max() - values.min())
    return Volume(values.astype(np.float32), spacing=(1.0, 1.1, 0.9), origin=(-3.0, 2.0, 1.0))


BRICKED = [{"compositing": m, "brick_size": 16, "lod_bias": -16.0} for m in ("dvr", "mip", "iso")] + [
    {"compositing": "dvr", "brick_size": 16, "lod_bias": -16.0, "shading": "blinn_phong"},
    {"compositing": "iso", "brick_size": 16, "lod_bias": -16.0, "shading": "blinn_phong",
     "derivatives": "forward"},
    {"compositing": "dvr", "brick_size": 32, "lod_bias": -16.0, "empty_space_skipping": False,
     "early_termination": 0.99, "sampling_rate": 2.0},
    {"compositing": "dvr", "brick_size": 16, "lod_bias": 4.0}]


def bricked_cases():
    # method passes, as recorded (the default auto draws dvr, iso and mip in one pass since issue #33,
    # item 3; tests/test_paged_bricks.py holds the single pass to the RayCaster's image)
    for properties in BRICKED:
        yield (f"BrickedRayCaster {properties}",
               lambda p=properties: ray_caster_network(field((37, 29, 41)), oblique(field((37, 29, 41))),
                                                        "BrickedRayCaster",
                                                        **{**UNSHADED_RAMP, "method": "passes", **p}),
               ("image", "depth"))


def wide() -> Volume:
    from vgraph.gl_context import get_context
    limit = get_context().info["GL_MAX_3D_TEXTURE_SIZE"]
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (6, 5, limit + 40)], indexing="ij")
    return Volume((np.clip(1 - np.sqrt(x * x + y * y + z * z), 0, 1)).astype(np.float32), spacing=(0.01, 1.0, 1.0))


def bricked_raycaster_cases():
    for mode in ("dvr", "mip"):
        yield (f"RayCaster brick by brick {mode}",
               lambda m=mode: ray_caster_network(wide(), oblique(wide()), "RayCaster",
                                                  **{**UNSHADED_RAMP, "compositing": m}),
               ("image", "depth"))


def more_cases():
    yield from label_cases()
    yield from multivolume_cases()
    yield from bricked_cases()
    yield from bricked_raycaster_cases()
