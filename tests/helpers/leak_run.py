"""One network's leak samples in a process of its own (tests/test_leaks.py): a full test run
leaves thousands of objects and a fragmented heap behind, whose pages come and go with the
network's volumes; a fresh process measures only the network.

    python -m helpers.leak_run NETWORK.json FOLDER EVALUATIONS EVERY   (from tests/)

prints the samples as JSON lines (evaluation, textures, resident_mb)."""

import dataclasses
import json
import sys
import warnings
from pathlib import Path

import vgraph
from vgraph.leaks import repeated_evaluations, writers_redirected


def main(path: str, folder: str, count: str, every: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        network = writers_redirected(vgraph.load(Path(path)), Path(folder))
        for sample in repeated_evaluations(network, int(count), every=int(every)):
            print(json.dumps(dataclasses.asdict(sample)))


if __name__ == "__main__":
    main(*sys.argv[1:])
