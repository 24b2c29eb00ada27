"""Virtual stores (issue #33, item 4): 8192^3 and 16384^3 uint8 volumes whose chunks are computed
from an implicit function when read (vgraph.bricks.implicit_store), rendered by the
BrickedRayCaster within a RAM budget; each case in a fresh process.

    .venv/bin/python bench/bench_virtual_store.py [--sizes 8192 16384] [--budget 256]
        [--image 512] [--load-limit 64] [--methods passes single_pass] [--function torus]
        [--lod-bias 0] [--stores /tmp/vgraph-bench/bonsai1024.zarr]

Per case: the first frame (seconds from the process's start: imports, opening the store, the
first frame at the load limit), the frames until one is complete (``last_frame["complete"]``,
each reading at most LOAD_LIMIT bricks, as the GUI does), the bricks read and the time to the
completed frame, and the process's peak RSS (resource.getrusage), in all and what the frames added
to it after the volume was opened and the GL started; for the single pass, its leaf table's size
(the directory and pages of vgraph.bricks.leaf_pages: bytes, directory level, pages) in the last
frame. Prints a markdown table.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

RENDER = """
import time
started = time.perf_counter()
import json, resource, sys, warnings
import vgraph
from vgraph.frame_context import FrameContext
from vgraph.bricks.cache import LoadLimit
from vgraph.bricks.paged_sampling import PagedSampling
url, budget, size, limit, method, bias = (sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]),
                                          sys.argv[5], float(sys.argv[6]))
warnings.simplefilter("ignore")
net = vgraph.Network()
net.add("VolumeSource", id="src", path=url, memory_budget=budget)
net.add("EntryExitPoints", id="eep")
net.add("BrickedRayCaster", id="rc", ram_budget=budget, gl_budget=budget, method=method, lod_bias=bias)
net.link("eep.camera", "rc.camera")
for a, b in (("src.volume", "eep.volume"), ("src.volume", "rc.volume"), ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit")):
    net.connect(a, b)
frames, first = 0, None
net.evaluate("eep.entry", size=(size, size))  # the volume opened, GL up: what the frames add comes after
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
try:
    while frames < 400:
        net.evaluate("rc.image", size=(size, size), context=FrameContext(load_limit=LoadLimit(bricks=limit)))
        frames += 1
        first = first or time.perf_counter() - started
        frame = net["rc"].last_frame
        if frame.get("complete", True):
            break
        net.invalidate_downstream("rc")  # as the GUI's render server does: the same state drawn again is finer
    result = {"first": first, "frames": frames, "complete_at": time.perf_counter() - started,
              "complete": bool(frame.get("complete", True)), "levels": sorted(set(frame["levels"])),
              "bricks_read": net["rc"].cache.stats["bricks_read"],
              "bytes_read": net["rc"].cache.stats.get("bytes_read")}
    table = getattr(net["rc"].parts[PagedSampling], "resolved", None)  # the single pass's leaf table
    if table is not None:
        result.update(table_mib=table.nbytes / 2**20, directory_level=table.level, pages=table.pages)
except vgraph.VGraphError as error:
    result = {"refused": str(error)}
result["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
result["rss_before_mib"] = before
print(json.dumps(result))
"""


def run_case(url: str, budget: float, image: int, limit: int, method: str, bias: float) -> dict:
    done = subprocess.run([sys.executable, "-c", RENDER, url, str(budget), str(image), str(limit), method, str(bias)],
                          capture_output=True, text=True)
    if done.returncode:
        return {"failed": done.stderr.strip().splitlines()[-1] if done.stderr.strip() else str(done.returncode)}
    return json.loads(done.stdout.strip().splitlines()[-1])


def table_text(result: dict) -> str:
    if "table_mib" not in result:
        return ""
    return (f"{result['table_mib']:.2f} MiB (directory at level {result['directory_level']}, "
            f"{result['pages']} pages)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[8192, 16384])
    parser.add_argument("--budget", type=float, default=256.0)
    parser.add_argument("--image", type=int, default=512)
    parser.add_argument("--load-limit", type=int, default=64)
    parser.add_argument("--methods", nargs="+", default=["passes", "single_pass"])
    parser.add_argument("--function", default="torus")
    parser.add_argument("--lod-bias", type=float, default=0.0)
    parser.add_argument("--stores", nargs="*", default=[],
                        help="real stores to measure alongside (e.g. the 1024^3 bonsai of bench_out_of_core.py)")
    args = parser.parse_args()
    print(f"{args.image}^2, ram_budget = gl_budget = {args.budget:g} MB, load limit {args.load_limit} "
          f"bricks a frame, lod_bias {args.lod_bias:g}\n")
    print("| store | method | first frame (s) | frames to complete | complete at (s) | levels | "
          "bricks read | MiB read | peak RSS (MiB) | of which frames (MiB) | leaf table |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    urls = [f"implicit:{args.function}?size={size}&brick=64" for size in args.sizes]
    for url in args.stores + urls:
        for method in args.methods:
            r = run_case(url, args.budget, args.image, args.load_limit, method, args.lod_bias)
            if "first" not in r:
                print(f"| `{url}` | {method} | {r.get('refused') or r.get('failed')} |  |  |  |  |  | "
                      f"{r.get('peak_rss_mib', 0):.0f} | | |", flush=True)
                continue
            mib = (r["bytes_read"] or 0) / 2**20
            print(f"| `{url}` | {method} | {r['first']:.2f} | {r['frames']}{'' if r['complete'] else ' (not complete)'} | "
                  f"{r['complete_at']:.2f} | {', '.join(map(str, r['levels']))} | {r['bricks_read']} | "
                  f"{mib:.0f} | {r['peak_rss_mib']:.0f} | {r['peak_rss_mib'] - r['rss_before_mib']:.0f} | "
                  f"{table_text(r)} |", flush=True)


if __name__ == "__main__":
    main()
