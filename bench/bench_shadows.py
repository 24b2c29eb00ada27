"""Volumetric shadows: the cost of the light volume (numpy sweep against a GL pass per slice), the
cost of a shadowed frame against the unshadowed one, and the error (the light volume against
shadow rays; the shadowed image against the unshadowed one).

    .venv/bin/python bench/bench_shadows.py [--volume bonsai|sphere] [--resolution 128]
        [--size 512] [--rounds 5] [--light -0.4 -1 1.2] [--points 3000]

Conventions:
- Volume: the CT bonsai (256^3 uint8, shared/data) with bench/raycaster_speed's BONSAI_TF, or the
  FunctionSelector sphere at --resolution with a half-transparent shell TF. Light: --light (world,
  towards the light), the RayCaster shaded with the same light (``light = direction``).
- Light-volume cost: classification plus the sweep, from the volume to T: vgraph's numpy sweep on
  sheared grids (vgraph.numerics.light_volume, rule 3) or bench/gl_light_sweep.py's GL pass per
  slice (the voxels classified first, the optical depth resampled every slice, read back slice by
  slice), or the numpy sweep on a copy at half the voxels per axis (VolumeResample, linear; the
  RayCaster samples a light volume on its own grid). Interleaved rounds (bench/interleave.py) after an untimed warm-up each; min / median /
  max seconds.
- Frame cost: RayCaster dvr + Blinn-Phong at --size^2, the camera orbiting 7 degrees a round, with
  and without the light volume connected (precomputed gradients, empty-space skipping as the
  defaults); interleaved after a warm-up frame each; the light volume is built before (it changes
  only with the TF or the light, not the camera).
- Error of each sweep: |T_sweep - T_rays| at --points random voxels where the TF is visible, T_rays
  from vgraph.numerics.reference_shadows (step min(spacing) / 4), T_sweep as the 16-bit codes. Error against the unshadowed
  frame: how much shadows change the picture, 8-bit RGB, max and mean over the pixels.
- Timings are wall-clock on whatever machine runs this (say which, and its load, beside them).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gl_light_sweep import GlSweep  # noqa: E402
from interleave import interleaved, spread  # noqa: E402
from raycaster_speed import BONSAI, BONSAI_TF, load_bonsai  # noqa: E402

from vgraph.camera import Camera  # noqa: E402
from vgraph.implicit import sample  # noqa: E402
from vgraph.numerics.light_volume import CODES, extinction, index_light, light_volume  # noqa: E402
from vgraph.numerics.reference_raycast import VolumeSampler, lookup, volume_box  # noqa: E402
from vgraph.numerics.reference_shadows import shadow_rays, shadowed  # noqa: E402
from vgraph.processors.volume_resample import VolumeResample  # noqa: E402
from vgraph.scheduler import finish_gl  # noqa: E402
from vgraph.testing import GivenVolume, ray_caster_network  # noqa: E402
from vgraph.transfer_function import TransferFunction  # noqa: E402

SPHERE_TF = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (0.45, 1, 1, 1, 0.0),
                                     (0.55, 0.9, 0.8, 0.6, 0.3), (1.0, 0.9, 0.8, 0.6, 0.3)])


def load(name: str, resolution: int):
    if name == "bonsai":
        if not BONSAI.is_file():
            raise SystemExit(f"{BONSAI} not found: use --volume sphere")
        return load_bonsai(), BONSAI_TF
    return sample("sphere", resolution, "float32"), SPHERE_TF


def light_volume_costs(volume, tf, light, rounds: int):
    """Seconds of each variant and its light volume (T as 16-bit codes, as light_volume stores it)."""
    index = index_light(volume, light)
    gl = GlSweep()
    results = {}

    def numpy_sweep(_):
        start = time.perf_counter()
        results["numpy sheared sweep"] = light_volume(volume, tf, light)
        return time.perf_counter() - start

    def gl_sweep(_):
        start = time.perf_counter()
        t = gl.transmittance(extinction(volume, tf), volume.spacing, index)
        results["GL pass per slice"] = lit.with_data(np.rint(np.clip(t, 0.0, 1.0) * CODES).astype(np.uint16))
        return time.perf_counter() - start

    def half_size(_):
        start = time.perf_counter()
        half = VolumeResample(id="half", mode="size", size=[max(1, n // 2) for n in volume.dims]).process(volume)
        results["numpy, half size per axis"] = light_volume(half, tf, light)
        return time.perf_counter() - start

    lit = light_volume(volume, tf, light)
    seconds, _ = interleaved({"numpy sheared sweep": numpy_sweep, "GL pass per slice": gl_sweep,
                              "numpy, half size per axis": half_size}, [None] * rounds, None)
    return seconds, results


def frame_costs(volume, tf, light, size: int, rounds: int):
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.45, -0.35, -1.0))
    cameras = [camera.rotate(math.radians(7.0 * r), 0.0) for r in range(rounds + 1)]
    lit = light_volume(volume, tf, light)
    networks = {}
    for name in ("unshadowed", "shadowed"):
        network = ray_caster_network(volume, camera, transfer_function=tf, shading="blinn_phong",
                                     derivatives="precomputed", light="direction", light_direction=light)
        if name == "shadowed":
            network.add(GivenVolume(id="light", volume=lit))
            network.connect("light.volume", "rc.light_volume")
        networks[name] = network

    def frame(network):
        def draw(camera):
            network.set("eep.camera", camera)
            start = time.perf_counter()
            network.evaluate("rc.image", size=(size, size))
            finish_gl()
            return time.perf_counter() - start
        return draw

    seconds, _ = interleaved({name: frame(n) for name, n in networks.items()}, cameras[1:], cameras[0])
    images = {}
    for name, network in networks.items():
        network.set("eep.camera", cameras[0])
        images[name] = np.rint(np.clip(network.evaluate("rc.image", size=(size, size))[..., :3], 0, 1) * 255)
    change = np.abs(images["shadowed"] - images["unshadowed"])
    return seconds, change


def sweep_error(volume, tf, light, lit, points: int):
    """|T_sweep - T_rays| at random voxels the TF shows (the same voxels for every light volume
    ``lit``, sampled trilinearly there: its own voxels where it has the volume's grid)."""
    rng = np.random.default_rng(0)
    alpha = lookup(tf.for_volume(volume).lut().astype(np.float64)[:, 3:4],
                   VolumeSampler(volume).flat)[:, 0]
    visible = np.flatnonzero(alpha > 0.0)
    chosen = rng.choice(visible, size=min(points, visible.size), replace=False)
    nx, ny = volume.dims[0], volume.dims[1]
    ijk = np.stack([chosen % nx, (chosen // nx) % ny, chosen // (nx * ny)], axis=1)
    world = volume.voxel_to_world(ijk)
    sweep = shadowed(lit)(world)
    rays = shadow_rays(volume, tf, light)(world)
    return np.abs(sweep - rays)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", choices=["bonsai", "sphere"], default="bonsai")
    parser.add_argument("--resolution", type=int, default=128, help="sphere voxels per axis")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--light", type=float, nargs=3, default=(-0.4, -1.0, 1.2))
    parser.add_argument("--points", type=int, default=3000)
    args = parser.parse_args()
    volume, tf = load(args.volume, args.resolution)
    light = tuple(args.light)
    print(f"volume {args.volume} {' x '.join(map(str, volume.dims))} {volume.data.dtype}, light {light}, "
          f"image {args.size}^2, {args.rounds} interleaved rounds after a warm-up, "
          f"shadow-ray error at {args.points} visible voxels")
    seconds, results = light_volume_costs(volume, tf, light, args.rounds)
    print("\nlight volume (classification + sweep), seconds min / median / max; |T - T_shadow_rays| at "
          f"{args.points} visible voxels: max / mean / 99th percentile")
    for name, values in seconds.items():
        error = sweep_error(volume, tf, light, results[name], args.points)
        print(f"  {name:26s} {spread(values)}   error {error.max():.3f} / {error.mean():.4f} / "
              f"{np.percentile(error, 99):.3f}")
    frames, change = frame_costs(volume, tf, light, args.size, args.rounds)
    print(f"\nframe (dvr, Blinn-Phong, {args.size}^2), seconds min / median / max")
    for name, values in frames.items():
        print(f"  {name:18s} {spread(values)}")
    ratio = np.median(frames["shadowed"]) / np.median(frames["unshadowed"])
    print(f"  shadowed / unshadowed (medians): {ratio:.2f}")
    print(f"  shadowed vs unshadowed image, 8-bit RGB: max {change.max():.0f}, mean {change.mean():.1f}, "
          f"pixels changed by more than 8: {np.mean(change.max(axis=-1) > 8) * 100:.0f} %")


if __name__ == "__main__":
    main()
