"""Memory the render process keeps across networks (issue 32, item 6): RSS of the render process
after each of ``--rounds`` passes over the shipped networks (networks/*.json whose data is here),
each opened as the window opens a file (a fresh job with the whole document), against the RSS
after the empty network the window starts with. The numbers in docs/reports/gui-performance.md
("Memory across networks") come from

    .venv/bin/python bench/bench_network_switch_memory.py --rounds 10
"""

import argparse
import sys
import time
from pathlib import Path

import vgraph
from vgraph.fileformat import network_document
from vgraph.live.render_messages import RenderJob
from vgraph.live.render_process import RenderProcess
from vgraph.network import Network

REPO = Path(__file__).resolve().parent.parent


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for process {pid}")


def openable(paths):
    """The networks whose files load (their data is on this machine)."""
    found = []
    for path in paths:
        try:
            found.append((path, vgraph.load(path)))
        except vgraph.VGraphError as error:
            print(f"skipped {path.name}: {str(error).splitlines()[0][:100]}", file=sys.stderr)
    return found


class Switcher:
    """Opens networks in one render process, as the window's File > Open does."""

    def __init__(self):
        self.renderer, self.version = RenderProcess(), 0

    def open(self, network: Network) -> float:
        """Render ``network`` as a fresh job; the render process's RSS (MiB) after it."""
        self.version += 1
        base_dir = str(network.base_dir) if network.base_dir else None
        self.renderer.submit(RenderJob(self.version, network_document(network), base_dir, fresh=True))
        result = self.renderer.wait(timeout=600)
        if result.error:
            raise RuntimeError(result.error)
        return rss_mib(self.renderer.pid)

    def stop(self) -> None:
        self.renderer.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument("networks", nargs="*", type=Path, help="default: networks/*.json")
    args = parser.parse_args()
    networks = openable(args.networks or sorted((REPO / "networks").glob("*.json")))
    switcher = Switcher()
    try:
        empty = switcher.open(Network())
        print(f"empty network: {empty:.0f} MiB ({len(networks)} networks, {args.rounds} rounds)")
        for round_ in range(1, args.rounds + 1):
            start, peak = time.perf_counter(), 0.0
            for path, network in networks:
                peak = max(peak, switcher.open(network))
            after = switcher.open(Network())
            print(f"round {round_}: peak {peak:.0f} MiB, empty network after it {after:.0f} MiB "
                  f"({(after / empty - 1) * 100:+.0f} %), {time.perf_counter() - start:.0f} s", flush=True)
    finally:
        switcher.stop()


if __name__ == "__main__":
    main()
