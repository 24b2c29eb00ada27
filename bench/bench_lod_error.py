"""BrickedRayCaster: error against frame time for the levels of detail, with and without the error
budget (max_error), on smooth, stiff and faint transfer functions (issue 30).

The measurement is the ``bricked`` section of ``vgraph bench accuracy`` (vgraph.accuracy_bricks,
docs/reference/general/cli.md); this script runs that section alone and passes its arguments on:

    .venv/bin/python bench/bench_lod_error.py [--volumes bonsai synthetic] [--bonsai FILE] [--size 192x192]
        [--brick 32] [--repeat 3] [--out DIR]
"""

import sys

from vgraph.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "accuracy", "--renderers", "bricked", *sys.argv[1:]]))
