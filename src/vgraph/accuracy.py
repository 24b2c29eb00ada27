"""Curvature accuracy against frame time: the measurement behind ``vgraph bench accuracy``.

Definitions (docs/reports/curvature-accuracy.md shows the results):
- A case is an implicit function (FunctionSelector, default parameters) x resolution x data type x
  derivative mode. It is rendered by FunctionSelector -> CubicSplineProcessor -> EntryExitPoints ->
  CurvatureRaycaster (cameras linked, the ray caster's defaults), built with the Python API; the
  spline is enabled for the tricubic modes and passes the samples through for forward, central
  and filtered. Each function has its own view (``camera_for``; the torus's is that of
  networks/curvature_torus.json).
- Hits are the pixels whose `curvature` flag is 1 (hit, curvature defined); their world positions
  come from the `position` outport. Hits nearer than max(MARGIN_VOXELS voxels, MARGIN_WORLD) to a
  face of the volume, or outside the function's REGIONS box, are left out and counted as
  ``excluded``: boundary handling is not derivative accuracy (only the saddle, which crosses the
  whole box, has such hits). Hits with flag 0.5 (curvature undefined) are counted as
  ``undefined``.
- Exact values come from ``exact_curvature(function, p)``: the curvature of the level set of f
  through the hit p. A hit that is off the surface f = 0 by d (reconstruction error) is thus compared
  with the parallel level set through it; that position error is reported separately as
  ``distance`` = |f(p)| / |grad f(p)| (world units).
- Relative error at a hit, with kappa = max(|k1|, |k2|, kappa_floor) of the exact values there:
  k1, k2, H: |k - k_exact| / kappa;  K: |K - K_exact| / kappa^2. kappa is the strongest bending of
  the surface at the point, so measures that pass through 0 (k2 and K on the torus, H on the
  saddle) are not divided by ~0; kappa_floor = 1 / (largest extent of the volume's box), a radius
  of curvature as large as the volume, keeps nearly flat points meaningful too. On the torus
  k1 = 1/r >= |k2| everywhere, so its k1 error is the plain relative error |k1 - k1_exact| / k1_exact.
- Statistics: median, 95th percentile and maximum over the hits (pixel-weighted, as the camera sees
  the surface).
- Time per frame: the camera turns by FRAME_TURN radians (alternating) and EntryExitPoints plus all
  passes of the CurvatureRaycaster run again; timed from the update call to ctx.finish() (no
  read-back); best and median over ``repeat`` frames, after one untimed frame (compilation, upload).
- The CPU reference (mode "cpu"): numerics.bspline.evaluate (float64) on the same float32
  coefficients and numerics.curvature.kindlmann at the hits of the GPU `tricubic` render; its
  time is that evaluation alone on the CPU (no hit search), best of ``repeat``.
"""

from __future__ import annotations

import itertools
import math
import statistics
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from tqdm import tqdm

from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.gl_context import get_context
from vgraph.implicit import DATA_TYPES, FUNCTIONS, RESOLUTION_RANGE, exact_curvature
from vgraph.network import Network
from vgraph.numerics import bspline
from vgraph.numerics.curvature import kindlmann

GPU_MODES = ("forward", "central", "filtered", "tricubic", "tricubic_fast")
MODES = GPU_MODES + ("cpu",)
MEASURES = ("k1", "k2", "K", "H")
DEFAULTS = {"functions": ("sphere", "torus", "ellipsoid", "saddle"),
            "resolutions": (32, 64, 128, 256), "derivatives": MODES,
            "data_types": ("uint8", "uint16", "float32"), "repeat": 7, "size": (256, 256)}
QUICK = {"functions": ("sphere", "torus"), "resolutions": (32, 64),
         "derivatives": ("forward", "central", "tricubic", "cpu"),
         "data_types": ("uint8", "float32"), "repeat": 2, "size": (128, 128)}
MARGIN_VOXELS = 2.0  # the widest stencil (filtered: central differences of neighbours) reaches 2
MARGIN_WORLD = 0.15  # the same region at every resolution >= 32 (2.3 voxels at 32^3)
# Where a surface runs into the volume's faces, the part evaluated (world box). The saddle crosses
# the x and y faces, where the spline's mirror boundary (an even extension of a field whose x and y
# derivatives are not 0 there) bends the reconstruction; 0.5 world units (7.8 voxels at 32^3) away
# that disturbance has decayed by 0.268^7.8 < 1e-4 (the prefilter's pole).
REGIONS = {"saddle": ((-0.5, -0.5, -1.0), (0.5, 0.5, 1.0))}
FRAME_TURN = 1e-3  # radians the camera turns between timed frames
VIEW_DIRECTION = (-0.3, -0.5, -1.0)  # networks/curvature_torus.json
# World boxes the cameras frame: the surface's extent (the torus's is curvature_torus.json's).
VIEW_BOXES = {"sphere": ((-0.7,) * 3, (0.7,) * 3),
              "torus": ((-0.8, -0.8, -0.25), (0.8, 0.8, 0.25)),
              "ellipsoid": ((-0.8, -0.6, -0.4), (0.8, 0.6, 0.4)),
              "saddle": ((-0.5, -0.5, -0.2), (0.5, 0.5, 0.2))}


class Stats(NamedTuple):
    median: float
    p95: float
    max: float


@dataclass(frozen=True)
class Case:
    function: str
    resolution: int
    data_type: str
    derivatives: str

    @property
    def label(self) -> str:
        return f"{self.function} {self.resolution}^3 {self.data_type} {self.derivatives}"


@dataclass
class Result:
    """Errors and frame time of one case (module docstring)."""

    case: Case
    hits: int
    undefined: int
    excluded: int
    errors: dict[str, Stats]  # measure -> relative error statistics
    distance: Stats  # world units off the exact surface f = 0
    ms_best: float  # wall-clock milliseconds per frame, best of `repeat`
    ms_median: float  # ... and their median
    cpu_ms: float  # process CPU milliseconds per frame (all threads, llvmpipe's too), median
    size: tuple[int, int] = (0, 0)

    def row(self) -> dict:
        """One flat CSV row."""
        row = {"function": self.case.function, "resolution": self.case.resolution,
               "data_type": self.case.data_type, "derivatives": self.case.derivatives,
               "width": self.size[0], "height": self.size[1], "hits": self.hits,
               "undefined": self.undefined, "excluded": self.excluded}
        for name in MEASURES:
            for stat, value in zip(Stats._fields, self.errors[name]):
                row[f"{name}_{stat}"] = value
        row.update(distance_median=self.distance.median, distance_max=self.distance.max,
                   ms_best=self.ms_best, ms_median=self.ms_median, cpu_ms=self.cpu_ms)
        return row


# --- definitions ---------------------------------------------------------------------------------
def kappa_floor(volume) -> float:
    """1 / largest extent of the volume's world box: a radius of curvature as large as the volume."""
    extent = (np.asarray(volume.dims) - 1) * np.asarray(volume.spacing, dtype=np.float64)
    return 1.0 / float(extent.max())


def relative_errors(measured: dict, exact, floor: float) -> dict[str, np.ndarray]:
    """Per-hit relative errors of k1, k2, K, H (module docstring). ``measured`` maps "k1", "k2",
    "K", "H" to arrays; ``exact`` is a numerics.curvature.Curvature at the same points."""
    kappa = np.maximum(np.maximum(np.abs(exact.k1), np.abs(exact.k2)), floor)
    truth = {"k1": exact.k1, "k2": exact.k2, "K": exact.gaussian, "H": exact.mean}
    return {name: np.abs(np.asarray(measured[name], np.float64) - truth[name])
            / (kappa * kappa if name == "K" else kappa) for name in MEASURES}


def statistics_of(values: np.ndarray) -> Stats:
    if values.size == 0:
        return Stats(math.nan, math.nan, math.nan)
    return Stats(float(np.median(values)), float(np.percentile(values, 95)), float(values.max()))


def measured_curvature(curvature: np.ndarray) -> dict[str, np.ndarray]:
    """k1, k2, K, H from the `curvature` outport's channels (H = (k1 + k2) / 2, as the shader)."""
    k1, k2 = curvature[..., 0].astype(np.float64), curvature[..., 1].astype(np.float64)
    return {"k1": k1, "k2": k2, "K": curvature[..., 2].astype(np.float64), "H": 0.5 * (k1 + k2)}


def evaluated(function: str, volume, points: np.ndarray) -> np.ndarray:
    """True for world points at least the margin away from every face of the volume's box and
    inside the function's REGIONS box, if it has one."""
    spacing = np.asarray(volume.spacing, dtype=np.float64)
    lo = np.asarray(volume.origin, dtype=np.float64)
    hi = lo + (np.asarray(volume.dims) - 1) * spacing
    margin = np.maximum(MARGIN_VOXELS * spacing, MARGIN_WORLD)
    lo, hi = lo + margin, hi - margin
    if function in REGIONS:
        lo, hi = np.maximum(lo, REGIONS[function][0]), np.minimum(hi, REGIONS[function][1])
    return np.all((points >= lo) & (points <= hi), axis=1)


def evaluate_hits(function, volume, measured: dict, points: np.ndarray):
    """(errors per measure, distance statistics) of measured curvature at world points."""
    errors = relative_errors(measured, exact_curvature(function, points), kappa_floor(volume))
    value, gradient, _ = function.jet(points)
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = np.abs(value) / np.linalg.norm(gradient, axis=1)
    return ({name: statistics_of(e) for name, e in errors.items()},
            statistics_of(distance[np.isfinite(distance)]))


# --- the network -----------------------------------------------------------------------------------
def camera_for(function: str) -> Camera:
    """The view of ``function``'s surface (its whole box for functions without a VIEW_BOXES entry)."""
    box = VIEW_BOXES.get(function) or FUNCTIONS[function].box
    return Camera.looking_at_box(*box, direction=VIEW_DIRECTION)


def build_network(function: str, resolution: int, data_type: str, camera: Camera, **properties):
    """FunctionSelector 'source' -> CubicSplineProcessor 'spline' -> EntryExitPoints 'eep' ->
    CurvatureRaycaster 'cr' (cameras linked)."""
    net = Network()
    net.add("FunctionSelector", id="source", function=function, resolution=resolution,
            data_type=data_type)
    net.add("CubicSplineProcessor", id="spline")
    net.add("EntryExitPoints", id="eep", camera=camera)
    net.add("CurvatureRaycaster", id="cr", **properties)
    net.link("eep.camera", "cr.camera", bidirectional=True)
    for source, target in (("source.volume", "spline.volume"), ("spline.volume", "eep.volume"),
                           ("spline.volume", "cr.volume"), ("eep.entry", "cr.entry"),
                           ("eep.exit", "cr.exit")):
        net.connect(source, target)
    return net


def use_mode(net, mode: str) -> None:
    """Switch the network to a GPU derivative mode (the spline only for the tricubic modes)."""
    net.set("spline.enabled", mode.startswith("tricubic"))
    net.set("cr.derivatives", mode)


def time_frames(net, camera: Camera, size, repeat: int) -> tuple[float, float, float]:
    """(best, median) wall-clock and median process-CPU milliseconds per frame (module
    docstring); leaves the camera at ``camera``."""
    ctx = get_context()
    times, cpu_times = [], []
    for k in range(max(1, repeat)):
        net.set("eep.camera", camera.rotate(FRAME_TURN if k % 2 == 0 else -FRAME_TURN, 0.0))
        start, cpu_start = time.perf_counter(), time.process_time()
        net.update("cr.curvature", size=size)
        ctx.finish()
        times.append(1e3 * (time.perf_counter() - start))
        cpu_times.append(1e3 * (time.process_time() - cpu_start))
    net.set("eep.camera", camera)
    return min(times), statistics.median(times), statistics.median(cpu_times)


def render_hits(net, camera: Camera, size):
    """(curvature, position) images of the current mode at ``camera``, float32 (H, W, 4)."""
    net.set("eep.camera", camera)
    return net.evaluate("cr.curvature", size=size), net.evaluate("cr.position", size=size)


def measure_gpu(net, case: Case, camera: Camera, size, repeat: int):
    """Result of a GPU mode, and the world positions of its hits (for the CPU reference)."""
    use_mode(net, case.derivatives)
    curvature, position = render_hits(net, camera, size)  # also the untimed first frame
    volume = net.output("source.volume")
    flag = curvature[..., 3]
    hit = flag == 1.0
    points = position[hit, :3].astype(np.float64)
    kept = evaluated(case.function, volume, points)
    measured = {name: v[hit][kept] for name, v in measured_curvature(curvature).items()}
    errors, distance = evaluate_hits(volume.function, volume, measured, points[kept])
    times = time_frames(net, camera, size, repeat)
    result = Result(case, int(kept.sum()), int(np.sum(flag == 0.5)), int((~kept).sum()), errors,
                    distance, *times, tuple(size))
    return result, points[kept]


def measure_cpu(net, case: Case, points: np.ndarray, size, repeat: int) -> Result:
    """The CPU reference at the hits of the GPU tricubic render (the spline must be enabled)."""
    coefficients = net.output("spline.volume")
    volume = net.output("source.volume")
    times, cpu_times = [], []
    for _ in range(max(1, repeat)):
        start, cpu_start = time.perf_counter(), time.process_time()
        spline = bspline.evaluate(coefficients.data, coefficients.world_to_voxel(points),
                          coefficients.spacing, derivatives=2)
        curvature = kindlmann(spline.gradient, spline.hessian)
        times.append(1e3 * (time.perf_counter() - start))
        cpu_times.append(1e3 * (time.process_time() - cpu_start))
    defined = curvature.defined
    measured = {"k1": curvature.k1, "k2": curvature.k2, "K": curvature.gaussian, "H": curvature.mean}
    errors, distance = evaluate_hits(volume.function, volume,
                                     {k: v[defined] for k, v in measured.items()}, points[defined])
    return Result(case, int(defined.sum()), int((~defined).sum()), 0, errors, distance,
                  min(times), statistics.median(times), statistics.median(cpu_times), tuple(size))


# --- the matrix --------------------------------------------------------------------------------------
def check_matrix(functions, resolutions, data_types, derivatives) -> None:
    """Refuse unknown names and out-of-range resolutions before minutes of work."""
    for option, values, known in (("--functions", functions, FUNCTIONS),
                                  ("--data-types", data_types, DATA_TYPES),
                                  ("--derivatives", derivatives, MODES)):
        bad = [v for v in values if v not in known]
        if bad or not values:
            raise VGraphError(f"{option}: unknown {', '.join(map(repr, bad)) or '(none given)'}; "
                              f"choose from {', '.join(known)}")
    lo, hi = RESOLUTION_RANGE
    bad = [r for r in resolutions if not lo <= r <= hi]
    if bad or not resolutions:
        raise VGraphError(f"--resolutions: {bad or '(none given)'} outside [{lo}, {hi}]")


def cases(functions, resolutions, data_types, derivatives) -> list[Case]:
    """Every case, grouped by volume; difference modes first, so the spline is computed once."""
    order = [m for m in MODES if m in derivatives]
    return [Case(f, r, t, m) for f, r, t in itertools.product(functions, resolutions, data_types)
            for m in order]


def run(functions=DEFAULTS["functions"], resolutions=DEFAULTS["resolutions"],
        data_types=DEFAULTS["data_types"], derivatives=DEFAULTS["derivatives"],
        size=DEFAULTS["size"], repeat=DEFAULTS["repeat"], progress: bool = True) -> list[Result]:
    """Measure every case of the matrix; the results come in ``cases()`` order."""
    check_matrix(functions, resolutions, data_types, derivatives)
    todo = cases(functions, resolutions, data_types, derivatives)
    results: list[Result] = []
    with tqdm(total=len(todo), desc="accuracy", unit="case", disable=not progress) as bar:
        for (function, resolution, data_type), group in itertools.groupby(
                todo, key=lambda c: (c.function, c.resolution, c.data_type)):
            group = list(group)
            camera = camera_for(function)
            net = build_network(function, resolution, data_type, camera)
            wanted = {c.derivatives: c for c in group}
            modes = [m for m in GPU_MODES if m in wanted or (m == "tricubic" and "cpu" in wanted)]
            for mode in modes:
                bar.set_postfix_str(f"{function} {resolution}^3 {data_type} {mode}")
                case = wanted.get(mode, Case(function, resolution, data_type, mode))
                result, points = measure_gpu(net, case, camera, size, repeat)
                if mode in wanted:
                    results.append(result)
                    bar.update(1)
                if mode == "tricubic" and "cpu" in wanted:
                    results.append(measure_cpu(net, wanted["cpu"], points, size, repeat))
                    bar.update(1)
    return sorted(results, key=lambda r: todo.index(r.case))
