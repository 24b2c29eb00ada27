"""The pictures of docs/explanations/ray-casting.md: strips of small renderings, one panel per property value.

    .venv/bin/python bench/make_rendering_images.py [--out docs/images] [--size 192]

Every panel is rendered by the network docs/explanations/ray-casting.md describes (FunctionSelector ->
EntryExitPoints -> RayCaster, cameras linked) on llvmpipe; each strip is one PNG of a few
panels with a caption under each."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import PIL.Image
import PIL.ImageDraw

from vgraph import Network
from vgraph.camera import Camera
from vgraph.transfer_function import TransferFunction

REPO = Path(__file__).resolve().parents[1]
# The surface of an implicit function sits at intensity 0.5, its inside is brighter.
SHELL = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.47, 0.25, 0.45, 0.9, 0.0),
                                 (0.52, 1.0, 0.65, 0.25, 0.35), (0.6, 1.0, 0.9, 0.7, 0.05),
                                 (1.0, 1.0, 1.0, 1.0, 0.3)])
FOG = TransferFunction(points=[(0.0, 0.2, 0.3, 0.8, 0.0), (0.4, 0.2, 0.3, 0.8, 0.02),
                               (0.55, 1.0, 0.6, 0.2, 0.08), (1.0, 1.0, 1.0, 1.0, 0.1)])

def grey_ramp(low: float, high: float) -> TransferFunction:
    return TransferFunction(points=[(low, 0, 0, 0, 0), (high, 1, 1, 1, 1)])

CAMERA = Camera.looking_at_box((-1, -1, -1), (1, 1, 1), direction=(-0.45, -0.55, -1.0)).zoom(1.6)
BACKGROUND = (0.08, 0.08, 0.1, 1.0)


def network(function="torus", resolution=64, data_type="float32", **raycaster) -> Network:
    net = Network()
    net.add("FunctionSelector", id="volume", function=function, resolution=resolution,
            data_type=data_type)
    net.add("EntryExitPoints", id="eep", camera=CAMERA)
    net.add("RayCaster", id="rc", **{"transfer_function": SHELL, "background": BACKGROUND,
                                     **raycaster})
    net.link("eep.camera", "rc.camera")
    for source, target in (("volume.volume", "eep.volume"), ("volume.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit")):
        net.connect(source, target)
    return net


def panel(net: Network, size: int, target="rc.image", **changes) -> np.ndarray:
    for address, value in changes.items():
        net.set(address.replace("__", "."), value)
    rgba = net.evaluate(target, size=(size, size))
    return np.clip(rgba[..., :3], 0.0, 1.0)


def strip(panels: list[tuple[str, np.ndarray]], path: Path) -> None:
    """Panels side by side with a caption band under each; written as 8-bit RGB PNG."""
    height, width = panels[0][1].shape[:2]
    caption = 18
    canvas = PIL.Image.new("RGB", (width * len(panels), height + caption), (255, 255, 255))
    draw = PIL.ImageDraw.Draw(canvas)
    for k, (label, pixels) in enumerate(panels):
        canvas.paste(PIL.Image.fromarray((pixels * 255 + 0.5).astype(np.uint8)), (k * width, 0))
        draw.text((k * width + 4, height + 3), label, fill=(0, 0, 0))
    path.parent.mkdir(parents=True, exist_ok=True)
    canvas.save(path, optimize=True)
    print(f"wrote {path.relative_to(REPO) if path.is_relative_to(REPO) else path}")


def strip_arguments(description: str) -> tuple[Path, int]:
    """(--out, --size) of a script that draws strips of panels into docs/images."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images")
    parser.add_argument("--size", type=int, default=192)
    args = parser.parse_args()
    return args.out, args.size


def main() -> None:
    out, size = strip_arguments(__doc__.splitlines()[0])

    net = network()
    strip([("entry points", panel(net, size, "eep.entry")),
           ("exit points", panel(net, size, "eep.exit"))], out / "rendering_entry_exit.png")

    panels = [(mode, panel(net, size, rc__compositing=mode)) for mode in ("dvr", "iso", "first_hit")]
    # The maximum along a ray reaches ~0.62 (the tube's core), the average only ~0.35.
    panels += [("mip, grey ramp .45-.62", panel(net, size, rc__compositing="mip",
                                               rc__transfer_function=grey_ramp(0.45, 0.62))),
               ("xray, grey ramp .25-.45", panel(net, size, rc__compositing="xray",
                                                rc__transfer_function=grey_ramp(0.25, 0.45)))]
    strip(panels, out / "rendering_compositing.png")

    net = network(shading="blinn_phong")
    strip([("shading none", panel(net, size, rc__shading="none")),
           ("headlight", panel(net, size, rc__shading="blinn_phong")),
           ("light_direction (1,1,1)", panel(net, size, rc__light="direction")),
           ("iso, headlight", panel(net, size, rc__light="headlight", rc__compositing="iso"))],
          out / "rendering_shading.png")

    net = network(resolution=24, data_type="uint8", compositing="iso", shading="blinn_phong")
    strip([(gradient, panel(net, size, rc__derivatives=gradient))
           for gradient in ("forward", "backward", "central", "sobel")],
          out / "rendering_gradients.png")

    net = network(resolution=16, compositing="iso", shading="blinn_phong")
    strip([(f"{mode} (16^3)", panel(net, size, rc__interpolation=mode))
           for mode in ("nearest", "trilinear")], out / "rendering_interpolation.png")

    net = network()
    strip([("rate 0.25", panel(net, size, rc__sampling_rate=0.25)),
           ("rate 0.25, jitter 4", panel(net, size, eep__jitter=4.0)),
           ("rate 1", panel(net, size, rc__sampling_rate=1.0, eep__jitter=0.0)),
           ("rate 4", panel(net, size, rc__sampling_rate=4.0)),
           ("fog TF, rate 1", panel(net, size, rc__sampling_rate=1.0, rc__transfer_function=FOG))],
          out / "rendering_sampling_rate.png")

    net = network()
    net.set("eep.camera", Camera(position=(0.0, 0.0, 0.3), focus=(1.0, 0.2, 0.0), up=(0, 0, 1),
                                 fov=90, near=0.01, far=5.0))
    strip([("camera inside, dvr", panel(net, size)),
           ("camera inside, iso", panel(net, size, rc__compositing="iso", rc__shading="blinn_phong"))],
          out / "rendering_camera_inside.png")


if __name__ == "__main__":
    main()
