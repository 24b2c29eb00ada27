"""Make docs/images/exploring_slice_display.png: the SliceViewer's two display conventions on the
MRI head (/work/shared/data/mri_head_t1/MR.nii.gz, RAS). The same axial slice, radiological (the
default: the patient's right on the image's left, as DICOM viewers show it) and neurological (the
patient's right on the image's right), each side labelled with the patient side it shows, found
from the viewer's own pixel -> world map (RAS: +x is the patient's right).

    python bench/make_slice_display_images.py [--out PATH] [--data MR.nii.gz] [--slice K]

``--slice K``: the axial slice through voxel k = K (default 88, through the lateral ventricles).
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import numpy as np

from vgraph.atomic import atomic_path
from vgraph.io import read_volume
from vgraph.processors.slice_viewer import SliceViewer

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "exploring_slice_display.png"
DATA = REPO.parent / "shared" / "data" / "mri_head_t1" / "MR.nii.gz"
SIZE = (320, 416)  # the head's 160 x 208 mm at 0.5 mm per pixel
TITLES = {"radiological": "radiological (default)", "neurological": "neurological"}


def axial(volume, display: str, k: int):
    centre = np.array(volume.dims) // 2
    centre[2] = k
    viewer = SliceViewer("axial", display=display, interpolation="linear", window=(220.0, 440.0),
                         cursor=tuple(volume.voxel_to_world(centre)))
    viewer.render_size = SIZE
    image = viewer.process(volume).to_numpy()
    left, right = viewer.pixel_to_world(0, SIZE[1] // 2), viewer.pixel_to_world(SIZE[0] - 1, SIZE[1] // 2)
    sides = ("R", "L") if left[0] > right[0] else ("L", "R")  # RAS: larger x is the patient's right
    return image, sides


def figure_png(panels) -> bytes:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(1, len(panels), figsize=(7.2, 4.9), facecolor="white")
    for ax, (title, image, (left, right)) in zip(axes, panels):
        ax.imshow(np.clip(image[..., :3], 0.0, 1.0), interpolation="nearest")
        ax.set_title(title, fontsize=11)
        for x, side, align in ((-8, left, "right"), (SIZE[0] + 8, right, "left")):
            ax.text(x, SIZE[1] / 2, side, fontsize=15, fontweight="bold", ha=align, va="center")
        ax.text(SIZE[0] / 2, -6, "A", fontsize=11, ha="center", va="bottom")
        ax.text(SIZE[0] / 2, SIZE[1] + 6, "P", fontsize=11, ha="center", va="top")
        ax.set_xlim(-40, SIZE[0] + 40)
        ax.set_ylim(SIZE[1] + 30, -30)
        ax.axis("off")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=100)
    plt.close(figure)
    return buffer.getvalue()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--slice", type=int, default=88)
    args = parser.parse_args(argv)
    volume = read_volume(args.data)
    panels = [(TITLES[display], *axial(volume, display, args.slice)) for display in TITLES]
    import PIL.Image
    with PIL.Image.open(io.BytesIO(figure_png(panels))) as image, atomic_path(args.out) as temporary:
        image.convert("RGB").quantize(256).save(temporary, format="PNG", optimize=True)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
