"""What a mask and a cut-away cost the RayCaster (vgraph.masking): networks/mask_engine.json (the
engine CT, 256 x 256 x 128, dvr, shaded) drawn with the same picture in every variant, so that only
the weighing of the samples differs:

- "no mask": the mask inport disconnected, cutaway none (no masking code is compiled);
- "mask, hard": the label volume keeping every label (one texelFetch and a 4x4 map per sample);
- "mask, smooth": the same, blurred indicator, trilinear fetch;
- "cut-away": a sphere away from the data (a 4x4 map and a test per sample).

    .venv/bin/python bench/bench_mask.py [--size 256] [--repeat 5]

Frames of an orbit of cameras, the variants in alternation (bench/interleave.py); seconds per frame
min / median / max, EntryExitPoints included (the same in every variant). Timings on shared
machines vary up to 2x: compare within one run.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from interleave import interleaved, spread  # noqa: E402

import vgraph  # noqa: E402

NETWORK = Path(__file__).resolve().parents[1] / "networks" / "mask_engine.json"
VARIANTS = {
    "no mask": {"mask": False},
    "mask, hard": {"mask": True, "rc.mask_labels": "0, 1, 2", "rc.mask_mode": "keep"},
    "mask, smooth": {"mask": True, "rc.mask_labels": "0, 1, 2", "rc.mask_mode": "keep",
                     "rc.mask_boundary": "smooth"},
    "cut-away": {"mask": False, "rc.cutaway": "sphere", "rc.cutaway_center": (1000.0, 0.0, 0.0),
                 "rc.cutaway_size": (10.0, 10.0, 10.0)},
}


def variant_frame(settings: dict, size: int):
    network = vgraph.load(NETWORK)
    if not settings["mask"]:
        network.disconnect("labels.volume", "rc.mask")
    for address, value in settings.items():
        if address != "mask":
            network.set(address, value)
    camera = network.get("eep.camera")

    def frame(turn):
        position = np.asarray(camera.position) - np.asarray(camera.focus)
        c, s = np.cos(turn), np.sin(turn)
        turned = np.asarray(camera.focus) + (c * position[0] - s * position[1], s * position[0] + c * position[1],
                                             position[2])
        network.set("eep.camera", camera.model_copy(update={"position": tuple(turned)}))
        start = time.perf_counter()
        network.evaluate("rc.image", size=(size, size))
        return time.perf_counter() - start
    return frame


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    frames = {name: variant_frame(settings, args.size) for name, settings in VARIANTS.items()}
    turns = np.linspace(0.1, 0.5, args.repeat)
    seconds, _ = interleaved(frames, turns, 0.0)
    base = float(np.median(seconds["no mask"]))
    print(f"| variant ({args.size}^2, mask_engine.json, dvr shaded) | s per frame (min / median / max) | median / no mask |")
    print("|---|---|---|")
    for name, values in seconds.items():
        print(f"| {name} | {spread(values)} | {float(np.median(values)) / base:.2f} |")


if __name__ == "__main__":
    main()
