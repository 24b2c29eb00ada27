"""The pictures of docs/explanations/curvature.md: strips of curvature renderings, one panel per property value.

    .venv/bin/python bench/make_curvature_images.py [--out docs/images] [--size 192]

Every panel is rendered by the network of networks/curvature_torus.json (FunctionSelector ->
CubicSplineProcessor -> EntryExitPoints -> CurvatureRaycaster, cameras linked); the finite-difference
panels disable the CubicSplineProcessor, since those modes need voxel samples."""

from __future__ import annotations

import sys
from pathlib import Path

from vgraph import Network
from vgraph.camera import Camera

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_rendering_images import panel, strip, strip_arguments  # noqa: E402

CAMERA = Camera.looking_at_box((-0.8, -0.8, -0.25), (0.8, 0.8, 0.25), direction=(-0.3, -0.5, -1.0))
BACKGROUND = (0.08, 0.08, 0.1, 1.0)


def network(function="torus", resolution=64, data_type="float32", processor="CurvatureRaycaster",
            **properties) -> Network:
    net = Network()
    net.add("FunctionSelector", id="volume", function=function, resolution=resolution,
            data_type=data_type)
    net.add("CubicSplineProcessor", id="spline")
    net.add("EntryExitPoints", id="eep", camera=CAMERA)
    net.add(processor, id="cr", **{"background": BACKGROUND, **properties})
    net.link("eep.camera", "cr.camera")
    for source, target in (("volume.volume", "spline.volume"), ("spline.volume", "eep.volume"),
                           ("spline.volume", "cr.volume"), ("eep.entry", "cr.entry"),
                           ("eep.exit", "cr.exit")):
        net.connect(source, target)
    return net


def main() -> None:
    out, size = strip_arguments(__doc__.splitlines()[0])

    net = network()
    strip([(measure, panel(net, size, "cr.image", cr__curvature=measure))
           for measure in ("gaussian", "mean", "k1", "k2", "shape_index")],
          out / "curvature_measures.png")

    for data_type, name in (("float32", "curvature_derivatives.png"), ("uint8", "curvature_precision.png")):
        net = network(resolution=32, data_type=data_type, curvature="mean", shading="none")
        label = f"(32^3 {data_type})"
        panels = [(f"{mode} {label}", panel(net, size, "cr.image", spline__enabled=False,
                                            cr__derivatives=mode))
                  for mode in ("forward", "central", "filtered")]
        panels.append((f"tricubic {label}", panel(net, size, "cr.image", spline__enabled=True,
                                                  cr__derivatives="tricubic")))
        strip(panels, out / name)

    net = network(curvature="gaussian")
    strip([("linear, jet", panel(net, size, "cr.image")),
           ("exponential t=0.1", panel(net, size, "cr.image", cr__normalization="exponential",
                                       cr__attenuation=0.1)),
           ("exponential t=1", panel(net, size, "cr.image", cr__attenuation=1.0)),
           ("linear, coolwarm", panel(net, size, "cr.image", cr__normalization="linear",
                                      cr__colormap="coolwarm")),
           ("viridis, contour 0", panel(net, size, "cr.image", cr__colormap="viridis",
                                        cr__contour_width=0.0))],
          out / "curvature_normalization.png")

    net = network(processor="CurvatureVolumeRaycaster", curvature="mean")
    strip([("mean, linear", panel(net, size, "cr.image")),
           ("mean, exponential t=0.2", panel(net, size, "cr.image", cr__normalization="exponential",
                                             cr__attenuation=0.2)),
           ("k2, coolwarm", panel(net, size, "cr.image", cr__normalization="linear",
                                  cr__curvature="k2", cr__colormap="coolwarm")),
           ("k2, shaded", panel(net, size, "cr.image", cr__shading="blinn_phong"))],
          out / "curvature_volume.png")


if __name__ == "__main__":
    main()
