"""The picture of docs/guide/shadows.md: the CT bonsai lit from one side, without shadows | with
the LightVolume's shadows | a slice of the light volume itself (transmittance, white = full
light), through the network the page describes (LightVolume -> RayCaster.light_volume, the TF and
the light direction linked). Writes <out>/shadows_bonsai.png.

    .venv/bin/python bench/make_shadow_images.py [--out docs/images] [--size 320]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from panel_row import write_panel_row  # noqa: E402
from raycaster_speed import BONSAI, BONSAI_TF  # noqa: E402

from vgraph import Network  # noqa: E402
from vgraph.camera import Camera  # noqa: E402
from vgraph.numerics.reference_raycast import volume_box  # noqa: E402

LIGHT = (-0.4, -1.0, 1.2)  # from the front left, above: the tree shades the pot and the tray


def shadow_network(size: int) -> Network:
    net = Network()
    net.add("VolumeSource", id="source", path=str(BONSAI))
    net.add("EntryExitPoints", id="eep")
    net.add("RayCaster", id="rc", transfer_function=BONSAI_TF, shading="blinn_phong", light="direction",
            light_direction=LIGHT, derivatives="precomputed", background=(1.0, 1.0, 1.0, 1.0),
            shadow_strength=0.85)
    net.add("LightVolume", id="light", transfer_function=BONSAI_TF, light_direction=LIGHT)
    net.link("eep.camera", "rc.camera")
    net.link("rc.transfer_function", "light.transfer_function")
    net.link("rc.light_direction", "light.light_direction")
    for source, target in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"),
                           ("source.volume", "light.volume"), ("eep.entry", "rc.entry"),
                           ("eep.exit", "rc.exit"), ("light.light_volume", "rc.light_volume")):
        net.connect(source, target)
    net.update("source.volume")
    volume = net.output("source.volume")
    net.set("eep.camera", Camera.looking_at_box(*volume_box(volume), direction=(0.55, 0.75, -0.35),
                                                up=(0.0, 0.0, 1.0)))
    return net


def light_slice(light_volume, size: int) -> np.ndarray:
    """The light volume's middle slice across y (x to the right, z up) as grey RGBA, size x size."""
    codes = light_volume.data[:, light_volume.data.shape[1] // 2, :][::-1]  # z up
    t = codes / 65535.0
    rows = np.minimum((np.arange(size) * t.shape[0]) // size, t.shape[0] - 1)
    columns = np.minimum((np.arange(size) * t.shape[1]) // size, t.shape[1] - 1)
    grey = t[rows][:, columns].astype(np.float32)
    return np.dstack([grey, grey, grey, np.ones_like(grey)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "docs" / "images")
    parser.add_argument("--size", type=int, default=320)
    args = parser.parse_args()
    net = shadow_network(args.size)
    shadowed = net.evaluate("rc.image", size=(args.size, args.size))
    net.update("light.light_volume")
    light_volume = net.output("light.light_volume")
    net.disconnect("light.light_volume", "rc.light_volume")
    plain = net.evaluate("rc.image", size=(args.size, args.size))
    write_panel_row(args.out / "shadows_bonsai.png", [plain, shadowed, light_slice(light_volume, args.size)])
    print(f"wrote {args.out / 'shadows_bonsai.png'}")


if __name__ == "__main__":
    main()
