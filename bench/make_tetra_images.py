"""The pictures of docs/explanations/tetrahedra.md: the two integration modes against the exact reference on
VTK's post.vtk, and the culled bonsai as tetrahedra beside the RayCaster on the same volume.

    .venv/bin/python bench/make_tetra_images.py   (writes docs/images/tetra_*.png)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image as PILImage, ImageDraw

import vgraph
from vgraph.imagefile import to_uint8
from vgraph.numerics.reference_tetra import render as reference

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images"
SIZE = (256, 256)


def strip(panels: list[tuple[str, np.ndarray]], path: Path) -> None:
    width, height = SIZE
    sheet = PILImage.new("RGB", (width * len(panels), height + 18), "white")
    draw = ImageDraw.Draw(sheet)
    for i, (label, pixels) in enumerate(panels):
        sheet.paste(PILImage.fromarray(to_uint8(pixels)[..., :3]), (i * width, 18))
        draw.text((i * width + 4, 3), label, fill="black")
    sheet.save(path, optimize=True)
    print(f"wrote {path}")


def modes() -> None:
    network = vgraph.load(ROOT / "networks" / "tets_lox_post.json")
    panels = []
    for mode in ("averaged", "preintegrated"):
        network.set("pt.integration", mode)
        panels.append((f"ProjectedTetrahedra, {mode}", network.evaluate("canvas", size=SIZE)))
    mesh = network.output("source.mesh")
    exact = reference(mesh, network["pt"].view_camera, network.get("pt.transfer_function"), SIZE)
    panels.append(("exact CPU reference", exact))
    strip(panels, OUT / "tetra_modes.png")


def culling() -> None:
    network = vgraph.load(ROOT / "networks" / "tets_bonsai.json")
    projected = network.evaluate("canvas", size=SIZE)
    kept, total = network["tets"].kept_cells, network["tets"].total_cells
    rc = vgraph.load(ROOT / "networks" / "tets_bonsai.json")
    for pid in ("tets", "pt"):
        rc.remove(pid)
    rc.add("EntryExitPoints", id="eep", camera=network["pt"].view_camera)
    rc.add("RayCaster", id="rc", transfer_function=network.get("pt.transfer_function"), sampling_rate=2.0,
           shading="none")  # as the projected tetrahedra: unshaded (the RayCaster starts shaded)
    rc.link("eep.camera", "rc.camera")
    for a, b in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"), ("eep.entry", "rc.entry"),
                 ("eep.exit", "rc.exit"), ("rc.image", "canvas.image")):
        rc.connect(a, b)
    strip([(f"tetrahedra, {kept / total:.0%} of the cells kept", projected),
           ("RayCaster, same TF and camera", rc.evaluate("canvas", size=SIZE))], OUT / "tetra_culling.png")


if __name__ == "__main__":
    modes()
    culling()
