"""``vgraph run NET -o OUT.png --cluster local:N|tcp://HOST:PORT [--split tiles|leaves] [--tiles CxR]``:
the run subcommand's cluster path (the parser and the local path stay in vgraph.cli). Everything
that can be refused is refused before a cluster starts; the image is written atomically, as a
local run writes it.
"""

from __future__ import annotations

import sys
import time

from vgraph.cli_common import EXIT_INTERRUPTED, EXIT_OK
from vgraph.distributed import connect, parse_cluster, parse_grid, render_report
from vgraph.distributed.render import prepare
from vgraph.errors import VGraphError


def run_on_cluster(args, network, outputs, target) -> int:
    """``vgraph run ... --cluster``: the picture rendered by the cluster's workers (tiles or leaves), written
    as a local run writes it (atomically, the same messages)."""
    from vgraph.cli_output import write_image_outputs  # imported when used: vgraph.io takes 0.15 s

    if args.cluster is None:
        raise VGraphError("--split and --tiles need --cluster local:N or --cluster tcp://HOST:PORT")
    if args.profile is not None:
        raise VGraphError("--profile times one process; it cannot be combined with --cluster")
    if not outputs:
        raise VGraphError("--cluster renders an image: write it with -o OUT.png or --data OUT.npz")
    split, grid = args.split or "tiles", parse_grid(args.tiles or "2x2")  # refused before starting
    parse_cluster(args.cluster)
    if split == "leaves" and args.tiles is not None:
        raise VGraphError("--tiles cuts the picture of the tiles split; --split leaves divides the bricks")
    prepare(network, split, grid, args.size, target)  # refuse what the split cannot render before starting
    start = time.perf_counter()
    try:
        with connect(args.cluster) as client:
            workers = len(client.scheduler_info().get("workers", {}))
            frame = render_report(network, client, split=split, tiles=grid, size=args.size, target=target,
                                  plugins=args.plugin or (), cluster=args.cluster)
    except KeyboardInterrupt:
        # render() cancelled the frame's tasks and connect() closed the cluster it started: one
        # line, and the exit code of a command stopped by SIGINT.
        print(f"vgraph: interrupted: the render on {args.cluster} was cancelled after "
              f"{time.perf_counter() - start:.1f} s; nothing was written", file=sys.stderr)
        return EXIT_INTERRUPTED
    write_image_outputs(outputs, frame.image)
    how = f"{grid[0]}x{grid[1]} tiles" if split == "tiles" else "runs of bricks (leaves)"
    print(f"rendered {target} as {how} on {workers} worker(s) of "
          f"{args.cluster} in {time.perf_counter() - start:.3f} s", file=sys.stderr)
    for line in frame.lines():  # what each worker read through its brick caches and computed
        print(line, file=sys.stderr)
    return EXIT_OK
