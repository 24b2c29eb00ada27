"""A data file on the command line (``vgraph run FILE``, ``vgraph gui FILE``): the --labels /
--intensity choice and the one line that says what the file was taken for and why
(vgraph.file_kind), e.g.::

    vgraph: frog.vti holds 29 labels (integer values 0..28): rendered as labels by the
    LabelRayCaster; --intensity renders intensities
"""

from __future__ import annotations

import argparse
import sys

import vgraph
from vgraph.file_kind import FileKind, file_kind
from vgraph.network import Network
from vgraph.volume_network import is_volume_path, volume_network


def add_render_as(parser: argparse.ArgumentParser) -> None:
    """--labels and --intensity, one or the other (argparse refuses both: exit 2)."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--labels", dest="render_as", action="store_const", const="labels",
                       help="a volume file's values are labels: render them with the "
                            "LabelRayCaster, a colour per label (default: when the file says so "
                            "or its values look like labels, docs/guide/own-data.md)")
    group.add_argument("--intensity", dest="render_as", action="store_const", const="intensity",
                       help="a volume file's values are intensities: ray cast them (or window a "
                            "single slice) even if they look like labels")


def loaded(args) -> Network:
    """The network ``run`` evaluates: a .json network, or the standard network for a data file
    after one line on stderr saying what it was taken for (unless it is an ordinary volume of
    intensities, ray cast as a volume file always was)."""
    render_as = getattr(args, "render_as", None)
    if not is_volume_path(args.network):
        return vgraph.load(args.network, allow_write=args.allow_write, render_as=render_as)
    kind = file_kind(args.network, render_as)
    if kind.sentence and not kind.ordinary:  # intensities ray cast as ever: nothing to explain
        print(f"vgraph: {kind.sentence}{other_choice(kind)}", file=sys.stderr)
    return volume_network(args.network, kind=kind)


def other_choice(kind: FileKind) -> str:
    """How to get the other rendering, where there is one and the user did not choose."""
    if kind.forced or kind.kind == "picture":
        return ""
    if kind.labels is not None:
        return "; --intensity renders intensities" if kind.kind == "labels" else \
            "; --intensity shows the values in grey"
    return "; --labels renders labels" if kind.kind == "volume" else ""
