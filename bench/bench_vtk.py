"""Our RayCaster side by side with VTK's vtkGPUVolumeRayCastMapper (on the same llvmpipe) and
vtkFixedPointVolumeRayCastMapper (CPU, all cores) in one run: same volume, image size, cameras,
transfer function and step, for composite, composite + shading and MIP, plus composite with a
dense fog TF (no empty space: shows the cost per sample when nothing can be skipped).

    .venv/bin/python bench/bench_vtk.py [--volume torus|bonsai] [--resolution 256] [--size 512]
        [--repeat 7] [--vtk-window egl|default] [--derivatives precomputed|central]
        [--volume-precision 16bit|full]
        [--out bench/results] [--figure PNG]

Conventions (what "the same" means here):
- Volume: the 256^3 float32 signed-distance torus of vgraph.implicit (surface at normalised 0.5)
  or the CT bonsai (256^3 uint8). VTK gets the same array as vtkImageData point data with the same
  origin and spacing, so both put voxel (i, j, k) at origin + (i, j, k) * spacing.
- Camera: vgraph Camera -> vtkCamera (position, focal point, view up, vertical view angle,
  clipping range). Frame r uses the base camera orbited by r * --azimuth degrees about its up axis,
  so no renderer can reuse a previous frame; every renderer sees the same camera sequence.
- TF: our points at normalised positions p become VTK points at lo + p * (hi - lo) of the volume's
  value range (vtkColorTransferFunction in RGB space + vtkPiecewiseFunction). Our alpha is per
  sample at step min(spacing); VTK's scalar opacity unit distance is set to min(spacing) and both
  mappers sample every min(spacing) (auto-adjust, jittering and image subsampling off), so the
  per-sample opacity is the same.
- Shading: ambient 0.3, diffuse 0.7, specular 0.2, headlight, two-sided, white. VTK uses Phong
  (R.V)^p where we use Blinn-Phong (N.H)^32; with a headlight R.V = 2 (N.L)^2 - 1, whose lobe
  matches (N.H)^32 near the peak for p = 8, so VTK gets specular power 8. Our normals come from
  --derivatives: precomputed (default; a gradient volume built once per volume, like the CPU
  mapper's normals, one fetch a sample) or central (six fetches a sample, nothing precomputed);
  the two differ only by 16-bit steps of the gradient (docs/explanations/ray-casting.md). The gradient volume is
  built in the untimed first frame of a mode, as VTK's CPU mapper builds its normals there.
- --volume-precision: 16bit (default) samples float volumes (the torus) from a 16-bit copy over
  the value range (error <= 7.6e-6 of the range; VTK's CPU mapper itself works on 15-bit values),
  full from R32F. uint8 volumes (the bonsai) are 16-bit textures either way.
- A frame is: set the camera, render, wait for completion, no read-back (ours: EntryExitPoints
  and RayCaster passes, then glFinish; VTK: Render() and WaitForCompletion()). VTK runs in a
  spawned worker process (see vtk_worker) that times its own frames. Rounds interleave the three
  renderers so load from other processes hits all alike; best of --repeat.
- PSNR (dB) over the whole RGB image in 8 bits (ours rounded to 8 bits like a displayed image),
  black background in all three, at the base camera. VTK GPU vs VTK CPU is given as a yardstick.

Writes bench/results/vtk_<volume>.md (the table), vtk_<volume>.png (the three images of
--figure-mode side by side, also to --figure if given) and every image at full size.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parent))
from raycaster_speed import (BONSAI, BONSAI_TF, FOG_TF, SURFACE_TF, load_bonsai,  # noqa: E402
                             network)

from vgraph.camera import Camera  # noqa: E402
from vgraph.gl_context import get_context  # noqa: E402
from vgraph.implicit import sample  # noqa: E402
from vgraph.numerics.reference_raycast import volume_box  # noqa: E402
from vgraph.transfer_function import TransferFunction  # noqa: E402
from vgraph.volume import Volume  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# The torus interior reaches normalised ~0.61: a ramp over the interior shows the MIP.
TORUS_MIP_TF = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.1, 0.2, 0.6, 0.0),
                                        (0.62, 1.0, 0.9, 0.6, 1.0), (1.0, 1.0, 1.0, 1.0, 1.0)])
SHADING = dict(ambient=0.3, diffuse=0.7, specular=0.2, shininess=32.0)
VTK_SPECULAR_POWER = 8.0  # Phong (R.V)^8 ~ Blinn-Phong (N.H)^32 under a headlight (docstring)
RENDERERS = ("ours", "VTK GPU", "VTK CPU")


def scenes(volume_name: str) -> dict[str, dict]:
    """Mode name -> compositing, shading and TF of that row."""
    surface = BONSAI_TF if volume_name == "bonsai" else SURFACE_TF
    maximum = BONSAI_TF if volume_name == "bonsai" else TORUS_MIP_TF
    return {"composite": dict(compositing="dvr", shading=False, tf=surface),
            "composite + shading": dict(compositing="dvr", shading=True, tf=surface),
            "MIP": dict(compositing="mip", shading=False, tf=maximum),
            # No empty space anywhere: every ray takes every sample, nothing can be skipped.
            "composite, dense fog TF": dict(compositing="dvr", shading=False, tf=FOG_TF)}


def load_volume(name: str, resolution: int) -> Volume:
    if name == "bonsai":
        if not BONSAI.is_file():
            raise SystemExit(f"{BONSAI} not found: use --volume torus")
        return load_bonsai()
    return sample("torus", resolution, "float32")


def camera_sequence(volume: Volume, count: int, azimuth_degrees: float) -> list[Camera]:
    """The base camera (index 0) and count - 1 orbited copies of it."""
    base = Camera.looking_at_box(*volume_box(volume), direction=(-0.45, -0.35, -1.0))
    return [base.rotate(math.radians(i * azimuth_degrees), 0.0) for i in range(count)]


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """Peak signal-to-noise ratio in dB of two uint8 images (inf when equal)."""
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return math.inf if mse == 0.0 else 10.0 * math.log10(255.0 ** 2 / mse)


# --- ours ---------------------------------------------------------------------------------------
class OurRenderer:
    def __init__(self, volume: Volume, camera: Camera, size: int, derivatives: str = "precomputed",
                 volume_precision: str = "16bit"):
        self.net = network(volume, camera)
        self.net.set("rc.volume_precision", volume_precision)
        self.size = (size, size)
        self.ctx = get_context()
        self.derivatives = derivatives

    def configure(self, scene: dict) -> None:
        self.net.set("rc.compositing", scene["compositing"])
        self.net.set("rc.transfer_function", scene["tf"])
        self.net.set("rc.shading", "blinn_phong" if scene["shading"] else "none")
        self.net.set("rc.derivatives", self.derivatives)
        for key, value in SHADING.items():
            self.net.set(f"rc.{key}", value)

    def render(self, camera: Camera) -> float:
        """Seconds for one frame at ``camera`` (until the image is complete in its texture)."""
        start = time.perf_counter()
        self.net.set("eep.camera", camera)  # linked: the ray caster's camera follows
        self.net.update("rc.image", size=self.size)
        self.ctx.finish()  # GL returns before llvmpipe has drawn: wait for the image
        return time.perf_counter() - start

    def image(self) -> np.ndarray:
        """The last frame's RGB in 8 bits, row 0 at the top."""
        rgba = self.net.output("rc.image").to_numpy()
        return np.clip(np.rint(rgba[..., :3] * 255.0), 0, 255).astype(np.uint8)


# --- VTK ----------------------------------------------------------------------------------------
def vtk_image_data(volume: Volume):
    from vtkmodules.util import numpy_support
    import vtk
    image = vtk.vtkImageData()
    image.SetDimensions(*volume.dims)
    image.SetSpacing(*volume.spacing)
    image.SetOrigin(*volume.origin)
    flat = np.ascontiguousarray(volume.data).ravel()  # [z, y, x]: x fastest, VTK's point order
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(flat, deep=True))
    return image


def vtk_transfer_functions(tf: TransferFunction, value_range):
    """vtkColorTransferFunction and vtkPiecewiseFunction over data values."""
    import vtk
    lo, hi = value_range
    colour, opacity = vtk.vtkColorTransferFunction(), vtk.vtkPiecewiseFunction()
    colour.SetColorSpaceToRGB()
    last = -math.inf
    for position, r, g, b, a in tf.points:
        value = lo + position * (hi - lo)
        value = max(value, last + 1e-9 * (hi - lo))  # a step: VTK keeps one point per x
        colour.AddRGBPoint(value, r, g, b)
        opacity.AddPoint(value, a)
        last = value
    return colour, opacity


def vtk_camera(camera: Camera, vtk_cam) -> None:
    vtk_cam.SetPosition(*camera.position)
    vtk_cam.SetFocalPoint(*camera.focus)
    vtk_cam.SetViewUp(*camera.up)
    vtk_cam.OrthogonalizeViewUp()
    vtk_cam.SetViewAngle(camera.fov)  # vertical, as ours
    vtk_cam.SetClippingRange(camera.near, camera.far)


class VtkRenderer:
    def __init__(self, kind: str, image_data, volume: Volume, size: int):
        import vtk
        self.volume = volume
        self.step = float(min(volume.spacing))
        if kind == "gpu":
            mapper = vtk.vtkGPUVolumeRayCastMapper()
            mapper.SetUseJittering(0)
        else:
            mapper = vtk.vtkFixedPointVolumeRayCastMapper()
            mapper.SetNumberOfThreads(os.cpu_count() or 1)
            mapper.SetInteractiveSampleDistance(self.step)
        mapper.SetInputData(image_data)
        mapper.SetAutoAdjustSampleDistances(0)
        mapper.SetLockSampleDistanceToInputSpacing(0)
        mapper.SetSampleDistance(self.step)
        mapper.SetImageSampleDistance(1.0)
        self.mapper = mapper
        self.prop = vtk.vtkVolumeProperty()
        self.actor = vtk.vtkVolume()
        self.actor.SetMapper(mapper)
        self.actor.SetProperty(self.prop)
        self.renderer = vtk.vtkRenderer()
        self.renderer.SetBackground(0.0, 0.0, 0.0)
        self.renderer.AddVolume(self.actor)
        self.window = vtk.vtkRenderWindow()
        self.window.SetOffScreenRendering(1)
        self.window.SetMultiSamples(0)
        self.window.SetSize(size, size)
        self.window.AddRenderer(self.renderer)

    def configure(self, scene: dict) -> None:
        colour, opacity = vtk_transfer_functions(scene["tf"], self.volume.value_range)
        self.prop.SetColor(colour)
        self.prop.SetScalarOpacity(opacity)
        self.prop.SetScalarOpacityUnitDistance(self.step)  # alpha per sample at our rate 1
        self.prop.SetInterpolationTypeToLinear()
        self.prop.SetShade(1 if scene["shading"] else 0)
        self.prop.SetAmbient(SHADING["ambient"])
        self.prop.SetDiffuse(SHADING["diffuse"])
        self.prop.SetSpecular(SHADING["specular"])
        self.prop.SetSpecularPower(VTK_SPECULAR_POWER)
        if scene["compositing"] == "mip":
            self.mapper.SetBlendModeToMaximumIntensity()
        else:
            self.mapper.SetBlendModeToComposite()

    def render(self, camera: Camera) -> float:
        start = time.perf_counter()
        vtk_camera(camera, self.renderer.GetActiveCamera())
        self.window.Render()
        self.window.WaitForCompletion()
        return time.perf_counter() - start

    def image(self) -> np.ndarray:
        from vtkmodules.util import numpy_support
        import vtk
        grab = vtk.vtkWindowToImageFilter()
        grab.SetInput(self.window)
        grab.SetInputBufferTypeToRGB()
        grab.ReadFrontBufferOff()
        grab.ShouldRerenderOff()
        grab.Update()
        out = grab.GetOutput()
        width, height, _ = out.GetDimensions()
        pixels = numpy_support.vtk_to_numpy(out.GetPointData().GetScalars())
        return pixels.reshape(height, width, 3)[::-1].copy()  # VTK's row 0 is the bottom


# --- VTK in a process of its own ---------------------------------------------------------------
# VTK's EGL windows and our moderngl EGL context in one process disturb each other on this machine
# (ours rendered black images once VTK had rendered, VTK's CPU mapper too), so VTK runs in a
# spawned worker. The parent drives it frame by frame; the worker times its own frames.
def vtk_worker(connection, volume_name: str, resolution: int, size: int, window: str) -> None:
    if window == "egl":
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"  # before VTK loads
    import vtk
    volume = load_volume(volume_name, resolution)
    image_data = vtk_image_data(volume)
    renderers = {"VTK GPU": VtkRenderer("gpu", image_data, volume, size),
                 "VTK CPU": VtkRenderer("cpu", image_data, volume, size)}
    connection.send((vtk.vtkVersion.GetVTKVersion(),
                     renderers["VTK GPU"].window.GetClassName()))
    while (message := connection.recv()) is not None:
        command, name, argument = message
        renderer = renderers[name]
        result = {"configure": renderer.configure, "render": renderer.render,
                  "image": lambda _: renderer.image()}[command](argument)
        connection.send(result)


class VtkProxy:
    """One VTK mapper of the worker, with the renderer interface of OurRenderer."""

    def __init__(self, connection, name: str):
        self.connection, self.name = connection, name

    def _call(self, command: str, argument=None):
        self.connection.send((command, self.name, argument))
        return self.connection.recv()

    def configure(self, scene: dict) -> None:
        self._call("configure", scene)

    def render(self, camera: Camera) -> float:
        return self._call("render", camera)

    def image(self) -> np.ndarray:
        return self._call("image")


def start_vtk_worker(args):
    import multiprocessing
    spawn = multiprocessing.get_context("spawn")
    parent, child = spawn.Pipe()
    process = spawn.Process(target=vtk_worker, daemon=True,
                            args=(child, args.volume, args.resolution, args.size, args.vtk_window))
    process.start()
    version, window = parent.recv()
    return process, parent, version, window


# --- the run ------------------------------------------------------------------------------------
def run(args, cameras: list[Camera], renderers: dict, modes: dict) -> tuple[list[dict], dict]:
    rows, pictures = [], {}
    bar = tqdm(total=len(modes) * (args.repeat + 2) * len(renderers), desc="frames", unit="frame")
    for mode, scene in modes.items():
        seconds = {name: [] for name in renderers}
        for renderer in renderers.values():
            renderer.configure(scene)
            renderer.render(cameras[-1])  # untimed: compile, upload, precompute
            bar.update(1)
        for r in range(args.repeat):  # interleaved rounds, a new camera each frame
            for name, renderer in renderers.items():
                seconds[name].append(renderer.render(cameras[1 + r]))
                bar.update(1)
        images = {}
        for name, renderer in renderers.items():
            renderer.render(cameras[0])
            images[name] = renderer.image()
            bar.update(1)
        best = {name: min(s) for name, s in seconds.items()}
        rows.append(dict(mode=mode, best=best,
                         median={name: float(np.median(s)) for name, s in seconds.items()},
                         psnr_gpu=psnr(images["ours"], images["VTK GPU"]),
                         psnr_cpu=psnr(images["ours"], images["VTK CPU"]),
                         psnr_vtk=psnr(images["VTK GPU"], images["VTK CPU"])))
        pictures[mode] = images
    bar.close()
    return rows, pictures


def markdown(rows: list[dict], args, window: str) -> str:
    lines = [f"torus SDF {args.resolution}^3 float32" if args.volume == "torus"
             else "ct_bonsai 256^3 uint8",
             f"{args.size}^2 image, step = min(spacing), best of {args.repeat} frames (camera "
             f"orbited {args.azimuth} degrees per frame), VTK window {window}, our derivatives "
             f"{args.derivatives}, volume precision {args.volume_precision}", "",
             "| mode | ours s | VTK GPU s | VTK CPU s | VTK GPU / ours | VTK CPU / ours "
             "| PSNR ours-GPU dB | PSNR ours-CPU dB | PSNR GPU-CPU dB |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        b = row["best"]
        lines.append(f"| {row['mode']} | {b['ours']:.3f} | {b['VTK GPU']:.3f} | "
                     f"{b['VTK CPU']:.3f} | {b['VTK GPU'] / b['ours']:.2f} | "
                     f"{b['VTK CPU'] / b['ours']:.2f} | {row['psnr_gpu']:.1f} | "
                     f"{row['psnr_cpu']:.1f} | {row['psnr_vtk']:.1f} |")
    lines += ["", "Medians (s): " + "; ".join(
        f"{row['mode']}: " + ", ".join(f"{n} {row['median'][n]:.3f}" for n in RENDERERS)
        for row in rows)]
    return "\n".join(lines) + "\n"


def save_figure(images: dict, row: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows, cols = np.nonzero(np.any([images[n].max(axis=2) > 0 for n in RENDERERS], axis=0))
    margin = 8  # crop the common black border away
    crop = (slice(max(rows.min() - margin, 0), rows.max() + margin + 1),
            slice(max(cols.min() - margin, 0), cols.max() + margin + 1)) if rows.size else ()
    fig, axes = plt.subplots(1, 3, figsize=(9.0, 3.4), dpi=90)
    for ax, name in zip(axes, RENDERERS):
        ax.imshow(images[name][crop])
        note = {"ours": "", "VTK GPU": f", PSNR {row['psnr_gpu']:.1f} dB",
                "VTK CPU": f", PSNR {row['psnr_cpu']:.1f} dB"}[name]
        ax.set_title(f"{name}: {row['best'][name]:.3f} s{note}", fontsize=9)
        ax.axis("off")
    fig.suptitle(f"{row['mode']} (PSNR against ours)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    small_png(path)


def small_png(path: Path, colours: int = 128) -> None:
    """Rewrite a PNG with a palette of ``colours`` (a third of the bytes; for docs/images)."""
    from PIL import Image as PILImage
    with PILImage.open(path) as image:
        palette = image.convert("RGB").quantize(colors=colours)
    palette.save(path, optimize=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", choices=["torus", "bonsai"], default="torus")
    parser.add_argument("--resolution", type=int, default=256, help="torus voxels per axis")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--azimuth", type=float, default=3.0, help="degrees per frame")
    parser.add_argument("--vtk-window", choices=["egl", "default"], default="egl",
                        help="egl: VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow")
    parser.add_argument("--derivatives", choices=["precomputed", "central"], default="precomputed",
                        help="our shading normals (rc.derivatives); precomputed measured faster")
    parser.add_argument("--volume-precision", choices=["16bit", "full"], default="16bit",
                        help="rc.volume_precision: how float volumes are sampled")
    parser.add_argument("--figure-mode", default="composite + shading")
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results")
    parser.add_argument("--figure", type=Path, default=None,
                        help="also save the three images of --figure-mode here (docs/images/...)")
    args = parser.parse_args()
    volume = load_volume(args.volume, args.resolution)
    cameras = camera_sequence(volume, args.repeat + 2, args.azimuth)
    modes = scenes(args.volume)
    process, connection, version, window = start_vtk_worker(args)
    print(f"VTK {version}, window {window}")
    try:
        renderers = {"ours": OurRenderer(volume, cameras[0], args.size, args.derivatives,
                                         args.volume_precision),
                     "VTK GPU": VtkProxy(connection, "VTK GPU"),
                     "VTK CPU": VtkProxy(connection, "VTK CPU")}
        rows, pictures = run(args, cameras, renderers, modes)
    finally:
        connection.send(None)
        process.join(timeout=30)
    text = markdown(rows, args, window)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"vtk_{args.volume}.md").write_text(text)
    row = next(r for r in rows if r["mode"] == args.figure_mode)
    save_figure(pictures[args.figure_mode], row, args.out / f"vtk_{args.volume}.png")
    if args.figure is not None:
        save_figure(pictures[args.figure_mode], row, args.figure)
    for mode, images in pictures.items():  # every image, full size, for inspection
        for name, image in images.items():
            from PIL import Image as PILImage
            slug = "_".join(f"{mode} {name}".replace(",", " ").replace("+", " ").split())
            PILImage.fromarray(image).save(args.out / f"vtk_{args.volume}_{slug}.png")


if __name__ == "__main__":
    main()
