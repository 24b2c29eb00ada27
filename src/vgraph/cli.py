"""The ``vgraph`` command (also ``python -m vgraph``).

Exit codes: 0 ok, 2 bad input (a file, a network, a value), 1 internal failure, 130 stopped by
Ctrl-C (SIGINT). Messages go to stderr; results to files named by the options (and listings to
stdout). Warnings of vgraph's own (``VGraphWarning``) print as one line ``vgraph: warning:
<message>``; others as Python shows them.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
import warnings
from contextlib import contextmanager
from pathlib import Path

import vgraph
from vgraph import animation
from vgraph.atomic import check_output_path, write_text_atomic
from vgraph.camera import VIEW_NAMES
from vgraph.cli_common import (EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK, add_allow_write,
                               check_before_evaluating)
from vgraph.cli_data import add_render_as, loaded
from vgraph.cli_values import parse_size, set_from_command_line, set_view, user_path
from vgraph.errors import ProcessorError, VGraphError, VGraphWarning
from vgraph.memory import out_of_memory
from vgraph.property_text import property_text
from vgraph.scheduler import blank_image_warning, default_target, evaluate, finish_gl, target_type
from vgraph.time_series import warn_time_series
from vgraph.volume_network import is_volume_path

def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    try:
        with vgraph_warnings_as_lines():
            for module in getattr(args, "plugin", None) or []:
                vgraph.registry.load_plugin(module)
            return args.command(args)
    except VGraphError as error:
        print(f"vgraph: error: {error}", file=sys.stderr)
        return EXIT_INTERNAL if isinstance(error, ProcessorError) and error.internal else EXIT_BAD_INPUT
    except MemoryError as error:  # outside any processor (which names itself): loading, writing
        print(f"vgraph: error: {out_of_memory(error)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:  # Ctrl-C: one line, and the exit code of a command stopped by SIGINT
        print("vgraph: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception:
        print("vgraph: internal error (please report it):", file=sys.stderr)
        traceback.print_exc()
        return EXIT_INTERNAL


@contextmanager
def vgraph_warnings_as_lines():
    """Show VGraphWarnings (and subclasses such as BlankImageWarning) as ``vgraph: warning: ...``
    on stderr, one line each; other warnings as Python shows them. Filters (-W) still apply."""
    with warnings.catch_warnings():
        python_way = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, VGraphWarning):
                text = " ".join(str(message).split("\n"))
                print(f"vgraph: warning: {text}", file=file or sys.stderr)
            else:
                python_way(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vgraph", description="Node-graph volume visualization.")
    parser.add_argument("--version", action="version", version=f"vgraph {vgraph.__version__}")
    commands = parser.add_subparsers(title="commands")

    run = commands.add_parser("run", help="evaluate a network and write its output")
    run.add_argument("network", type=user_path, help="the .json network, or a data file: a volume, a "
                                                "single slice, a PNG or JPEG (rendered by the standard "
                                                "network for what it holds: docs/guide/own-data.md)")
    run.add_argument("-o", "--output", type=user_path, metavar="OUT.png",
                     help="write the image as an 8-bit PNG")
    run.add_argument("--data", action="append", default=[], type=user_path, metavar="OUT",
                     help="write the data; the extension chooses the format: .npy, .npz (image: "
                          "float32 H x W x 4; volume: .npz keeps the grid), .nrrd, .nii, .nii.gz, "
                          ".mha, .vti (volumes, with their affine; run on a data file without "
                          "--port they write the volume read), .csv (tables); repeatable")
    run.add_argument("--npy", type=user_path, metavar="OUT.npy", help="deprecated: --data OUT.npy")
    run.add_argument("--port", help="the port to evaluate, ID.PORT (default: the Canvas)")
    run.add_argument("--size", type=parse_size, metavar="WxH",
                     help="size of the image written (default: the Canvas size); renderers draw at it")
    run.add_argument("--view", choices=VIEW_NAMES, metavar="NAME",
                     help=f"turn every camera to a named view framing the data: {', '.join(VIEW_NAMES)}")
    run.add_argument("--set", action="append", default=[], metavar="ID.PROPERTY=VALUE",
                     help="change a property before evaluating (after --view); VALUE is JSON where it "
                          "parses; a relative file path is relative to the current folder")
    run.add_argument("--profile", type=user_path, metavar="PROFILE.json",
                     help="write which processors ran and their times (each with its GL work: the GL is "
                          "finished after each processor), and the one that failed")
    run.add_argument("--plugin", action="append", metavar="MODULE", help="import a plug-in module")
    add_render_as(run)
    add_allow_write(run)
    run.add_argument("--cluster", metavar="local:N|tcp://HOST:PORT",
                     help="render on a Dask cluster: N local worker processes, or a running scheduler "
                          "whose workers see the network's files at the same paths (docs/guide/distributed.md)")
    run.add_argument("--split", choices=["tiles", "leaves"], help="how --cluster divides the work "
                     "(default: tiles; leaves: runs of a BrickedRayCaster's bricks, docs/guide/distributed.md)")
    run.add_argument("--tiles", metavar="CxR", help="columns x rows of the tiles split (default: 2x2)")
    run.set_defaults(command=command_run)

    validate = commands.add_parser("validate", help="check a network file")
    validate.add_argument("network", type=user_path)
    validate.add_argument("--plugin", action="append", metavar="MODULE")
    add_allow_write(validate)
    validate.set_defaults(command=command_validate)

    listing = commands.add_parser("list", help="list the processor types")
    listing.add_argument("--json", action="store_true", help="machine-readable output")
    listing.add_argument("--plugin", action="append", metavar="MODULE")
    listing.set_defaults(command=command_list)

    animation.add_parser(commands)

    gui = commands.add_parser("gui", help="open the network editor (PySide6)")
    gui.add_argument("network", type=user_path, nargs="?", help="a .json network or a volume file to open")
    gui.add_argument("--plugin", action="append", metavar="MODULE", help="import a plug-in module")
    gui.add_argument("--screenshot", type=user_path, metavar="OUT.png",
                     help="wait until the canvases have rendered, save the window as a PNG and exit")
    gui.add_argument("--select", metavar="ID", help="select this processor (its properties show)")
    gui.add_argument("--window-size", type=parse_size, metavar="WxH", help="window size in pixels")
    add_render_as(gui)
    gui.set_defaults(command=command_gui)

    add_convert_parser(commands)

    bench = commands.add_parser("bench", help="benchmarks: error against frame time per renderer")
    bench.set_defaults(command=lambda args: _print_help(bench))
    benchmarks = bench.add_subparsers(title="benchmarks")
    accuracy = benchmarks.add_parser(
        "accuracy", help="error against frame time, a section per renderer: curvature, projected "
                         "tetrahedra, bricked levels (docs/reports/accuracy.md)")
    accuracy.add_argument("--renderers", nargs="+", metavar="NAME",
                          help="sections to measure: curvature tetrahedra bricked (default: all)")
    accuracy.add_argument("--repeat", type=int,
                          help="timed frames per case (default: curvature 7, tetrahedra 3, bricked 3)")
    accuracy.add_argument("--size", type=parse_size,
                          help="image size WxH (default: curvature and tetrahedra 256x256, bricked 192x192)")
    accuracy.add_argument("--out", type=user_path,
                          help="output folder (default: bench/results/accuracy)")
    accuracy.add_argument("--quick", action="store_true",
                          help="small matrices in seconds, no data files (curvature: sphere, torus; 32, 64; "
                               "uint8, float32; forward, central, tricubic, cpu; 128x128; repeat 2. "
                               "tetrahedra: grid and c, 96x96, repeat 1. bricked: synthetic, 16^3 bricks, "
                               "96x96, repeat 1); given options still apply")
    curvature = accuracy.add_argument_group("curvature (CurvatureRaycaster)")
    curvature.add_argument("--functions", nargs="+", metavar="NAME",
                           help="implicit functions (default: sphere torus ellipsoid saddle)")
    curvature.add_argument("--resolutions", nargs="+", type=int, metavar="N",
                           help="voxels per axis (default: 32 64 128 256)")
    curvature.add_argument("--derivatives", nargs="+", metavar="MODE",
                           help="forward central filtered tricubic tricubic_fast cpu (default: all)")
    curvature.add_argument("--data-types", nargs="+", metavar="TYPE",
                           help="uint8 uint16 float32 (default: all)")
    tetrahedra = accuracy.add_argument_group("tetrahedra (ProjectedTetrahedra)")
    tetrahedra.add_argument("--meshes", nargs="+", metavar="NAME",
                            help="post disk grid c (default: all; grid and c are made here, no data)")
    tetrahedra.add_argument("--integrations", nargs="+", metavar="MODE",
                            help="averaged preintegrated partial (default: all)")
    tetrahedra.add_argument("--orders", nargs="+", metavar="ORDER",
                            help="centroid mpvo mpvonc (default: all)")
    tetrahedra.add_argument("--post-mesh", type=user_path, metavar="FILE",
                            help="the post mesh (default: ../shared/data/tet_lox_post/post.vtk)")
    tetrahedra.add_argument("--disk-mesh", type=user_path, metavar="FILE",
                            help="the disk mesh (default: ../shared/data/hex_disk_out_ref/disk_out_ref.vtu)")
    bricked = accuracy.add_argument_group("bricked (BrickedRayCaster levels of detail)")
    bricked.add_argument("--volumes", nargs="+", metavar="NAME",
                         help="bonsai synthetic (default: both; synthetic is made here, no data)")
    bricked.add_argument("--bonsai", type=user_path, metavar="FILE",
                         help="the bonsai volume (default: ../shared/data/ct_bonsai/bonsai.nii.gz)")
    bricked.add_argument("--brick", type=int, metavar="N", help="brick edge in voxels (default: 32)")
    accuracy.set_defaults(command=command_bench_accuracy)
    return parser


def add_convert_parser(commands) -> None:
    convert = commands.add_parser(
        "convert", help="convert a volume file into an OME-Zarr pyramid of bricks (volumes larger "
                        "than memory: docs/guide/large-data.md)")
    convert.add_argument("input", type=user_path, help="the volume file; uncompressed raw, NRRD, .nii, "
                                                  "MetaImage and .npy are read slab by slab, other "
                                                  "formats whole")
    convert.add_argument("output", type=user_path, metavar="OUT.zarr",
                         help="the store (a folder), replaced only when the conversion succeeds")
    convert.add_argument("--brick", type=int, default=64, metavar="N",
                         help="voxels per brick edge, even (default 64)")
    convert.add_argument("--levels", type=int, metavar="N",
                         help="pyramid levels (default: until the coarsest fits in one brick)")
    convert.add_argument("--time-step", type=int, default=0, metavar="T",
                         help="of a file with a time axis: the time point to convert (default 0)")
    convert.add_argument("--raw-dims", type=int, nargs=3, metavar=("X", "Y", "Z"),
                         help="a headerless raw file's voxels (with --raw-dtype ...)")
    convert.add_argument("--raw-dtype", default="uint8", help="a headerless raw file's voxel type")
    convert.add_argument("--raw-endianness", default="little", choices=["little", "big"])
    convert.add_argument("--raw-offset", type=int, default=0, metavar="BYTES",
                         help="header bytes before a raw file's data (-1: the data end the file)")
    convert.add_argument("--quiet", action="store_true", help="no progress bar")
    convert.set_defaults(command=command_convert)


def _print_help(parser: argparse.ArgumentParser) -> int:
    parser.print_help(sys.stderr)
    return EXIT_BAD_INPUT


def command_run(args) -> int:
    # imported when used: cli_output writes volumes through vgraph.io, whose readers' libraries
    # (pydicom, nibabel) take 0.15 s that vgraph --help, list and validate need not wait for
    from vgraph.cli_output import check_formats, requested_outputs, targets_of, write_outputs

    outputs = requested_outputs(args)  # refused before a long evaluation, not after
    if args.profile is not None:
        check_output_path(args.profile)
    network = loaded(args)  # a data file: the network for what it holds, said on stderr
    if args.view:
        set_view(network, args.view)
    for assignment in args.set:
        set_from_command_line(network, assignment)
    check_before_evaluating(network, args.network)
    target = args.port or (default_target(network) if outputs else None)
    groups = targets_of(outputs, target, network, from_data_file=is_volume_path(args.network) and not args.port)
    for each, its_outputs in groups.items():
        check_formats(its_outputs, each, target_type(network, each))
    if args.cluster is not None or args.split is not None or args.tiles is not None:
        if set(groups) - {target}:
            raise VGraphError(f"{', '.join(str(o) for t in groups if t != target for o in groups[t])}: "
                              f"writes the volume read, which a cluster run does not hold; write "
                              f"it in a run without --cluster, --split or --tiles")
        # imported when used: the cluster's modules bring the bricks' and scipy's (0.2 s)
        from vgraph.distributed.command import run_on_cluster
        return run_on_cluster(args, network, outputs, target)
    started = time.perf_counter()
    try:
        # A profile waits for the GL after each processor, so each time holds its own GL work
        # (docs/reference/general/cli.md); a run without one lets the GL work overlap with the next processor.
        report = evaluate(network, evaluation_targets(network, args.port, groups), size=args.size,
                          finish_each=args.profile is not None)
        finish_gl()  # what is still queued belongs to the evaluation's time printed below
        seconds = time.perf_counter() - started
    finally:
        if args.profile and network.last_evaluation is not None:
            write_text_atomic(args.profile, json.dumps(network.last_evaluation.to_json(), indent=2) + "\n")
    warn_time_series(network)  # a 4D file's one time point, said once per source
    for each, its_outputs in groups.items():
        write_outputs(its_outputs, each, network.output(each),
                      lambda pixels, each=each: blank_image_warning(network, each, pixels))
    if not outputs:
        say_nothing_was_written(network, report, profile=args.profile)
    ran = ", ".join(report.ids) or "nothing (all valid)"
    print(f"evaluated {ran} in {seconds:.3f} s", file=sys.stderr)
    return EXIT_OK


def evaluation_targets(network, port: str | None, groups: dict) -> list[str]:
    """What ``run`` evaluates: the --port, else every sink (the scheduler's default), and the
    source's volume where a --data output writes it (cli_output.targets_of)."""
    if port:
        return [port]
    extra = [target for target in groups if target not in {p.id for p in network.sinks()}]
    return [p.id for p in network.sinks()] + extra if extra else []


def say_nothing_was_written(network, report, profile: Path | None) -> None:
    """``vgraph run NET`` without -o or --data: the result stays unwritten, which should not go
    unnoticed. The network's own writers (sinks with a file path they write) did write."""
    writers = [f"{pid} -> {network[pid].resolve_path(network.get(f'{pid}.{name}'))}"
               for pid in report.ids for name, prop in network[pid].properties.items()
               if prop.kind == "file_path" and getattr(prop, "writes", False) and not network[pid].outports]
    wrote = f"only the network's writers wrote ({'; '.join(writers)})" if writers else \
        "no result written (only the profile)" if profile else "nothing written"
    has_canvas = any(p.type_name == "Canvas" for p in network.processors.values())
    port = "" if has_canvas else "choose a port with --port ID.PORT and "
    print(f"vgraph: {wrote}: no -o or --data given; {port}write the image with -o OUT.png, the "
          f"data with --data OUT.npz (or .npy; volumes also .nrrd, .nii, .nii.gz, .mha, .vti)",
          file=sys.stderr)


def command_validate(args) -> int:
    network = vgraph.load(args.network, allow_write=args.allow_write)
    check_before_evaluating(network, args.network)
    for processor in network.processors.values():
        for inport in processor.inports:
            if not inport.optional and not network.inputs_of(processor.id, inport.name):
                print(f"{args.network}: warning: inport {processor.id}.{inport.name} is not connected",
                      file=sys.stderr)
    print(f"{args.network}: valid ({len(network.processors)} processors, "
          f"{len(network.connections)} connections, {len(network.links)} links"
          + (f", {len(network.tracks)} tracks)" if network.tracks else ")"))
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
                print(f"      property {property_text(prop)}")
    for origin, reason in vgraph.registry.failed_plugins.items():
        print(f"plug-in {origin} failed to load: {reason}", file=sys.stderr)
    return EXIT_OK


def command_gui(args) -> int:
    from vgraph.gui.app import run_gui  # imported here so no other command imports Qt
    if args.screenshot is not None:
        check_output_path(args.screenshot)
    if args.render_as is not None and (args.network is None or not is_volume_path(args.network)):
        raise VGraphError(f"--{args.render_as} applies to a data file to open, not to "
                          f"{args.network or 'an empty editor'}")
    return run_gui(args.network, screenshot=args.screenshot, select=args.select, size=args.window_size,
                   render_as=args.render_as)


def command_convert(args) -> int:
    from vgraph.io.convert import convert  # imported when used: vgraph.io and zarr take 0.3 s
    raw = None if args.raw_dims is None else {
        "dims": tuple(args.raw_dims), "dtype": args.raw_dtype, "endianness": args.raw_endianness,
        "offset": args.raw_offset}
    report = convert(args.input, args.output, brick=args.brick, levels=args.levels, raw=raw,
                     time_step=args.time_step, progress=not args.quiet)
    print(report.text(), file=sys.stderr)
    return EXIT_OK


def command_bench_accuracy(args) -> int:
    from vgraph.accuracy_sections import command  # imported here: the benchmark needs matplotlib
    return command(args)
