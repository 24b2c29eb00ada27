"""The pictures of the Shift and scale section (docs/explanations/ray-casting.md): the classic VTK
headsq CT (networks/raycast_head.json) stores its values about 1000 above Hounsfield units (air
below 150, soft tissue at 1000-1100), so the ct-bone preset, in HU, shows its soft tissue as bone;
``tf_shift`` of that offset puts the preset back on the skull without editing a point. Writes
<out>/tf_shift_head.png (the preset unshifted | shifted) and <out>/tf_shift_editor.png (the TF
editor with the shifted preset over the volume's histogram).

    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/make_tf_shift_images.py [--out docs/images] [--shift 1000]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
SIZE = (320, 320)


def renders(shift: float) -> np.ndarray:
    """The head with ct-bone as it is and shifted, side by side (float RGBA)."""
    import vgraph
    network = vgraph.load(REPO / "networks" / "raycast_head.json")
    images = []
    for value in ("ct-bone", {"preset": "ct-bone", "tf_shift": shift}):
        network.set("rc.transfer_function", value)
        images.append(network.evaluate("rc.image", size=SIZE))
    return np.concatenate(images, axis=1)


def editor_picture(shift: float, path: Path) -> None:
    """The TF editor of the head's RayCaster with the shifted preset, as the GUI's inspector shows it."""
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtWidgets import QApplication

    import vgraph
    from vgraph.gui.transfer_function_editor import TransferFunctionEditor
    from vgraph.transfer_function import ValueScale
    app = QApplication.instance() or QApplication(sys.argv)
    network = vgraph.load(REPO / "networks" / "raycast_head.json")
    network.set("rc.transfer_function", {"preset": "ct-bone", "tf_shift": shift})
    network.evaluate("rc.image", size=SIZE)
    processor = network["rc"]
    volume = processor.inputs["volume"]   # the Volume, as the render process measures it
    editor = TransferFunctionEditor(processor.properties["transfer_function"], processor)
    editor.set_histogram(volume.histogram()[0])
    editor.log_scale.setChecked(True)
    editor.set_value_scale(ValueScale.of(volume))
    editor.plot.selected = 2   # bone's start point: the readout names where it sits
    editor.show_value(network.get("rc.transfer_function"))
    editor.resize(460, 330)
    editor.show()
    app.processEvents()
    editor.grab().save(str(path))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images")
    parser.add_argument("--shift", type=float, default=1000.0)
    args = parser.parse_args(argv)
    from vgraph.imagefile import write_png
    write_png(args.out / "tf_shift_head.png", renders(args.shift))
    editor_picture(args.shift, args.out / "tf_shift_editor.png")
    print(f"wrote {args.out / 'tf_shift_head.png'} and {args.out / 'tf_shift_editor.png'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
