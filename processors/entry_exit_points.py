"""EntryExitPoints (Inácio 2009 ch. 4.2.2, Krueger & Westermann 2003): where each pixel's view ray
enters and leaves the volume's box, as two images for the ray casters.

Conventions (vgraph.gl.raycasting.geometry has the long form):
- The box is the one spanned by the voxel centres, in world space (dims - 1) * spacing from the
  origin, so anisotropic volumes have their true shape. Its faces, grown by a margin, are
  rasterised to find the pixels the box covers; each fragment then intersects its pixel's ray with
  the box exactly (slab test in float32): interpolated attributes would inherit the rasteriser's
  sub-pixel snapping (llvmpipe: 1/256 pixel, ~1e-3 voxel errors, ragged edges).
- Outputs are RGBA32F images at the render size (the Canvas's size drives it): rgb = texture
  coordinates (voxel centre i at (i + 0.5) / dims, clamped to the box of the voxel centres),
  alpha = 1 where the ray meets the box between the near and far planes, else 0 (rgb 0).
- Exit points: back faces, then far-plane capping (pixels whose far-plane point is inside the box,
  whose back face was clipped: the ray ends on the far plane). Entry points: front faces, then
  near-plane capping (where the near plane cuts the box, e.g. a camera inside the volume, the ray
  starts on the near plane, as Camera.rays does).
- Rays are those of Camera.rays: one per pixel centre, row 0 at the top after Image.to_numpy().
- The default camera fits the data (Camera.fit_to_data: each volume that arrives is framed, keeping
  the view direction) and chooses near/far from the volume's box every frame, so a volume from a
  file shows without setting a camera first; a stored camera stays as stored. ``view_camera`` is
  the concrete camera of the last frame; frame_volume() stores a framed camera.
- Clipping (vgraph.clipping has the model): ``clip_planes`` keep the side each normal points into,
  ``crop_box`` (world units) narrows the box. Both cut each ray's interval before the ray casters
  see it, so every ray caster and compositing mode respects them and a cut shows the inside (the
  ray starts on the cut); rays with nothing left are misses (alpha 0). Without planes the shader
  is the one of before (CLIP_PLANES is not defined).
"""

from __future__ import annotations

import moderngl
import numpy as np

from vgraph import CameraProperty, FloatProperty, Inport, Outport, Processor, VGraphError
from vgraph.clipping import ClipPlanesProperty, CropBoxProperty, cropped_box, plane_uniforms
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, bind_textures, fullscreen_pass, set_uniforms
from vgraph.gl.shaders import programs
from vgraph.gl.raycasting.geometry import (BOX_EPSILON, DEFAULT_CAMERA, PROXY_MARGIN, VolumeGeometry,
                                           plane_cuts_box, plane_frame, ray_uniforms, vec, view_camera)
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.image import Image
from vgraph.volume import Volume

FACE_SHADERS = ("raycasting/entry_exit.vert.glsl", "raycasting/entry_exit.frag.glsl")
CAP_SHADER = "raycasting/plane_cap.frag.glsl"


def grown_box_of(geometry: VolumeGeometry, box_min, box_max):
    """The (cropped) box grown as VolumeGeometry.grown_box grows the whole one: rays meeting it hit.
    Without a crop box this is grown_box() itself."""
    whole_min, whole_max = geometry.box
    eps = BOX_EPSILON * (max(np.abs(whole_min).max(), np.abs(whole_max).max()) + geometry.spacing.min())
    return box_min - eps, box_max + eps


def proxy_box_of(geometry: VolumeGeometry, hit_min, hit_max):
    """The box rasterised to find the pixels to compute (VolumeGeometry.proxy_box for a cropped box)."""
    margin = PROXY_MARGIN * (float((hit_max - hit_min).max()) + geometry.spacing.min())
    return hit_min - margin, hit_max + margin


def cube_triangles() -> np.ndarray:
    """The unit cube's 12 triangles as 36 corners (0/1 per axis), float32, each triangle
    counter-clockwise seen from outside (GL's default front face is the outside)."""
    corners = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (0.0, 1.0):
            quad = []
            for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                point = np.zeros(3)
                point[axis], point[u], point[v] = side, a, b
                quad.append(point)
            normal = np.cross(quad[1] - quad[0], quad[2] - quad[0])
            if normal[axis] * (side - 0.5) < 0.0:  # points inwards: reverse the quad
                quad.reverse()
            corners += [quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]]
    return np.array(corners, dtype=np.float32)


class EntryExitPoints(Processor):
    """Entry and exit points of the view rays through the volume's box (texture coordinates)."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]
    outports = [Outport("entry", Image), Outport("exit", Image)]
    renders_at_size = True

    camera = CameraProperty(DEFAULT_CAMERA, doc="the view; link it to the ray caster's camera. By "
                                                "default it fits whatever volume arrives")
    jitter = FloatProperty(0.0, min=0.0, max=4.0,
                           doc="move entry points along their ray by a per-pixel pseudo-random "
                               "fraction of this many voxels (smallest spacing); 0 = off. About "
                               "1 / sampling_rate hides wood-grain artefacts")
    clip_planes = ClipPlanesProperty((), doc="planes that cut the volume, each {normal, point} in "
                                             "world units; the side the normal points into is kept "
                                             "(at most 8). Ctrl+drag in a canvas moves the first")
    crop_box = CropBoxProperty(doc="keep only this box (x_min, y_min, z_min, x_max, y_max, z_max), "
                                   "world units; auto = the whole volume")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._entry, self._exit = RenderTargets(1), RenderTargets(1)
        self._cube: tuple | None = None  # (ctx, vertex buffer, {program: vertex array})
        self._volume_cache: tuple | None = None  # (volume, crop box, _volume_uniforms of them)
        self.passes: list[tuple[str, dict]] = []  # (shader, defines) of each pass of the last frame

    def process(self, volume: Volume) -> dict:
        ctx = self.gl
        size = self.render_size
        self.view_camera = view_camera(self.camera, volume, size)
        (entry,), (exit_points,) = self._entry.ensure(ctx, size), self._exit.ensure(ctx, size)
        uniforms = self._uniforms(volume, size, self.view_camera)
        self.passes = []
        if uniforms is None:  # the crop box leaves nothing: every ray misses
            for image in (entry, exit_points):
                image.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
            return {"entry": entry, "exit": exit_points}
        planes = {"CLIP_PLANES": len(self.clip_planes) or None}  # None: no define, no extra code
        self._draw(ctx, exit_points, "front", planes, uniforms, "far")
        self._draw(ctx, entry, "back", {"ENTRY": True, **planes}, uniforms, "near", exit_points)
        return {"entry": entry, "exit": exit_points}

    def frame_volume(self, volume: Volume | None = None) -> None:
        """Store a camera that frames the volume's box (keeping direction and up; see
        Camera.framing) with near/far enclosing it. Uses the last volume received unless one is
        given."""
        volume = volume if volume is not None else self.inputs.get("volume")
        if volume is None:
            raise VGraphError(f"{self.id}: frame_volume() needs a volume: evaluate the network "
                              "first or pass one")
        width, height = self.render_size
        fitting = self.camera.model_copy(update={"fit_to_data": True, "near": None, "far": None})
        framed = fitting.resolved(*VolumeGeometry.of(volume).box, width / height)
        if framed != self.camera:
            self.camera = framed  # a linked ray caster's camera follows

    # --- drawing --------------------------------------------------------------------------------
    def _uniforms(self, volume: Volume, size, camera) -> dict | None:
        """Uniforms of the point computation (entry_exit_point.glsl), and under "faces" and "cap"
        those of the two ways of drawing it; None when the crop box leaves nothing."""
        cached = self._volume_uniforms(volume)
        if cached is None:
            return None
        boxes, proxy, self._hit_box, min_spacing = cached
        clipping = plane_uniforms(self.clip_planes) if self.clip_planes else {}
        return {**boxes, **clipping,
                "faces": {**proxy["faces"], "view_projection": camera.view_projection(size[0] / size[1])},
                "cap": proxy["cap"],
                "near_to_far": camera.far - camera.near,
                "jitter": float(self.jitter * min_spacing),
                "viewport_size": (float(size[0]), float(size[1])),
                **ray_uniforms(camera, size)}

    def _volume_uniforms(self, volume: Volume):
        """What depends on the volume alone, worked out once per volume (a camera drag asks
        every frame): (box uniforms, proxy uniforms of faces and cap, the hit box, min spacing), or
        None when the crop box leaves nothing of the volume's box."""
        crop = self.crop_box
        if self._volume_cache is None or self._volume_cache[0] is not volume or self._volume_cache[1] != crop:
            geometry = VolumeGeometry.of(volume)
            kept = cropped_box(*geometry.box, crop)
            if kept is None:
                self._volume_cache = (volume, crop, None)
                return None
            box_min, box_max = kept
            hit_min, hit_max = hit_box = grown_box_of(geometry, box_min, box_max)
            proxy_min, proxy_max = proxy_box_of(geometry, *hit_box)
            scale, offset = geometry.world_to_texture
            texture_min, texture_max = geometry.texture_box
            boxes = {"box_min": vec(box_min), "box_max": vec(box_max),
                     "hit_box_min": vec(hit_min), "hit_box_max": vec(hit_max),
                     "world_to_texture_scale": vec(scale), "world_to_texture_offset": vec(offset),
                     "texture_box_min": vec(texture_min), "texture_box_max": vec(texture_max),
                     "texture_to_world_scale": vec(geometry.texture_to_world[0])}
            proxies = {"faces": {"proxy_min": vec(proxy_min), "proxy_size": vec(proxy_max - proxy_min)},
                     "cap": {"proxy_min": vec(proxy_min), "proxy_max": vec(proxy_max)}}
            self._volume_cache = (volume, crop, (boxes, proxies, hit_box, float(geometry.spacing.min())))
        return self._volume_cache[2]

    def _draw(self, ctx, target: Image, culled: str, defines: dict, uniforms: dict, plane: str,
              exit_points: Image | None = None) -> None:
        """Clear ``target``, rasterise the box's faces that survive culling, then cap with the
        near or far plane."""
        textures = {"exit_points": exit_points} if exit_points is not None else {}
        uniforms = dict(uniforms)
        faces_only, cap_only = uniforms.pop("faces"), uniforms.pop("cap")
        target.framebuffer.use()
        target.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        ctx.viewport = (0, 0, *target.size)
        faces = programs.program(ctx, *FACE_SHADERS, defines, processor=self.id)
        self.passes.append((FACE_SHADERS[1], defines))
        bind_textures(faces, textures)
        set_uniforms(faces, {**uniforms, **faces_only})
        ctx.front_face, ctx.cull_face = "ccw", culled
        ctx.enable(moderngl.CULL_FACE)
        try:
            self._cube_vertex_array(ctx, faces).render(moderngl.TRIANGLES)
        finally:
            ctx.disable(moderngl.CULL_FACE)
        if not plane_cuts_box(self.view_camera, plane, *self._hit_box):
            return  # the full-screen capping pass would change no pixel
        centre, right, up = plane_frame(self.view_camera, target.size, plane)
        cap = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, CAP_SHADER, defines, processor=self.id)
        self.passes.append((CAP_SHADER, defines))
        fullscreen_pass(ctx, cap, target, textures,
                        {**uniforms, **cap_only, "cap_centre": vec(centre), "cap_right": vec(right),
                         "cap_up": vec(up)})

    def _cube_vertex_array(self, ctx, program):
        if self._cube is None or self._cube[0] is not ctx:
            self._cube = (ctx, ctx.buffer(cube_triangles().tobytes()), {})
        _, buffer, arrays = self._cube
        if program not in arrays:
            arrays[program] = ctx.vertex_array(program, [(buffer, "3f", "corner")])
        return arrays[program]
