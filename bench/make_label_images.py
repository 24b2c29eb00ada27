"""Make docs/images/exploring_labels_boundaries.png: why labels need their own ray caster. Two
touching boxes, label 1 (red) beside label 3 (blue), first from the RayCaster, whose trilinear
interpolation blends the label values (1 and 3 make 2, green, along the boundary, and a TF step
must pick some value between labels), then from the LabelRayCaster (majority of interpolation
weights: only red and blue, the boundary half-way between the voxel centres, rounded corners).

    python bench/make_label_images.py [--out PATH]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from panel_row import write_panel_row
from vgraph.camera import Camera
from vgraph.labels import LabelEntry, LabelTable
from vgraph.numerics.reference_raycast import volume_box
from vgraph.network import Network
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "exploring_labels_boundaries.png"
SIZE = (360, 300)
RED, GREEN, BLUE = (1.0, 0.15, 0.1), (0.1, 0.9, 0.2), (0.15, 0.35, 1.0)


def boxes() -> Volume:
    data = np.zeros((10, 12, 18), dtype=np.uint8)
    data[2:8, 2:10, 2:9] = 1
    data[2:8, 2:10, 9:16] = 3
    return Volume(data, declared_range=(0.0, 3.0))


def label_transfer_function() -> TransferFunction:
    """Labels 0..3 as normalised intensities 0, 1/3, 2/3, 1; opaque from half-way to label 1 on."""
    return TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.16, 0, 0, 0, 0), (0.17, *RED, 1), (1 / 3, *RED, 1),
                                    (2 / 3, *GREEN, 1), (1.0, *BLUE, 1)])


def label_network(volume: Volume, camera: Camera, **properties) -> Network:
    """GivenVolume 'src' -> EntryExitPoints 'eep' -> LabelRayCaster 'lrc' (its inport is 'labels')."""
    return ray_caster_network(volume, camera, "LabelRayCaster", "lrc", inport="labels", **properties)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    volume = boxes()
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.35, -0.9, -0.7))
    common = {"shading": "blinn_phong", "background": (1.0, 1.0, 1.0, 1.0)}
    interpolated = ray_caster_network(volume, camera, "RayCaster", compositing="dvr",
                                      transfer_function=label_transfer_function(), **common)
    table = LabelTable(labels=[LabelEntry(value=0, visible=False), LabelEntry(value=1, color=RED),
                               LabelEntry(value=2, color=GREEN), LabelEntry(value=3, color=BLUE)])
    labels = label_network(volume, camera, label_table=table, compositing="first_hit", **common)
    left = interpolated.evaluate("rc.image", size=SIZE)
    right = labels.evaluate("lrc.image", size=SIZE)
    write_panel_row(args.out, [left, right])
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
