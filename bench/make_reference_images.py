"""The pictures of the processor reference pages that no essay draws (vgraph.reference_docs' PICTURES):
the BrickedRayCaster's levels of detail and the SweepPlaneRenderer beside the RayCaster.

    .venv/bin/python bench/make_reference_images.py [--out docs/images] [--size 192]

The torus of bench/make_rendering_images.py (FunctionSelector, 128^3 float32, its TF and camera),
on llvmpipe; a strip of panels per picture, a caption under each."""

from __future__ import annotations

from make_rendering_images import BACKGROUND, CAMERA, SHELL, panel, strip, strip_arguments

from vgraph import Network

BRICK = 32  # 128^3 in 32^3 bricks: levels 0, 1 and 2


def network(renderer: str, fed_entry_exit: bool = True, **properties) -> Network:
    """FunctionSelector's torus into ``renderer`` (and EntryExitPoints, cameras linked)."""
    net = Network()
    net.add("FunctionSelector", id="volume", function="torus", resolution=128, data_type="float32")
    net.add(renderer, id="r", **{"transfer_function": SHELL, "background": BACKGROUND, "camera": CAMERA,
                                  **properties})
    net.connect("volume.volume", "r.volume")
    if fed_entry_exit:
        net.add("EntryExitPoints", id="eep", camera=CAMERA)
        net.link("eep.camera", "r.camera")
        for source, target in (("volume.volume", "eep.volume"), ("eep.entry", "r.entry"),
                               ("eep.exit", "r.exit")):
            net.connect(source, target)
    return net


def main() -> None:
    out, size = strip_arguments(__doc__.splitlines()[0])

    # lod_bias -16 asks every brick for level 0, finest_level then draws level L everywhere.
    net = network("BrickedRayCaster", brick_size=BRICK, lod_bias=-16.0)
    panels = []
    for level in range(3):
        pixels = panel(net, size, "r.image", r__finest_level=level)
        panels.append((f"level {level} ({net['r'].last_frame['bricks']} bricks)", pixels))
    strip(panels, out / "bricked_levels.png")

    strip([("SweepPlaneRenderer", panel(network("SweepPlaneRenderer", fed_entry_exit=False), size, "r.image")),
           ("RayCaster", panel(network("RayCaster", shading="none"), size, "r.image"))],
          out / "sweep_plane.png")


if __name__ == "__main__":
    main()
