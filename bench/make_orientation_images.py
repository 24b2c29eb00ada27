"""Make docs/images/patient_space_views.png: the MRI head (/work/shared/data/mri_head_t1/MR.nii.gz,
stored RAS) and an LPS copy of it (the same voxels stored mirrored in x and y, written by nibabel
with the affine that keeps every voxel at its world point), each read by vgraph and drawn by the
standard `vgraph run FILE` network from the anterior, left and superior views. Both rows must be
the same picture: readers turn every file into the RAS world, and named views are patient
directions (docs/explanations/conventions.md, "Patient space"). The script prints the largest difference.

    python bench/make_orientation_images.py [--out PATH] [--data MR.nii.gz]
"""

from __future__ import annotations

import argparse
import io
import tempfile
from pathlib import Path

import nibabel as nib
import numpy as np

import vgraph
from vgraph.atomic import atomic_path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "patient_space_views.png"
DATA = REPO.parent / "shared" / "data" / "mri_head_t1" / "MR.nii.gz"
SIZE = (240, 240)
VIEWS = ("anterior", "left", "superior")


def lps_copy(path: Path, folder: Path) -> Path:
    """The file's voxels stored in LPS order: nibabel reorients the array and its affine together."""
    image = nib.load(path)
    orientations = nib.orientations
    turned = image.as_reoriented(orientations.ornt_transform(orientations.io_orientation(image.affine),
                                                             orientations.axcodes2ornt(("L", "P", "S"))))
    target = folder / "MR_lps.nii.gz"
    nib.save(turned, target)
    return target


def pictures(path: Path) -> list[np.ndarray]:
    network = vgraph.load(path)
    images = []
    for view in VIEWS:
        network.set("eep.camera", network.get("eep.camera").viewed_from(view))
        images.append(np.asarray(network.evaluate("rc.image", size=SIZE)))
    return images


def figure_png(rows: dict[str, list[np.ndarray]]) -> bytes:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(len(rows), len(VIEWS), figsize=(7.2, 5.0), facecolor="white")
    for r, (label, images) in enumerate(rows.items()):
        for c, (view, image) in enumerate(zip(VIEWS, images)):
            ax = axes[r][c]
            ax.imshow(np.clip(image[..., :3], 0.0, 1.0))
            ax.set_xticks([]), ax.set_yticks([])
            if r == 0:
                ax.set_title(view, fontsize=11)
            if c == 0:
                ax.set_ylabel(label, fontsize=10)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=100)
    return buffer.getvalue()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--data", type=Path, default=DATA)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        lps = lps_copy(args.data, Path(folder))
        rows = {"stored RAS": pictures(args.data), "stored LPS": pictures(lps)}
    difference = max(float(np.abs(a - b).max()) for a, b in zip(*rows.values()))
    print(f"largest difference between the RAS and LPS pictures: {difference:.3g}")
    with atomic_path(args.out) as target:
        Path(target).write_bytes(figure_png(rows))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
