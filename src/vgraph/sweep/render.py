"""RZSweep rendering of an in-memory Volume into the ray casters' image conventions
(docs/explanations/sweep-plane.md).

The camera, rays, box, transfer-function LUT, near/far clipping and compositing over the
background are the exact CPU reference's (vgraph.numerics.reference_raycast); what differs is the
integration along each ray: per grid cell crossed, the Shirley-Tuchman average of the colour and
extinction at the cell's entry and exit faces (vgraph.sweep.kernel) instead of trilinear samples
every min(spacing) / sampling_rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.camera import Camera
from vgraph.errors import VGraphError, positive_pair
from vgraph.numerics.reference_boxes import volume_box
from vgraph.sweep import kernel
from vgraph.sweep.grid import SweptGrid, swept_grid
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

FIRST_POOL = 4  # list entries per pixel the first try holds; doubled while too few


@dataclass(frozen=True)
class SweepResult:
    image: np.ndarray  # float32 (H, W, 4), row 0 at the top, over the background
    depth: np.ndarray  # float32 (H, W, 4): window depth, distance, segments, has depth
    vertices_swept: int
    faces_projected: int
    largest_lists: int  # most list entries held at once (all pixels together)
    camera: Camera  # the resolved camera


def render(volume: Volume, camera: Camera, transfer_function: TransferFunction, size, *,
           threshold=None, early_termination: float = 0.99, background=(0.0, 0.0, 0.0, 1.0),
           owner: str = "SweepPlaneRenderer") -> SweepResult:
    """Render ``volume`` by RZSweep. ``threshold``: (low, high) normalised intensities or None
    (vgraph.sweep.grid); ``owner`` names the caller in errors."""
    frame = begin(volume, camera, transfer_function, size, threshold=threshold,
                  early_termination=early_termination, owner=owner)
    grid = swept_grid(volume, frame.camera, threshold, owner)
    sweep_into(frame, grid, volume.dims)
    return finish(frame, background)


@dataclass
class Frame:
    """What every grid swept into one picture shares (the camera's rays, the LUT, the optical
    constants) and the per-pixel state the sweeps accumulate, front to back: premultiplied
    ``colour``, ``log_transparency``, ``first_t`` (NaN: no opacity yet) and ``segments``. Grids
    swept one after another in visibility order (the leaves of a store, vgraph.sweep.leaves)
    continue the same per-pixel compositing, early termination included."""

    camera: Camera
    width: int
    height: int
    rays: dict  # origins, directions, cosines, t_far, near, width, height: the kernel's arguments
    view_projection: np.ndarray
    lut: np.ndarray
    tau_scale: float
    threshold: tuple | None
    early_termination: float
    owner: str
    colour: np.ndarray
    log_transparency: np.ndarray
    first_t: np.ndarray
    segments: np.ndarray
    counts: list  # vertices swept, faces projected, largest list use (the most of any grid)


def begin(volume: Volume, camera: Camera, transfer_function: TransferFunction, size, *,
          threshold=None, early_termination: float = 0.99, owner: str = "SweepPlaneRenderer") -> Frame:
    """An empty picture of ``volume`` (its box, value range and spacing; no voxel is read)."""
    width, height = positive_pair(size, f"{owner}: size", "(width, height)")
    camera = camera.resolved(*volume_box(volume), width / height)  # as the reference and GL do
    near, _ = camera.planes()
    origins, directions = (np.ascontiguousarray(a.reshape(-1, 3)) for a in camera.rays(width, height))
    forward = camera.basis()[2]
    rays = dict(origins=origins, directions=directions, cosines=directions @ forward,
                t_far=camera.far_distance(directions), near=float(near), width=width, height=height)
    pixels = width * height
    return Frame(camera, width, height, rays, np.ascontiguousarray(camera.view_projection(width / height)),
                 transfer_function.for_volume(volume).lut().astype(np.float64), 1.0 / min(volume.spacing),
                 None if threshold is None else tuple(threshold), float(early_termination), owner,
                 np.zeros((pixels, 3)), np.zeros(pixels), np.full(pixels, np.nan),
                 np.zeros(pixels, dtype=np.int64), [0, 0, 0])


def sweep_into(frame: Frame, grid: SweptGrid, dims) -> None:
    """Sweep ``grid`` (of a volume with ``dims`` (x, y, z)) into ``frame``'s pixels, behind what
    is there already."""
    near = frame.rays["near"]
    depths = grid.depths[grid.kept_vertices]
    if depths.size and depths.min() < near <= depths.max():
        raise VGraphError(f"{frame.owner}: the camera's near plane cuts the volume's box; the sweep needs "
                          "the whole box in front of it (move the camera out of the volume)")
    if not depths.size or depths.max() < near:  # nothing, or all behind the near plane
        return
    pixel_x, pixel_y = pixel_coordinates(grid.positions.reshape(-1, 3), frame.view_projection,
                                          frame.width, frame.height)
    arrays = dict(values=grid.values.ravel(), positions=grid.positions.reshape(-1, 3),
                  pixel_x=pixel_x, pixel_y=pixel_y,
                  depths=grid.depths.ravel(), kept_vertices=grid.kept_vertices.ravel(),
                  kept_cells=grid.kept_cells.ravel(), dims=np.array(dims, dtype=np.int64), **frame.rays,
                  lut=frame.lut, tau_scale=frame.tau_scale, threshold_on=frame.threshold is not None,
                  inverse=grid.inverse, early_termination=frame.early_termination)
    capacity = FIRST_POOL * frame.width * frame.height + 1024
    while True:
        # a sweep that runs out of list entries has composited part of its grid: retry on copies
        state = [a.copy() for a in (frame.colour, frame.log_transparency, frame.first_t, frame.segments)]
        swept, faces, peak = kernel.sweep(**arrays, capacity=capacity, colour=state[0],
                                          log_transparency=state[1], first_t=state[2], segments=state[3])
        if swept != kernel.OVERFLOW:
            break
        capacity *= 2
    frame.colour, frame.log_transparency, frame.first_t, frame.segments = state
    frame.counts[0] += int(swept)
    frame.counts[1] += int(faces)
    frame.counts[2] = max(frame.counts[2], int(peak))


def finish(frame: Frame, background=(0.0, 0.0, 0.0, 1.0)) -> SweepResult:
    """The picture over ``background`` and its depth image."""
    image = _over_background(frame.colour, frame.log_transparency, np.asarray(background, dtype=np.float64))
    depth = _depth_image(frame.first_t, frame.segments, frame.rays["origins"], frame.rays["directions"],
                         frame.view_projection)
    shape = (frame.height, frame.width, 4)
    return SweepResult(image.reshape(shape), depth.reshape(shape), *frame.counts, frame.camera)


def pixel_coordinates(points, view_projection, width, height) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of world points in the image, pixel centres at whole numbers, row 0 at the top (the
    rays of Camera.rays go through the centres)."""
    clip = points @ view_projection[:, :3].T + view_projection[:, 3]
    x = (clip[:, 0] / clip[:, 3] + 1.0) * 0.5 * width - 0.5
    y = (1.0 - clip[:, 1] / clip[:, 3]) * 0.5 * height - 0.5
    return np.ascontiguousarray(x), np.ascontiguousarray(y)


def _over_background(colour, log_transparency, background) -> np.ndarray:
    coverage = -np.expm1(log_transparency)[:, None]
    return np.concatenate([colour + (1.0 - coverage) * background[:3],
                           coverage + (1.0 - coverage) * background[3]], axis=1).astype(np.float32)


def _depth_image(first_t, segments, origins, directions, view_projection) -> np.ndarray:
    """r = window depth of the front of the first segment with opacity (1 where none), g = its
    distance from the ray's start, b = segments composited, a = 1 where there is a depth."""
    depth = np.zeros((len(first_t), 4))
    depth[:, 0] = 1.0
    depth[:, 2] = segments
    hit = ~np.isnan(first_t)
    points = origins[hit] + first_t[hit, None] * directions[hit]
    clip = np.concatenate([points, np.ones((len(points), 1))], axis=1) @ view_projection.T
    depth[hit, 0] = (clip[:, 2] / clip[:, 3] + 1.0) * 0.5
    depth[hit, 1] = first_t[hit]
    depth[hit, 3] = 1.0
    return depth.astype(np.float32)
