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
- One pass writes both images: the box's back faces, then far-plane capping (pixels whose far-plane
  point is inside the box, whose back face was clipped: the ray ends on the far plane). Every ray
  that meets the box leaves it through a back face, also where the near plane cuts the box (a
  camera inside the volume: the ray starts on the near plane, as Camera.rays does), so the front
  faces and a near-plane cap are not drawn: the entry point is computed in the same fragment.
- Rays are those of Camera.rays: one per pixel centre, row 0 at the top after Image.to_numpy().
- Both images carry ``covered`` (vgraph.image): the bounding rectangle of the drawn box's
  footprint, outside of which every ray misses; ray casters draw only inside it (on llvmpipe a
  pixel whose ray misses still costs the whole shader's straight-line code).
- Several volumes (the channels of a MultiVolumeRayCaster): the optional inports ``volume2`` ..
  ``volume4`` make the box the UNION of the connected volumes' boxes (rays_box), so every channel is
  drawn whole. The rgb stay texture coordinates of ``volume`` (the first), now clamped to the union
  box: outside the first volume's box they leave [0.5 / dims, 1 - 0.5 / dims], even [0, 1]. Only
  ray casters that sample every connected volume at such points (the MultiVolumeRayCaster) should
  take these images: a single-volume ray caster would smear the first volume's edge voxels there.
  With nothing extra connected everything is as before, bit for bit. The camera is resolved on the
  same union box (framed_view); the MultiVolumeRayCaster resolves its own on the union of its
  channels, so connect the same volumes to both.
- The default camera fits the data (Camera.fit_to_data: each volume that arrives is framed, keeping
  the view direction) and chooses near/far from the volume's box every frame, so a volume from a
  file shows without setting a camera first; a stored camera stays as stored. ``view_camera`` is
  the concrete camera of the last frame; frame_volume() stores a framed camera.
- An extreme box (1e14 or 1e-12 across, or far from the origin; vgraph.box_frame) is drawn in its
  normalised frame (vgraph.gl.raycasting.framed_view): the boxes, rays, clip planes, crop box and
  jitter are moved and scaled there, the outputs (texture coordinates) are the same, and
  ``view_camera`` stays in world units (None where a Camera cannot hold it). Ordinary boxes are
  drawn as before, bit for bit.
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
from vgraph.errors import PropertyError
from vgraph.clipping import (MAX_CLIP_PLANES, ClipPlanesProperty, CropBoxProperty, crop_planes, cropped_box,
                             plane_uniforms)
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass, set_uniforms
from vgraph.gl.shaders import programs
from vgraph.gl.raycasting.framed_view import framed_view, rays_box
from vgraph.gl.raycasting.geometry import (BOX_EPSILON, DEFAULT_CAMERA, PROXY_MARGIN, VolumeGeometry,
                                           box_corners, cube_triangles, footprint, picture_of,
                                           pixel_rays, plane_cuts_box, plane_frame, vec)
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.image import Image
from vgraph.volume import Volume

FACE_SHADERS = ("raycasting/entry_exit.vert.glsl", "raycasting/entry_exit.frag.glsl")
CAP_SHADER = "raycasting/plane_cap.frag.glsl"


EXTRA_VOLUMES = ("volume2", "volume3", "volume4")  # optional inports that widen the box


def grown_box_of(whole: tuple, min_spacing: float, box_min, box_max):
    """The (cropped) box grown as VolumeGeometry.grown_box grows the ``whole`` one (the growth
    depends on the whole box, not the crop): rays meeting it hit. Without a crop box and with one
    volume this is that volume's grown_box() itself."""
    whole_min, whole_max = whole
    eps = BOX_EPSILON * (max(np.abs(whole_min).max(), np.abs(whole_max).max()) + min_spacing)
    return box_min - eps, box_max + eps


def proxy_box_of(min_spacing: float, hit_min, hit_max):
    """The box rasterised to find the pixels to compute (VolumeGeometry.proxy_box for a cropped box)."""
    margin = PROXY_MARGIN * (float((hit_max - hit_min).max()) + min_spacing)
    return hit_min - margin, hit_max + margin


class EntryExitPoints(Processor):
    """Entry and exit points of the view rays through the volume's box (texture coordinates), or
    through the union of several volumes' boxes."""

    category = "Volume rendering"
    inports = ([Inport("volume", Volume, "rgb are its texture coordinates")]
               + [Inport(port, Volume, "widens the box to the union (for a MultiVolumeRayCaster)",
                         optional=True) for port in EXTRA_VOLUMES])
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
        self._targets = RenderTargets(2)  # entry, exit
        self._cube: tuple | None = None  # (ctx, vertex buffer, {program: vertex array})
        self._volume_cache: tuple | None = None  # (volumes, crop box, _volume_uniforms of them)
        self._view = None  # the FramedView of the last frame (its camera and volumes in its frame)
        self.passes: list[tuple[str, dict]] = []  # (shader, defines) of each pass of the last frame

    def process(self, volume: Volume, volume2: Volume | None = None, volume3: Volume | None = None,
                volume4: Volume | None = None) -> dict:
        ctx = self.gl
        size = self.render_size
        volumes = tuple(v for v in (volume, volume2, volume3, volume4) if v is not None)
        view = self._view = framed_view(self.camera, volumes, size, self.id)
        self.view_camera = view.world_camera
        entry, exit_points = self._targets.ensure(ctx, size)
        uniforms = self._uniforms(view, size)
        self.passes = []
        self._targets.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        covered = (0, 0, 0, 0)  # the crop box leaves nothing: every ray misses
        if uniforms is not None:
            self._draw(ctx, {"CLIP_PLANES": len(self._planes(view.frame)) or None}, uniforms)  # None: no define
            covered = footprint(uniforms["faces"]["view_projection"], self._proxy_corners, size)
        entry.covered = exit_points.covered = covered  # only there do ray casters draw (Image)
        return {"entry": entry, "exit": exit_points}

    def frame_volume(self, volume: Volume | None = None) -> None:
        """Store a camera that frames the volume's box (keeping direction and up; see
        Camera.framing) with near/far enclosing it. Uses the last volumes received (their union
        box) unless one is given."""
        if volume is not None:
            volumes = (volume,)
        else:
            volumes = tuple(v for v in (self.inputs.get(p) for p in ("volume", *EXTRA_VOLUMES)) if v is not None)
        if not volumes:
            raise VGraphError(f"{self.id}: frame_volume() needs a volume: evaluate the network "
                              "first or pass one")
        fitting = self.camera.model_copy(update={"fit_to_data": True, "near": None, "far": None})
        framed = framed_view(fitting, volumes, self.render_size, self.id).world_camera
        if framed is None:
            low, high, _ = rays_box(volumes)
            raise VGraphError(f"{self.id}.camera: a camera framing the box {low.tolist()} .. "
                              f"{high.tolist()} lies beyond +-1e15 in world units, where a stored "
                              f"camera cannot be held; the default camera (fit_to_data) frames it "
                              f"every frame")
        if framed != self.camera:
            self.camera = framed  # a linked ray caster's camera follows

    # --- drawing --------------------------------------------------------------------------------
    def _uniforms(self, view, size) -> dict | None:
        """Uniforms of the point computation (entry_exit_point.glsl), and under "faces" and "cap"
        those of the two ways of drawing it, in the view's frame; None when the crop box leaves
        nothing."""
        cached = self._volume_uniforms(view.volumes, self._framed_crop(view.frame))
        if cached is None:
            return None
        camera = view.camera
        boxes, proxy, self._hit_box, self._proxy_corners, min_spacing = cached
        planes = self._planes(view.frame)
        clipping = plane_uniforms(planes, view.frame) if planes else {}
        return {**boxes, **clipping,
                "faces": {**proxy["faces"], "view_projection": camera.view_projection(size[0] / size[1])},
                "cap": proxy["cap"],
                "near_to_far": camera.far - camera.near,
                "jitter": float(self.jitter * min_spacing),
                **pixel_rays(camera, size)}  # a tile's pixels: the whole picture's rays

    def _framed_crop(self, frame):
        """The crop box in the frame (as given in world units for the identity frame); None in a
        turned frame, where it cuts as six planes (_planes)."""
        crop = self.crop_box
        if crop is None or frame.is_identity:
            return crop
        if frame.is_turned:
            return None
        return (*frame.points(crop[:3]).tolist(), *frame.points(crop[3:]).tolist())

    def _planes(self, frame) -> tuple:
        """The clip planes, and in a turned frame (a volume tilted against the world axes) the
        crop box's six planes after them."""
        planes = tuple(self.clip_planes)
        if self.crop_box is None or not frame.is_turned:
            return planes
        if len(planes) + 6 > MAX_CLIP_PLANES:
            raise PropertyError(f"{self.id}.crop_box", f"the volume is tilted against the world axes, "
                                                       f"where the crop box cuts as six planes: with "
                                                       f"{len(planes)} clip planes that is more than "
                                                       f"{MAX_CLIP_PLANES}; remove the crop box or "
                                                       f"{len(planes) + 6 - MAX_CLIP_PLANES} clip planes")
        return planes + crop_planes(self.crop_box)

    def _volume_uniforms(self, volumes: tuple, crop):
        """What depends on the volumes alone, worked out once per volume set (a camera drag asks
        every frame): (box uniforms, proxy uniforms of faces and cap, the hit box, the corners of
        the drawn box, min spacing), or None when the crop box leaves nothing of the rays' box."""
        cache = self._volume_cache
        if (cache is None or len(cache[0]) != len(volumes) or any(a is not b for a, b in zip(cache[0], volumes))
                or cache[1] != crop):
            self._volume_cache = (volumes, crop, self._box_uniforms(volumes, crop))
        return self._volume_cache[2]

    @staticmethod
    def _box_uniforms(volumes: tuple, crop):
        geometry = VolumeGeometry.of(volumes[0])  # the texture space of the outputs
        whole_min, whole_max, min_spacing = rays_box(volumes)
        kept = cropped_box(whole_min, whole_max, crop)
        if kept is None:
            return None
        box_min, box_max = kept
        hit_min, hit_max = hit_box = grown_box_of((whole_min, whole_max), min_spacing, box_min, box_max)
        proxy_min, proxy_max = proxy_box_of(min_spacing, *hit_box)
        scale, offset = geometry.world_to_texture
        if len(volumes) == 1:
            texture_min, texture_max = geometry.texture_box  # as before, to the last bit
        else:  # the union box in the first volume's texture space: may leave [0, 1]
            texture_min, texture_max = whole_min * scale + offset, whole_max * scale + offset
        boxes = {"box_min": vec(box_min), "box_max": vec(box_max),
                 "hit_box_min": vec(hit_min), "hit_box_max": vec(hit_max),
                 "world_to_texture_scale": vec(scale), "world_to_texture_offset": vec(offset),
                 "texture_box_min": vec(texture_min), "texture_box_max": vec(texture_max),
                 "texture_to_world_scale": vec(geometry.texture_to_world[0])}
        proxies = {"faces": {"proxy_min": vec(proxy_min), "proxy_size": vec(proxy_max - proxy_min)},
                   "cap": {"proxy_min": vec(proxy_min), "proxy_max": vec(proxy_max)}}
        return boxes, proxies, hit_box, box_corners(proxy_min, proxy_max), min_spacing

    def _draw(self, ctx, defines: dict, uniforms: dict) -> None:
        """Rasterise the box's back faces into both targets, then cap with the far plane."""
        uniforms = dict(uniforms)
        faces_only, cap_only = uniforms.pop("faces"), uniforms.pop("cap")
        targets = self._targets
        targets.framebuffer.use()
        ctx.viewport = (0, 0, *targets.size)
        faces = programs.program(ctx, *FACE_SHADERS, defines, processor=self.id)
        self.passes.append((FACE_SHADERS[1], defines))
        set_uniforms(faces, {**uniforms, **faces_only})
        ctx.front_face, ctx.cull_face = "ccw", "front"
        ctx.enable(moderngl.CULL_FACE)
        try:
            self._cube_vertex_array(ctx, faces).render(moderngl.TRIANGLES)
        finally:
            ctx.disable(moderngl.CULL_FACE)
        camera = self._view.camera  # in the frame of the boxes
        if not plane_cuts_box(camera, "far", *self._hit_box):
            return  # the full-screen capping pass would change no pixel
        centre, right, up = plane_frame(*picture_of(camera, targets.size)[:2], "far")
        cap = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, CAP_SHADER, defines, processor=self.id)
        self.passes.append((CAP_SHADER, defines))
        fullscreen_pass(ctx, cap, targets, {},
                        {**uniforms, **cap_only, "cap_centre": vec(centre), "cap_right": vec(right),
                         "cap_up": vec(up)})

    def _cube_vertex_array(self, ctx, program):
        if self._cube is None or self._cube[0] is not ctx:
            self._cube = (ctx, ctx.buffer(cube_triangles().tobytes()), {})
        _, buffer, arrays = self._cube
        if program not in arrays:
            arrays[program] = ctx.vertex_array(program, [(buffer, "3f", "corner")])
        return arrays[program]
