"""Memory returned (issue 32, item 6): the render process gives back what a network took when
another replaces it (File > New or Open). Before, tets_bonsai left about 780 MiB behind after the
window went back to an empty network, and each pass over the networks kept more. The long
measurement (10 passes over every shipped network) is bench/bench_network_switch_memory.py."""

from bench_network_switch_memory import Switcher

import vgraph
from helpers.paths import REPO
from vgraph.network import Network

LIBRARIES_MIB = 250   # what the first frames load for good: the GL driver, LLVM, readers' modules


def test_switching_networks_returns_their_memory():
    networks = [vgraph.load(REPO / "networks" / f"{name}.json") for name in ("raycast_head", "tets_bonsai")]
    switcher = Switcher()
    try:
        empty = switcher.open(Network())
        peaks, afters = [], []
        for _ in range(3):
            peaks.append(max(switcher.open(network) for network in networks))
            afters.append(switcher.open(Network()))
    finally:
        switcher.stop()
    assert max(peaks) > empty + 500            # tets_bonsai takes that much while it is open
    assert afters[-1] < empty + LIBRARIES_MIB  # and gives it back
    assert max(afters) < afters[0] * 1.1       # no pass keeps more than the first
