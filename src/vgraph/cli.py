"""The ``vgraph`` command (also ``python -m vgraph``).

Exit codes: 0 ok, 2 bad input (a file, a network, a value), 1 internal failure. Messages go to
stderr; results to files named by the options (and listings to stdout).
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback
from pathlib import Path

import numpy as np

import vgraph
from vgraph.errors import ProcessorError, VGraphError

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT = 0, 1, 2


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    try:
        for module in getattr(args, "plugin", None) or []:
            vgraph.registry.load_plugin(module)
        return args.command(args)
    except VGraphError as error:
        print(f"vgraph: error: {error}", file=sys.stderr)
        return EXIT_INTERNAL if isinstance(error, ProcessorError) and error.internal else EXIT_BAD_INPUT
    except KeyboardInterrupt:
        return EXIT_INTERNAL
    except Exception:
        print("vgraph: internal error (please report it):", file=sys.stderr)
        traceback.print_exc()
        return EXIT_INTERNAL


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vgraph", description="Node-graph volume visualization.")
    parser.add_argument("--version", action="version", version=f"vgraph {vgraph.__version__}")
    commands = parser.add_subparsers(title="commands")

    run = commands.add_parser("run", help="evaluate a network and write its output")
    run.add_argument("network", type=Path, help="the .json network")
    run.add_argument("-o", "--output", type=Path, help="write the image as an 8-bit PNG")
    run.add_argument("--npy", type=Path, help="write the data as .npy (image: float32 H x W x 4)")
    run.add_argument("--port", help="the port to evaluate, ID.PORT (default: the Canvas)")
    run.add_argument("--size", type=parse_size, help="image size WxH (default: the Canvas size)")
    run.add_argument("--set", action="append", default=[], metavar="ID.PROPERTY=VALUE",
                     help="change a property before evaluating; VALUE is JSON where it parses")
    run.add_argument("--profile", type=Path, help="write which processors ran and their times")
    run.add_argument("--plugin", action="append", metavar="MODULE", help="import a plug-in module")
    add_allow_write(run)
    run.set_defaults(command=command_run)

    validate = commands.add_parser("validate", help="check a network file")
    validate.add_argument("network", type=Path)
    validate.add_argument("--plugin", action="append", metavar="MODULE")
    add_allow_write(validate)
    validate.set_defaults(command=command_validate)

    listing = commands.add_parser("list", help="list the processor types")
    listing.add_argument("--json", action="store_true", help="machine-readable output")
    listing.add_argument("--plugin", action="append", metavar="MODULE")
    listing.set_defaults(command=command_list)

    gui = commands.add_parser("gui", help="open the network editor (PySide6)")
    gui.add_argument("network", type=Path, nargs="?", help="a .json network to open")
    gui.add_argument("--plugin", action="append", metavar="MODULE", help="import a plug-in module")
    gui.add_argument("--screenshot", type=Path, metavar="OUT.png",
                     help="wait until the canvases have rendered, save the window as a PNG and exit")
    gui.add_argument("--select", metavar="ID", help="select this processor (its properties show)")
    gui.add_argument("--window-size", type=parse_size, metavar="WxH", help="window size in pixels")
    gui.set_defaults(command=command_gui)

    bench = commands.add_parser("bench", help="benchmarks: curvature accuracy against frame time")
    bench.set_defaults(command=lambda args: _print_help(bench))
    benchmarks = bench.add_subparsers(title="benchmarks")
    accuracy = benchmarks.add_parser(
        "accuracy", help="curvature error against frame time per function, resolution, data type "
                         "and derivative mode (docs/accuracy.md)")
    accuracy.add_argument("--functions", nargs="+", metavar="NAME",
                          help="implicit functions (default: sphere torus ellipsoid saddle)")
    accuracy.add_argument("--resolutions", nargs="+", type=int, metavar="N",
                          help="voxels per axis (default: 32 64 128 256)")
    accuracy.add_argument("--derivatives", nargs="+", metavar="MODE",
                          help="forward central filtered tricubic tricubic_fast cpu (default: all)")
    accuracy.add_argument("--data-types", nargs="+", metavar="TYPE",
                          help="uint8 uint16 float32 (default: all)")
    accuracy.add_argument("--repeat", type=int, help="timed frames per case (default: 7)")
    accuracy.add_argument("--size", type=parse_size, help="image size WxH (default: 256x256)")
    accuracy.add_argument("--out", type=Path,
                          help="output folder (default: bench/results/accuracy)")
    accuracy.add_argument("--quick", action="store_true",
                          help="a small matrix in seconds (sphere, torus; 32, 64; uint8, float32; "
                               "forward, central, tricubic, cpu; 128x128; repeat 2); given "
                               "options still apply")
    accuracy.set_defaults(command=command_bench_accuracy)
    return parser


def add_allow_write(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--allow-write", action="append", default=[], type=Path, metavar="DIR",
                        help="let the network's writers write into DIR too (by default only inside "
                             "the network file's folder); repeatable")


def _print_help(parser: argparse.ArgumentParser) -> int:
    parser.print_help(sys.stderr)
    return EXIT_BAD_INPUT


def parse_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 512x384, got '{text}'") from None
    return width, height


def parse_assignment(text: str) -> tuple[str, object]:
    address, equals, value = text.partition("=")
    if not equals:
        raise VGraphError(f"--set {text}: expected ID.PROPERTY=VALUE")
    try:
        return address.strip(), json.loads(value)
    except json.JSONDecodeError:
        return address.strip(), value  # a bare string such as a file name


def command_run(args) -> int:
    from vgraph.atomic import atomic_path, check_output_path, write_text_atomic
    from vgraph.image import Image
    from vgraph.imagefile import write_png
    from vgraph.scheduler import default_target, to_numpy

    for output in (args.output, args.npy, args.profile):
        if output is not None:
            check_output_path(output)  # refuse before a long evaluation, not after
    network = vgraph.load(args.network, allow_write=args.allow_write)
    for assignment in args.set:
        network.set(*parse_assignment(assignment))
    wants_output = args.output or args.npy
    target = args.port or (default_target(network) if wants_output else None)
    try:
        report = network.update(*([target] if args.port else []), size=args.size)
    finally:
        if args.profile and network.last_evaluation is not None:
            write_text_atomic(args.profile, json.dumps(network.last_evaluation.to_json(), indent=2) + "\n")
    if args.output:
        image = network.output(target)
        if not isinstance(image, Image):
            raise VGraphError(f"{target} holds {type(image).__name__}, not an image: use --npy")
        write_png(args.output, warned_if_blank(network, target, image.to_numpy()))
    if args.npy:
        with atomic_path(args.npy, suffix=".npy") as temporary:
            np.save(temporary, warned_if_blank(network, target, to_numpy(network.output(target))))
    ran = ", ".join(report.ids) or "nothing (all valid)"
    print(f"evaluated {ran} in {report.total_seconds:.3f} s", file=sys.stderr)
    return EXIT_OK


def warned_if_blank(network, target: str, pixels: np.ndarray) -> np.ndarray:
    from vgraph.scheduler import blank_image_warning
    warning = blank_image_warning(network, target, pixels)
    if warning:
        print(f"vgraph: warning: {warning}", file=sys.stderr)
    return pixels


def command_validate(args) -> int:
    network = vgraph.load(args.network, allow_write=args.allow_write)
    for processor in network.processors.values():
        for inport in processor.inports:
            if not inport.optional and not network.inputs_of(processor.id, inport.name):
                print(f"{args.network}: warning: inport {processor.id}.{inport.name} is not connected",
                      file=sys.stderr)
    print(f"{args.network}: valid ({len(network.processors)} processors, "
          f"{len(network.connections)} connections, {len(network.links)} links)")
    return EXIT_OK


def command_list(args) -> int:
    types = vgraph.registry.all()
    if args.json:
        print(json.dumps([cls.describe() for cls in types], indent=2))
        return EXIT_OK
    for category in sorted({cls.category for cls in types}):
        print(f"{category}:")
        for cls in (c for c in types if c.category == category):
            print(f"  {cls.type_name:24s} {cls.description}")
            for port in (*cls.inports, *cls.outports):
                print(f"      {port.direction:3s} {port.name}: {port.type_name}")
            for prop in cls.properties.values():
                print(f"      property {prop.name} ({prop.kind}) = {prop.to_json(prop.default)!r}")
    for origin, reason in vgraph.registry.failed_plugins.items():
        print(f"plug-in {origin} failed to load: {reason}", file=sys.stderr)
    return EXIT_OK


def command_gui(args) -> int:
    from vgraph.atomic import check_output_path
    from vgraph.gui.app import run_gui  # imported here so no other command imports Qt
    if args.screenshot is not None:
        check_output_path(args.screenshot)
    return run_gui(args.network, screenshot=args.screenshot, select=args.select, size=args.window_size)


def command_bench_accuracy(args) -> int:
    from vgraph.accuracy_report import command  # imported here: the benchmark needs matplotlib
    return command(args)
