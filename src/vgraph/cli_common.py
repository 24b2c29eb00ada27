"""What the ``vgraph`` subcommands share: the exit statuses, ``--allow-write`` and the checks
before evaluating. vgraph.cli, vgraph.animation (``vgraph animate``) and vgraph.distributed.command
(``vgraph run --cluster``) import them from here, not from cli.py, which imports those commands:
so no import circle runs through the command line (docs/explanations/architecture.md, "Layers")."""

from __future__ import annotations

import argparse

from vgraph.cli_values import user_path
from vgraph.write_paths import check_writers

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT = 0, 1, 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports a command stopped by Ctrl-C


def add_allow_write(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--allow-write", action="append", default=[], type=user_path, metavar="DIR",
                        help="let the network's writers write into DIR too (by default only inside "
                             "the network file's folder); repeatable")


def check_before_evaluating(network, file) -> None:
    """What ``run`` refuses about a loaded network before evaluating it, beyond what loading
    refuses; ``validate`` refuses the same: what its writers could not write (vgraph.write_paths)."""
    check_writers(network, str(file))
