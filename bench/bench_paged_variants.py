"""Benchmark (issue #33): the single pass's before / after comparisons of
docs/explanations/bricked-ray-casting.md, each variant rebuilt here, in one process, frames alternating.

Usage:  python bench/bench_paged_variants.py CASE [--volume FILE [--subsample K] | --implicit FUNCTION:N | --ball N]
                                             [--size 256] [--rounds 3] [--bricks 64] [--cpu] ...

Cases (each prints its settings beside its numbers):
  stride     coarse dvr frames (``--levels 1 2 3``, ``--modes dvr shaded``), everything at one level:
             the pass per brick, the single pass taking every level-0 sample (before PAGED_STRIDE) and
             the single pass on the level's own lattice (PAGED_STRIDE, vgraph.bricks.paged_strides).
  refining   frames with missing bricks under a load limit (``--modes mip iso dvr``), frozen at a
             state (``--after 0 3``: refining frames of ``--limit`` bricks drawn first; 0: level 0
             drawn from the fallback level): mip and iso marching front to back (the tree before
             their PAGED_MIP_ASKS / PAGED_WALK_ASKS walks) against walking; dvr marching (as it
             does) against walking as iso does (the variant that did not pay). ``--no-skipping``
             adds the frame with no empty-space skipping at all (an existing property).
  walk       complete level-0 frames (``--modes dvr shaded mip iso``): the frame-wide walk grids
             (PAGED_WALK, PAGED_MIP_WALK, PAGED_ISO_GRID) against the slots' block distances alone
             (PAGED_BLOCKS: what every mode did before its grid), beside the RayCaster.
  gradients  shaded coarse frames (``--levels 1 2``; shaded dvr with central and Sobel differences,
             shaded iso): PSNR against the RayCaster's level-0 image with the differences one
             level-0 voxel apart (as drawn) and one voxel of the level (as the pass per brick did
             before 4249bcc). No timings.

Timed cases: every variant draws one untimed frame, then the variants take turns frame by frame
(bench/interleave.py), each frame a new evaluation (the sampling rate nudged, as
bench_paged_bricks.py does); min / median / max ms per variant, ``--cpu``: CPU seconds of the
process (llvmpipe's threads included). Beside each variant: its largest difference from the first
variant's image (8-bit steps).

The "before" variants are not knobs of the renderer: each is made here by replacing, for its own
frames only, the one function of vgraph.bricks that chooses the newer path, as the tests force the
older path (tests/test_paged_stride.py, test_paged_iso_refining.py, test_paged_mip_refining.py), or
by an existing property (``empty_space_skipping``). Each replacement says why where it is made.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_paged_bricks import DATA, WINDOW, cpu_seconds, implicit_volume, psnr  # noqa: E402
from interleave import interleaved, spread  # noqa: E402

from vgraph.bricks import paged_grids, paged_sampling, walk_grids  # noqa: E402
from vgraph.bricks import sampling as brick_sampling  # noqa: E402
from vgraph.bricks.atlas_blocks import AtlasBlocks, kept_texture  # noqa: E402
from vgraph.bricks.brick_planning import skipping_alpha  # noqa: E402
from vgraph.bricks.cache import LoadLimit  # noqa: E402
from vgraph.bricks.kept_frame import Kept, on_context  # noqa: E402
from vgraph.bricks.paged_sampling import PagedSampling  # noqa: E402
from vgraph.bricks.ray_requests import drawn_bricks  # noqa: E402
from vgraph.camera import Camera  # noqa: E402
from vgraph.frame_context import FrameContext  # noqa: E402
from vgraph.gl.raycasting.empty_space import occupied_blocks  # noqa: E402
from vgraph.gl.raycasting.raycaster_base import Binding  # noqa: E402
from vgraph.io import read_volume  # noqa: E402
from vgraph.numerics.reference_raycast import volume_box  # noqa: E402
from vgraph.testing import ray_caster_network  # noqa: E402
from vgraph.volume import Volume  # noqa: E402

FINEST = -16.0  # lod_bias: every brick at the finest level allowed (finest_level)
MODES = {"dvr": {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 1.0},
         "shaded": {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 0.99,
                    "shading": "blinn_phong"},
         "mip": {"compositing": "mip"}, "iso": {"compositing": "iso", "iso_level": 0.3},
         "shaded_iso": {"compositing": "iso", "iso_level": 0.3, "shading": "blinn_phong"}}
SHADED = {"dvr central": {**MODES["shaded"], "derivatives": "central"},
          "dvr sobel": {**MODES["shaded"], "derivatives": "sobel"},
          # (the processor's default transfer function, as bench_paged_bricks.py's iso; the test's iso
          # takes the normalised ramp: there the smooth ball at 48 x 48 gives its MEASURED)
          "iso": {**MODES["iso"], "shading": "blinn_phong", "derivatives": "central"}}


# --- the older paths, rebuilt from here -------------------------------------------------------------
@contextlib.contextmanager
def replaced(*replacements):
    """(module, name, value): each attribute replaced while the block runs, then put back."""
    saved = [(module, name, getattr(module, name)) for module, name, _ in replacements]
    for module, name, value in replacements:
        setattr(module, name, value)
    try:
        yield
    finally:
        for module, name, value in saved:
            setattr(module, name, value)


def every_level_0_sample():
    # Before PAGED_STRIDE (e3df95c) the single pass took every level-0 sample at every level: a frame
    # compiled without the define, which paged_sampling binds only where stride_binding gives one
    # (tests/test_paged_stride.py forces it the same way).
    return replaced((paged_sampling, "stride_binding", lambda *args: None))


def no_walk_grid(only_where_missing: bool):
    # Before each mode's frame-wide grid the rays marched front to back over the slots' block
    # distances (PAGED_BLOCKS): paged_sampling falls back to them where walk_grid gives no binding.
    # only_where_missing: refining frames only (mip before b49d99f, iso before 3b9c401; the tests'
    # march_where_missing fixture), else every frame (the complete frames before their grids).
    walk_grid = paged_grids.walk_grid

    def chosen(processor, kept, frame, source, geometry, plan, atlas, missing):
        if len(missing) or not only_where_missing:
            return None
        return walk_grid(processor, kept, frame, source, geometry, plan, atlas, missing)
    return replaced((paged_grids, "walk_grid", chosen))


def dvr_walks_where_missing():
    # dvr's refining frames walked as iso's do (3b9c401's variant that did not pay, in no commit):
    # skip radii over each cell drawn from its finest resident ancestor under dvr's rule (the
    # opacity over the blocks' ranges, as the complete frame's grid), the empty blocks of missing
    # cells ASKING (PAGED_WALK with PAGED_WALK_ASKS; march.glsl compiles it for any mode). walk_grid
    # refuses dvr with missing bricks, so its body is repeated here for that case only.
    walk_grid = paged_grids.walk_grid

    def chosen(processor, kept, frame, source, geometry, plan, atlas, missing):
        if processor.compositing != "dvr" or not len(missing) or not processor.empty_space_skipping:
            return walk_grid(processor, kept, frame, source, geometry, plan, atlas, missing)
        alpha = skipping_alpha(processor, frame)

        def build() -> Binding | None:
            keys = plan.keys()
            bricks = drawn_bricks(geometry, keys, atlas.slots)
            grid, block = walk_grids.skip_radii(source, geometry, keys, atlas.slots.__getitem__, atlas.blocks.ranges,
                                                lambda low, high: occupied_blocks(low, high, alpha), bricks, missing)
            if grid is None:
                return None
            return Binding({"PAGED_WALK": True, "PAGED_WALK_ASKS": True},
                           textures={"blocks": kept_texture(atlas.gl, "walk_grid", frame.ctx, grid)},
                           uniforms=walk_grids.uniforms(geometry, block, grid))
        return kept.walk.get((kept.table.key, "dvr asking", alpha.tobytes()), build,
                             lambda binding: binding is None or on_context(atlas.gl, "walk_grid", frame.ctx))
    return replaced((paged_grids, "walk_grid", chosen))


def iso_grid_reducing_minima():
    # Before 3b9c401 settled on lows=False, iso's refining grid reduced the blocks' minima as well as
    # their maxima (skip_radii's default; iso's rule reads only the maxima): the same grid, twice
    # the build.
    original = walk_grids.skip_radii
    return replaced((walk_grids, "skip_radii", lambda *args, **kwargs: original(*args, **{**kwargs, "lows": True})))


# The functions that build the grids and flags rays skip by (timed per frame, the calling thread's CPU)
BUILDERS = ((walk_grids, "skip_radii"), (walk_grids, "asking_grid"), (walk_grids, "frame_grid"),
            (walk_grids, "iso_grid"), (paged_grids, "block_radii"))


@contextlib.contextmanager
def timing_builds(spent: list):
    """While the block runs, the BUILDERS add the thread CPU seconds they take to spent[0] (the
    outermost call only: frame_grid calls skip_radii)."""
    depth = [0]

    def timed_builder(function):
        def run(*args, **kwargs):
            depth[0] += 1
            began = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                depth[0] -= 1
                if depth[0] == 0:
                    spent[0] += time.thread_time() - began
        return run
    with replaced(*[(module, name, timed_builder(getattr(module, name))) for module, name in BUILDERS]):
        yield


# The slots each atlas stored bricks in, in order (id of its AtlasBlocks -> slots): refining frames
# forget what the grids keep for the last ones (Variant.forget_loaded).
STORED: dict = {}


@contextlib.contextmanager
def logging_stored_slots():
    record = AtlasBlocks.record

    def logged(blocks, slot, data):
        STORED.setdefault(id(blocks), []).append(slot)
        return record(blocks, slot, data)
    with replaced((AtlasBlocks, "record", logged)):
        yield


# --- frames -----------------------------------------------------------------------------------------
class Variant:
    """One network and how its frames are drawn: ``older`` (a context manager factory, or None)
    wraps each of its frames; ``context`` the frame context (a load limit); ``rebuild``: the grids
    and flags made again every frame, as a refining frame does (its atlas changes each frame), and
    what they keep for the last ``loads`` bricks stored forgotten, as if the frame had loaded them."""

    def __init__(self, network, size, clock, older=None, context=None, rebuild=False, loads=0):
        self.network, self.size, self.clock = network, size, clock
        self.older, self.context, self.rebuild, self.loads = older, context, rebuild, loads
        self.count, self.image, self.builds = 0, None, []

    @property
    def rc(self):
        return self.network["rc"]

    def forget_loaded(self) -> None:
        """Drop what the walk grids keep for the slots of the last ``self.loads`` bricks stored in
        the atlas (AtlasBlocks.of_slot): a refining frame that had loaded them would reduce their
        cells again, and a frozen state loads none, so its grids would be made from what is kept."""
        atlas = getattr(self.rc.parts[PagedSampling], "atlas", None)
        blocks = getattr(atlas, "blocks", None)
        if blocks is not None and self.loads:
            for slot in STORED.get(id(blocks), [])[-self.loads:]:
                blocks.derived.pop(slot, None)

    def frame(self, _argument=None) -> float:
        self.count += 1
        self.network.set("rc.sampling_rate", 1.0 + 1e-6 * self.count)  # a new frame: planned and drawn again
        if self.rebuild:
            kept = self.rc.parts[PagedSampling].kept
            kept.walk, kept.flags = Kept(), Kept()
            self.forget_loaded()
        spent = [0.0]
        with timing_builds(spent), self.older() if self.older else contextlib.nullcontext():
            began = self.clock()
            self.image = np.asarray(self.network.evaluate("rc.image", size=self.size, context=self.context))
            seconds = self.clock() - began
        self.builds.append(spent[0])
        return seconds

    def samples(self) -> float:
        """Samples a pixel whose ray took any, after the timed frames (untimed): the depth output's
        counter (b) of the same frame, drawn under the variant's path."""
        with self.older() if self.older else contextlib.nullcontext():
            depth = np.asarray(self.network.evaluate("rc.depth", size=self.size, context=self.context))
        taken = depth[..., 2]
        return float(taken.sum() / max(int((taken > 0).sum()), 1))

    def defines(self) -> str:
        defines = self.rc.passes[-1].defines if getattr(self.rc, "passes", None) else {}
        shown = [name for name in ("PAGED_STRIDE", "PAGED_WALK", "PAGED_WALK_ASKS", "PAGED_MIP_WALK",
                                   "PAGED_MIP_ASKS", "PAGED_ISO_GRID", "PAGED_BLOCKS") if defines.get(name)]
        return " ".join(shown) or "-"

    def drawn(self) -> str:
        frame = self.rc.last_frame or {}
        if "levels" not in frame:
            return "in core"
        return f"levels {frame.get('levels')}, {'complete' if frame.get('complete') else 'refining'}"


def timed(variants: dict, rounds: int, unit: str, samples: bool = False) -> dict:
    """Interleave ``variants`` (name -> Variant) and print each one's ms and difference from the first
    (``samples``: and the samples a pixel of its last frame)."""
    seconds, _ = interleaved({name: variant.frame for name, variant in variants.items()}, [None] * rounds, None)
    first = next(iter(variants.values()))
    base = float(np.median(seconds[next(iter(variants))]))
    for name, variant in variants.items():
        steps = float(np.abs(variant.image - first.image).max()) * 255.0
        median = float(np.median(seconds[name]))
        line = (f"  {name:>34}: {spread([v * 1e3 for v in seconds[name]], 0)} ms {unit}  ({median / base:.2f}x; "
                f"max difference {steps:.2f} steps)  [{variant.drawn()}; {variant.defines()}]")
        if samples:
            line += f"  {variant.samples():.1f} samples a pixel"
        if variant.rebuild:  # (the timed frames' builds: the warm-up frame's is the first)
            line += f"  grids built {1e3 * float(np.median(variant.builds[1:])):.1f} ms a frame"
        if variant.rc.last_frame and variant.rc.last_frame.get("requests"):
            requests = variant.rc.last_frame["requests"]
            line += f"  requests {len(requests)} cells, {sum(p for _, p in requests)} pixels"
        print(line, flush=True)
    return seconds


def bricked(volume, camera, **properties):
    return ray_caster_network(volume, camera, "BrickedRayCaster", lod_bias=FINEST, **properties)


# --- the cases --------------------------------------------------------------------------------------
def stride_case(args, volume, camera, clock, unit) -> None:
    print(f"stride: {args.bricks}^3 bricks, every brick at the level (finest_level, lod_bias {FINEST})")
    for mode in args.modes:
        for level in args.levels:
            properties = {"shading": "none", **MODES[mode], "brick_size": args.bricks, "finest_level": level}
            variants = {
                "passes": Variant(bricked(volume, camera, method="passes", **properties), args.size, clock),
                "single pass, every level-0 sample": Variant(bricked(volume, camera, method="single_pass", **properties),
                                                             args.size, clock, older=every_level_0_sample),
                "single pass, the level's lattice": Variant(bricked(volume, camera, method="single_pass", **properties),
                                                            args.size, clock)}
            print(f"{mode}, level {level}:")
            timed(variants, args.rounds, unit, args.samples)


def frozen(variant: Variant, after: int, limit: int) -> None:
    """Draw ``after`` refining frames under a limit of ``limit`` bricks, then stop the variant's
    reading: its requests are still counted and read back, but no brick is read after the frame,
    so every timed frame draws the same state (the next refining frame, again and again)."""
    for _ in range(after):
        variant.frame()
    cache = variant.rc.parts[brick_sampling.BrickSampling].cache
    cache.read_ahead = lambda *args, **kwargs: 0  # (the instance's: this variant's cache only)


def refining_case(args, volume, camera, clock, unit) -> None:
    with logging_stored_slots():
        drawn_refining(args, volume, camera, clock, unit)


def drawn_refining(args, volume, camera, clock, unit) -> None:
    limit = LoadLimit(bricks=args.limit)
    context = FrameContext(load_limit=limit)
    print(f"refining: {args.bricks}^3 bricks, level 0 planned (lod_bias {FINEST}), from an empty cache under "
          f"LoadLimit(bricks={args.limit}); each state frozen after its refining frames (no brick read after "
          f"a timed frame); " + ("the walk grid and block flags kept across the timed frames" if args.keep_grids else
                                f"the walk grid and block flags built again every frame, what they keep for the last {args.limit} "
                                "bricks stored forgotten (as a refining frame's, whose atlas changes)"))
    for mode in args.modes:
        properties = {"shading": "none", **MODES[mode], "brick_size": args.bricks, "method": "single_pass"}
        if MODES[mode]["compositing"] == "dvr":
            older = {"march (as drawn)": None, "walk (did not pay)": dvr_walks_where_missing}
        else:
            older = {"march (before)": lambda: no_walk_grid(only_where_missing=True), "walk (as drawn)": None}
        for after in args.after:
            variants = {name: Variant(bricked(volume, camera, **properties), args.size, clock, older=make,
                                      context=context, rebuild=not args.keep_grids, loads=args.limit) for name, make in older.items()}
            if args.no_skipping:
                variants["no empty-space skipping"] = Variant(
                    bricked(volume, camera, empty_space_skipping=False, **properties), args.size, clock,
                    context=context, rebuild=not args.keep_grids, loads=args.limit)
            if args.lows and MODES[mode]["compositing"] == "iso":
                variants["walk, minima reduced too (before)"] = Variant(
                    bricked(volume, camera, **properties), args.size, clock, older=iso_grid_reducing_minima,
                    context=context, rebuild=not args.keep_grids, loads=args.limit)
            for variant in variants.values():
                with variant.older() if variant.older else contextlib.nullcontext():
                    frozen(variant, after, args.limit)
            print(f"{mode}, after {after} refining frames:")
            timed(variants, args.rounds, unit, args.samples)


def walk_case(args, volume, camera, clock, unit) -> None:
    print(f"walk: {args.bricks}^3 bricks, everything resident at level 0")
    for mode in args.modes:
        properties = {"shading": "none", **MODES[mode]}
        variants = {"RayCaster": Variant(ray_caster_network(volume, camera, "RayCaster", **properties), args.size, clock),
                    "slots' distances (before)": Variant(
                        bricked(volume, camera, brick_size=args.bricks, method="single_pass", **properties),
                        args.size, clock, older=lambda: no_walk_grid(only_where_missing=False)),
                    "walk grid (as drawn)": Variant(
                        bricked(volume, camera, brick_size=args.bricks, method="single_pass", **properties),
                        args.size, clock)}
        if args.no_skipping:
            variants["no empty-space skipping"] = Variant(
                bricked(volume, camera, brick_size=args.bricks, method="single_pass", empty_space_skipping=False,
                        **properties), args.size, clock)
        print(f"{mode}:")
        timed(variants, args.rounds, unit, args.samples)


def level_step(level: int):
    # Before 4249bcc the pass per brick differenced one voxel of the brick's level apart; the single
    # pass never did (this is the variant the PSNR table weighs). Both methods take the step from
    # targets.level_voxel(geometry, 0), imported by name: here it gives the level's voxel instead
    # (every brick of these frames is of that level: finest_level with lod_bias -16).
    original = paged_sampling.level_voxel

    def voxel(geometry, _level):
        return original(geometry, level)
    return replaced((paged_sampling, "level_voxel", voxel), (brick_sampling, "level_voxel", voxel))


def gradients_case(args, volume, camera, _clock, _unit) -> None:
    print(f"gradients: {args.bricks}^3 bricks, method {args.method}, PSNR (dB) against the RayCaster's image "
          f"(level 0): differences one level-0 voxel apart / one voxel of the level")
    for name, properties in SHADED.items():
        truth = np.asarray(ray_caster_network(volume, camera, "RayCaster", **properties)
                           .evaluate("rc.image", size=args.size))
        row = []
        for level in args.levels:
            values = []
            for older in (None, lambda: level_step(level)):
                network = bricked(volume, camera, brick_size=args.bricks, finest_level=level, method=args.method,
                                  **properties)
                with older() if older else contextlib.nullcontext():
                    image = np.asarray(network.evaluate("rc.image", size=args.size))
                assert network["rc"].last_frame["levels"] == [level], network["rc"].last_frame["levels"]
                values.append(psnr(image, truth))
            row.append(f"level {level} {values[0]:.2f} / {values[1]:.2f}")
        print(f"  {name:>12}: " + ", ".join(row), flush=True)


CASES = {"stride": stride_case, "refining": refining_case, "walk": walk_case, "gradients": gradients_case}


def ball(n: int) -> Volume:
    """The tests' smooth ball with a ripple (tests/test_bricked_raycaster.py's field), n^3 float32."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n)] * 3, indexing="ij")
    values = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.15 * np.sin(9 * x) * np.cos(7 * z)
    return Volume(((values - values.min()) / (values.max() - values.min())).astype(np.float32))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=list(CASES))
    parser.add_argument("--volume", default=str(DATA / "ct_bonsai" / "bonsai.nii.gz"))
    parser.add_argument("--implicit", help="FUNCTION:N, a vgraph.implicit function sampled N^3 (uint8)")
    parser.add_argument("--subsample", type=int, default=1, help="K: every K-th voxel of --volume along each axis")
    parser.add_argument("--ball", type=int, help="N: the tests' smooth ball with a ripple, N^3 float32")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--bricks", type=int, default=64)
    parser.add_argument("--cpu", action="store_true", help="CPU seconds of the process, not wall seconds")
    parser.add_argument("--modes", nargs="+", choices=list(MODES), help="stride: dvr shaded; refining: mip iso dvr; "
                        "walk: dvr shaded mip iso (the defaults); shaded: dvr shaded, early termination 0.99")
    parser.add_argument("--levels", type=int, nargs="+", help="stride: 1 2 3, gradients: 1 2 (the defaults)")
    parser.add_argument("--after", type=int, nargs="+", default=[0, 3], help="refining: frames drawn before the state timed")
    parser.add_argument("--limit", type=int, default=8, help="refining: bricks a frame may read")
    parser.add_argument("--samples", action="store_true", help="timed cases: also the samples a pixel (the depth "
                        "output's counter, untimed, after the timed frames)")
    parser.add_argument("--keep-grids", action="store_true", help="refining: the grids and flags not built again each frame")
    parser.add_argument("--lows", action="store_true", help="refining: also iso's grid reducing the minima too")
    parser.add_argument("--no-skipping", action="store_true", help="refining, walk: also empty_space_skipping False")
    parser.add_argument("--method", choices=["single_pass", "passes"], default="single_pass", help="gradients")
    args = parser.parse_args(argv)
    args.modes = args.modes or {"stride": ["dvr", "shaded"], "refining": ["mip", "iso", "dvr"],
                                "walk": ["dvr", "shaded", "mip", "iso"], "gradients": []}[args.case]
    args.levels = args.levels or ([1, 2, 3] if args.case == "stride" else [1, 2])
    if args.implicit:
        function, count = args.implicit.split(":")
        volume, args.volume = implicit_volume(function, int(count)), f"implicit {args.implicit}"
    elif args.ball:
        volume, args.volume = ball(args.ball), f"smooth ball {args.ball}^3"
    else:
        volume = read_volume(args.volume)
        if args.subsample > 1:  # every k-th voxel, as the tests' 64^3 bonsai (tests/test_bricked_raycaster.py)
            k = args.subsample
            volume = Volume(np.ascontiguousarray(volume.data[::k, ::k, ::k]),
                            spacing=tuple(k * float(s) for s in volume.spacing), origin=volume.origin)
            args.volume += f" every {k}th voxel"
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    clock, unit = (cpu_seconds, "CPU") if args.cpu else (time.perf_counter, "wall")
    args.size = (args.size, args.size)
    print(f"{args.volume}: {volume.dims}, {args.size[0]} x {args.size[1]}"
          + ("" if args.case == "gradients" else f", {args.rounds} rounds (min / median / max ms, {unit})"))
    CASES[args.case](args, volume, camera, clock, unit)


if __name__ == "__main__":
    main()
