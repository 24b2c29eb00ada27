"""How far the cluster's pictures are from the single process's, for every renderer it runs
(issue 30; the numbers of docs/guide/distributed.md "Accuracy" and the tolerances of
tests/test_distributed*.py).

    nice -n 10 .venv/bin/python bench/distributed_tolerances.py [--only NAME ...] [--size 128]

Each case is drawn whole in this process and split as the workers split it, by the workers' own
task functions called in this process (the tiles: ``worker.render_tile`` per tile and
``tiles.assemble``; the leaves: ``plan_task``, ``run_task`` per run, the ``composite`` tree and
``resolve_task``): a task on a worker is the same function of the same arguments, so the numbers
are the cluster's without starting one. Per case: the largest difference of any channel, the
pixels that differ by more than 1e-6, and whether the two pictures are finite.

Cases: the shipped networks of each renderer (RayCaster, LabelRayCaster, MultiVolumeRayCaster,
the curvature ray caster with exponential normalization, ProjectedTetrahedra in each integration
mode and visibility order, GeometryRenderer), a BrickedRayCaster on a rippled ball (dvr, mip,
iso) in tiles and leaves, and the stiff cases of issue 30 item 6: a spike transfer function one
data unit wide, opacities near 0 and near 1, optical depths 1e-8 and 1e8 (the tetrahedra's
reference_length), in tiles and leaves.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from distributed_cases import (bricked_network, difference, leaves_picture, shipped_network, spike_tf,
                               stiff_mesh_network, tets_network, tiles_picture)


def cases(folder: Path, size: int):
    """(name, network, split, grid or runs, size) of every case."""
    square, wide = (size, size), (size, size * 3 // 4)
    for name in ("raycast_sphere", "raycast_head", "labels_engine", "two_channels_hydrogen_neghip",
                 "clip_engine"):
        yield name, lambda n=name: shipped_network(n), "tiles", (2, 3), square
    yield "curvature_torus (exponential)", lambda: shipped_network(
        "curvature_torus", {"curvature.normalization": "exponential"}), "tiles", (2, 3), square
    yield "head_skin_mesh_bone_volume (GeometryRenderer)", lambda: shipped_network(
        "head_skin_mesh_bone_volume"), "tiles", (2, 2), square
    for name in ("tets_lox_post", "tets_bonsai", "tets_disk_out_ref"):
        for integration in ("averaged", "preintegrated", "partial"):
            yield f"{name} {integration}", lambda n=name, i=integration: shipped_network(
                n, {"pt.integration": i}), "tiles", (2, 2), square
        yield f"{name} mpvonc", lambda n=name: shipped_network(
            n, {"pt.visibility_order": "mpvonc", "pt.integration": "partial"}), "tiles", (2, 2), square
    for mode, extra in (("dvr", {"shading": "blinn_phong"}), ("mip", {}),
                        ("iso", {"iso_level": 0.45, "shading": "blinn_phong"})):
        for split, parts in (("tiles", (2, 3)), ("leaves", 3)):
            yield f"bricked {mode} {split}", lambda m=mode, e=extra: bricked_network(
                folder, compositing=m, **e), split, parts, wide
    for split, parts in (("tiles", (2, 3)), ("leaves", 3)):  # 48 x 36 pixels: levels 1 and 2
        yield f"bricked dvr coarser levels (96^3, lod_bias 0) {split}", lambda: bricked_network(
            folder, shape=(96, 96, 96), lod_bias=0.0, shading="blinn_phong"), split, parts, (48, 36)
    # Stiff cases (issue 30, item 6)
    for split, parts in (("tiles", (2, 3)), ("leaves", 3)):
        yield f"bricked spike TF {split}", lambda: bricked_network(
            folder, transfer_function=spike_tf(50.0)), split, parts, wide
        for opacity in (1e-6, 1 - 1e-6):
            yield f"bricked opacity {opacity:g} {split}", lambda o=opacity: bricked_network(
                folder, transfer_function=spike_tf(50.0, width=100.0, opacity=o)), split, parts, wide
    for integration in ("averaged", "preintegrated", "partial"):
        yield f"tets spike TF {integration}", lambda i=integration: stiff_mesh_network(
            folder, integration=i), "tiles", (2, 3), square
    for length in (1e8, 1e-8):  # optical depth ~ 1 / reference_length: 1e-8 and 1e8
        yield f"tets reference_length {length:g}", lambda n=length: stiff_mesh_network(
            folder, integration="partial", reference_length=n), "tiles", (2, 3), square
    for opacity in (1e-6, 1 - 1e-6):
        yield f"tets opacity {opacity:g}", lambda o=opacity: tets_network(
            folder, transfer_function=spike_tf(50.0, width=100.0, opacity=o)), "tiles", (2, 3), square


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=128, help="image width (default 128)")
    parser.add_argument("--only", nargs="*", default=[], help="cases whose name contains one of these")
    args = parser.parse_args(argv)
    print("| case | split | size | largest difference | pixels > 1e-6 | worst pixel (row, col) | finite | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as temporary:
        for name, make, split, parts, size in cases(Path(temporary), args.size):
            if args.only and not any(word in name for word in args.only):
                continue
            start = time.perf_counter()
            try:
                network = make()
            except FileNotFoundError as missing:
                print(f"| {name} | {split} | | skipped: {missing} | | | | |")
                continue
            split_picture = tiles_picture if split == "tiles" else leaves_picture
            image, reference = split_picture(network, size, parts)
            d = difference(image, reference)
            label = f"{split} {'x'.join(map(str, parts)) if split == 'tiles' else f'{parts} runs'}"
            print(f"| {name} | {label} | {size[0]}x{size[1]} | {d['max']:.2g} | {d['pixels']} | "
                  f"{d['worst_pixel'][:2]} | {d['finite'] and d['same_nan']} | "
                  f"{time.perf_counter() - start:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
