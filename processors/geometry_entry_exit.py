"""GeometryEntryExit: a ray caster's entry and exit points cut at opaque geometry, so that rays
stop where a surface is (Voreen's EEPGeometryIntegrator; Inviwo does the same in its geometry
entry/exit points). Together with a GeometryRenderer and an ImageCompositor it mixes opaque
surfaces with volume rendering with correct depth, keeping each processor its own job:

    VolumeSource -> EntryExitPoints --entry/exit--> GeometryEntryExit --entry/exit--> RayCaster
    geometry -> GeometryRenderer --depth--> GeometryEntryExit
    RayCaster.image (background transparent) over GeometryRenderer.image -> ImageCompositor

Conventions:
- ``depth`` is a GeometryRenderer's depth image (the RayCaster's depth convention: g = distance
  in world units from the pixel's ray start on the near plane, a = 1 where there is a surface).
  Per pixel: a surface before the entry point empties the ray (entry and exit alpha 0: the ray
  caster shows its background); one between entry and exit becomes the exit point (texture
  coordinates on the segment from entry to exit); a surface beyond the exit changes nothing.
- The camera must be the EntryExitPoints camera (link it; the GeometryRenderer's too, with the
  same volume connected to it), resolved against the volume's box as EntryExitPoints does, in
  the normalised frame of an extreme box (framed_view); the surface's depth stays in world units.
- The images must have one size (the render size; a Canvas drives it for all of them).
"""

from __future__ import annotations

from vgraph import CameraProperty, Inport, Outport, Processor, VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.framed_view import framed_view
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA, VolumeGeometry, ray_uniforms, vec
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image
from vgraph.volume import Volume

SHADER = "geometry/geometry_entry_exit.frag.glsl"


class GeometryEntryExit(Processor):
    """Entry/exit points that stop the rays at opaque geometry (from a GeometryRenderer's depth)."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume), Inport("entry", Image), Inport("exit", Image),
               Inport("depth", Image)]
    outports = [Outport("entry", Image), Outport("exit", Image)]

    camera = CameraProperty(DEFAULT_CAMERA, doc="link it to the EntryExitPoints camera")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = RenderTargets(2)
        self.view_camera = None

    def process(self, volume: Volume, entry: Image, exit: Image, depth: Image) -> dict:
        sizes = {"entry": entry.size, "exit": exit.size, "depth": depth.size}
        if len(set(sizes.values())) > 1:
            listed = ", ".join(f"{name} {w}x{h}" for name, (w, h) in sizes.items())
            raise VGraphError(f"{self.id}: the images must have one size, got {listed} (render them "
                              f"at one size, e.g. all for the same Canvas)")
        size = entry.size
        ctx = self.gl
        view = framed_view(self.camera, (volume,), size, self.id)
        self.view_camera, camera = view.world_camera, view.camera
        scale, offset = VolumeGeometry.of(view.volumes[0]).texture_to_world
        new_entry, new_exit = self._targets.ensure(ctx, size)
        program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, SHADER, processor=self.id)
        uniforms = {"texture_to_world_scale": vec(scale), "texture_to_world_offset": vec(offset),
                    "world_length": view.frame.scale,
                    "viewport_size": (float(size[0]), float(size[1])), **ray_uniforms(camera, size)}
        fullscreen_pass(ctx, program, self._targets, {"entry_points": entry, "exit_points": exit,
                                                        "geometry_depth": depth}, uniforms)
        return {"entry": new_entry, "exit": new_exit}

