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
  list entries held at once.
"""

from __future__ import annotations

from vgraph import (CameraProperty, ColorProperty, FloatProperty, Inport, Outport, Processor, PropertyError,
                    VectorProperty)
from vgraph.gl.raycasting.components import palette_transfer_function
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
from vgraph.gl.raycasting.shown_volume import ShowsVolume
from vgraph.image import Image
from vgraph.sweep.render import render
from vgraph.volume import Volume


class SweepPlaneRenderer(ShowsVolume, Processor):
    """Direct volume rendering by RZSweep: a sweep plane over the grid's vertices, cells projected
    face by face, composited lazily per pixel (CPU, numba)."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image), Outport("depth", Image, on_demand=True)]
    renders_at_size = True

    camera = CameraProperty(DEFAULT_CAMERA, doc="the view; by default it fits whatever volume arrives")
    transfer_function = palette_transfer_function()
    threshold = VectorProperty(None, size=2, min=0.0, max=1.0, optional=True,
                               doc="(low, high) normalised intensities: sweep only the cells whose "
                                   "values meet this interval (on-demand classification); "
                                   "None: every cell")
    early_termination = FloatProperty(0.99, min=0.01, max=1.0,
                                      doc="a pixel stops compositing at this opacity (the RayCaster's)")
    background = ColorProperty((0.0, 0.0, 0.0, 1.0))

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.last_sweep: dict = {}
        self.view_camera = None

    def process(self, volume: Volume) -> dict:
        volume.require_samples(f"SweepPlaneRenderer '{self.id}'")
        threshold = self.threshold
        if threshold is not None and threshold[0] > threshold[1]:
            raise PropertyError(f"{self.id}.threshold", f"low {threshold[0]} is above high {threshold[1]}")
        result = render(volume, self.camera, self.transfer_function, self.render_size,
                        threshold=threshold, early_termination=self.early_termination,
                        background=tuple(self.background), owner=f"SweepPlaneRenderer '{self.id}'")
        self.view_camera = result.camera
        self.last_sweep = {"vertices_swept": result.vertices_swept,
                           "faces_projected": result.faces_projected,
                           "largest_lists": result.largest_lists}
        outputs = {"image": Image.from_numpy(self.gl, result.image)}
        if self.wants("depth"):
            outputs["depth"] = Image.from_numpy(self.gl, result.depth)
        return outputs
