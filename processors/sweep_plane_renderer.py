"""SweepPlaneRenderer: RZSweep (Retondaro 2008; ZSweep: Farias, Mitchell and Silva 2000), direct
volume rendering of a regular grid by a sweep plane over its vertices, on the CPU (numba).

Conventions (docs/explanations/sweep-plane.md has the long form):
- The same camera, rays, box, transfer-function LUT and compositing over the background as the
  RayCaster and the exact CPU reference (vgraph.numerics.reference_raycast), so the images compare
  pixel for pixel. The integration differs: per grid cell a pixel's ray crosses, the colour and
  extinction averaged between the cell's entry and exit faces (Shirley-Tuchman), not samples every
  min(spacing) / sampling_rate. No shading (the thesis's renderer has none).
- ``threshold`` (low, high) in normalised intensity, default off: only the cells whose values meet
  the interval are swept (on-demand classification); the others add nothing, which is the same
  image wherever the TF is zero outside the interval.
- Outputs: ``image`` RGBA over ``background``; ``depth`` (on demand) RGBA with r = window depth of
  the front of the first cell segment with opacity (1 where none), g = its distance in world units
  from the ray's start on the near plane, b = the number of segments composited, a = 1 where there
  is a depth (the RayCaster's layout).
- The camera is the RayCaster's (link them to compare); the whole box must lie beyond its near
  plane (a camera inside the volume is refused by name). NaN or infinite voxels are refused.
- ``last_sweep`` holds the counts of the last frame: vertices swept, faces projected, the most
  list entries held at once; for a store also the leaves swept, the bytes read and the most bytes
  the brick cache held.
- A BrickedVolume (a store) is swept out of core, leaf by leaf (the bricks of ``leaf_level``)
  through a brick cache within the volume's memory budget, front to back; leaves the threshold
  empties are never read (vgraph.sweep.leaves). The cluster's leaves split gives a run of leaves
  as the frame context's ``leaf`` (vgraph.distributed.leaves): the processor then sweeps only those
  into a partial, or finishes the picture from the composited partials.
"""

from __future__ import annotations

from vgraph import (CameraProperty, ColorProperty, FloatProperty, Inport, IntProperty, Outport, Processor,
                    PropertyError, VectorProperty)
from vgraph.bricks.cache import BrickCache
from vgraph.bricks.selection import FramePlan
from vgraph.errors import VGraphError
from vgraph.frame_context import FrameContext
from vgraph.gl.raycasting.components import palette_transfer_function
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
from vgraph.gl.raycasting.shown_volume import ShowsVolume
from vgraph.image import Image
from vgraph.sweep import leaves
from vgraph.sweep.grid import check_volume
from vgraph.sweep.render import begin, finish, render
from vgraph.volume import Volume


class SweepPlaneRenderer(ShowsVolume, Processor):
    """Direct volume rendering by RZSweep: a sweep plane over the grid's vertices, cells projected
    face by face, composited lazily per pixel (CPU, numba)."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image), Outport("depth", Image, on_demand=True)]
    renders_at_size = True
    uses_context = ("leaf",)  # the cluster's leaves split (vgraph.distributed.leaves)

    camera = CameraProperty(DEFAULT_CAMERA, doc="the view; by default it fits whatever volume arrives")
    transfer_function = palette_transfer_function()
    threshold = VectorProperty(None, size=2, min=0.0, max=1.0, optional=True,
                               doc="(low, high) normalised intensities: sweep only the cells whose "
                                   "values meet this interval (on-demand classification); "
                                   "None: every cell")
    early_termination = FloatProperty(0.99, min=0.01, max=1.0,
                                      doc="a pixel stops compositing at this opacity (the RayCaster's)")
    background = ColorProperty((0.0, 0.0, 0.0, 1.0))
    leaf_level = IntProperty(0, min=0, max=16,
                             doc="a store's pyramid level whose bricks are the leaves swept out of core "
                                 "(0: full resolution); ignored for an in-memory volume")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.last_sweep: dict = {}
        self.view_camera = None
        self.cache = BrickCache(1024.0, 0.0)  # a store's leaves; budgets set from the volume per frame

    def process(self, volume: Volume, context: FrameContext) -> dict:
        owner = f"SweepPlaneRenderer '{self.id}'"
        volume.require_samples(owner)
        threshold = self.threshold
        if threshold is not None and threshold[0] > threshold[1]:
            raise PropertyError(f"{self.id}.threshold", f"low {threshold[0]} is above high {threshold[1]}")
        options = dict(threshold=threshold, early_termination=self.early_termination, owner=owner)
        if getattr(volume, "bricks", None) is not None:
            result, store = self._sweep_store(volume, context.leaf, options)
        elif context.leaf is not None:
            raise VGraphError(f"{owner}: the leaves split sweeps the leaves of a store (an OME-Zarr "
                              "BrickedVolume); this volume is in memory (use split='tiles')")
        else:
            result, store = render(volume, self.camera, self.transfer_function, self.render_size,
                                   background=tuple(self.background), **options), {}
        self.view_camera = result.camera
        self.last_sweep = {"vertices_swept": result.vertices_swept,
                           "faces_projected": result.faces_projected,
                           "largest_lists": result.largest_lists, **store}
        outputs = {"image": Image.from_numpy(self.gl, result.image)}
        if self.wants("depth"):
            outputs["depth"] = Image.from_numpy(self.gl, result.depth)
        return outputs

    def brick_source(self, volume: Volume):
        """The store whose bricks are the leaves (the leaves split weighs them by their voxels)."""
        return volume.bricks

    def _sweep_store(self, volume, leaf, options) -> tuple:
        """Out of core over the leaves (vgraph.sweep.leaves); under the leaves split only the
        given run of leaves into ``leaf.partial``, or the picture from ``leaf.accumulated``."""
        check_volume(volume, options["owner"])
        frame = begin(volume, self.camera, self.transfer_function, self.render_size, **options)
        if leaf is not None and leaf.accumulated is not None:
            leaves.restore(frame, leaf.accumulated)
            return finish(frame, tuple(self.background)), {}
        chosen = leaves.planned(volume, frame, self.leaf_level)
        if leaf is not None:
            whole = (0, 0, frame.width, frame.height)
            leaf.plan = FramePlan(bricks=[(one.key, whole) for one in chosen])
            if leaf.bricks is not None:  # a run of the plan; None: all of it
                wanted = {tuple(key) for key, _ in leaf.bricks}
                chosen = [one for one in chosen if one.key in wanted]
        store = leaves.sweep_leaves(frame, volume, self.cache, chosen)
        if leaf is not None:
            leaf.partial = leaves.partial(frame)
        return finish(frame, tuple(self.background)), store
