"""ProjectedTetrahedra: error against frame time for every integration x visibility order (issue 30).

The measurement is the ``tetrahedra`` section of ``vgraph bench accuracy`` (vgraph.accuracy_tetra,
docs/reference/general/cli.md); this script runs that section alone and passes its arguments on:

    .venv/bin/python bench/bench_tetra_accuracy.py [--size 256x256] [--repeat 3] [--meshes post disk grid c]
        [--out DIR]
"""

import sys

from vgraph.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "accuracy", "--renderers", "tetrahedra", *sys.argv[1:]]))
