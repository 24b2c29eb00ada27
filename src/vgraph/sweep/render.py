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
from vgraph.sweep.grid import swept_grid
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
    width, height = positive_pair(size, f"{owner}: size", "(width, height)")
    camera = camera.resolved(*volume_box(volume), width / height)  # as the reference and GL do
    grid = swept_grid(volume, camera, threshold, owner)
    near, _ = camera.planes()
    depths = grid.depths[grid.kept_vertices]
    if depths.size and depths.min() < near <= depths.max():
        raise VGraphError(f"{owner}: the camera's near plane cuts the volume's box; the sweep needs "
                          "the whole box in front of it (move the camera out of the volume)")
    if depths.size and depths.max() < near:  # all behind the near plane: nothing to sweep
        grid = swept_grid(volume, camera, (np.inf, np.inf), owner)  # keeps no cell
    origins, directions = (a.reshape(-1, 3) for a in camera.rays(width, height))
    forward = camera.basis()[2]
    view_projection = np.ascontiguousarray(camera.view_projection(width / height))
    lut = transfer_function.for_volume(volume).lut().astype(np.float64)
    pixels = width * height
    pixel_x, pixel_y = _pixel_coordinates(grid.positions.reshape(-1, 3), view_projection, width, height)
    arrays = dict(values=grid.values.ravel(), positions=grid.positions.reshape(-1, 3),
                  pixel_x=pixel_x, pixel_y=pixel_y,
                  depths=grid.depths.ravel(), kept_vertices=grid.kept_vertices.ravel(),
                  kept_cells=grid.kept_cells.ravel(), dims=np.array(volume.dims, dtype=np.int64),
                  origins=np.ascontiguousarray(origins), directions=np.ascontiguousarray(directions),
                  cosines=directions @ forward, t_far=camera.far_distance(directions),
                  near=float(near), width=width, height=height,
                  lut=lut, tau_scale=1.0 / min(volume.spacing), threshold_on=threshold is not None,
                  inverse=grid.inverse, early_termination=float(early_termination))
    capacity = FIRST_POOL * pixels + 1024
    while True:
        colour, log_t = np.zeros((pixels, 3)), np.zeros(pixels)
        first_t, segments = np.full(pixels, np.nan), np.zeros(pixels, dtype=np.int64)
        swept, faces, peak = kernel.sweep(**arrays, capacity=capacity, colour=colour,
                                          log_transparency=log_t, first_t=first_t, segments=segments)
        if swept != kernel.OVERFLOW:
            break
        capacity *= 2
    image = _over_background(colour, log_t, np.asarray(background, dtype=np.float64))
    depth = _depth_image(first_t, segments, origins, directions, view_projection)
    return SweepResult(image.reshape(height, width, 4), depth.reshape(height, width, 4),
                       int(swept), int(faces), int(peak), camera)


def _pixel_coordinates(points, view_projection, width, height) -> tuple[np.ndarray, np.ndarray]:
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
