"""GeometryRenderer: an opaque triangle mesh (Geometry) drawn with the GL's depth test, as a colour
image and a depth image that GeometryEntryExit uses to stop a ray caster's rays at the surface.

Conventions:
- Colour: ``coloring`` auto takes the geometry's vertex colours if it has them, else its scalars
  through ``colormap`` over ``scalar_range`` (empty: the scalars' min..max), else ``color``. The
  surface is opaque (alpha 1; a vertex colour's alpha is not used) and lit like the ray casters'
  samples (Blinn-Phong, two-sided, the same properties: raycasting/shading.glsl) with the
  geometry's normals, or area-weighted face normals when it has none. Pixels without geometry
  show ``background``. Colours are premultiplied, as the ray casters' (alpha 1 makes that moot).
- Depth: the RayCaster's depth output convention (docs/explanations/ray-casting.md): r = window-space depth in
  [0, 1], g = distance in world units from the pixel's ray start on the near plane (Camera.rays),
  b = 0, a = 1 where a surface is; (1, 0, 0, 0) elsewhere.
- Camera: with the optional ``volume`` inport connected the camera resolves against the volume's
  box exactly as EntryExitPoints resolves it (same framing, same automatic near/far planes, the
  same normalised frame for an extreme volume box, where the geometry is drawn moved and scaled):
  link the cameras and connect the same volume, and the images line up pixel for pixel with the
  ray caster's. Without a volume it frames the geometry's bounds; an extreme box (1e14 or 1e-12 across,
  or near the +-1e15 limit) is drawn in its normalised frame as ProjectedTetrahedra draws one
  (vgraph.box_frame: a moved and scaled copy of the geometry, the camera resolved there, the depth
  distance and ``view_camera`` in world units). Geometry beyond the near or far plane is clipped
  by them.
"""

from __future__ import annotations

import moderngl
import numpy as np

from vgraph import (CameraProperty, ColorProperty, Inport, OptionProperty, Outport, Processor,
                    PropertyError, VectorProperty, derived)
from vgraph.box_frame import BoxFrame
from vgraph.camera import Camera
from vgraph.geometry import Geometry
from vgraph.gl_context import bind_default_framebuffer
from vgraph.gl.curvature import COLORMAPS, colormap_table
from vgraph.gl.passes import bind_textures, set_uniform
from vgraph.gl.raycasting.framed_view import framed_view
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA, picture_of, pixel_rays, vec
from vgraph.gl.raycasting.light import Light, shading_uniforms
from vgraph.gl.shaders import programs
from vgraph.image import Image
from vgraph.volume import Volume

SHADERS = ("geometry/surface.vert.glsl", "geometry/surface.frag.glsl")
COLORINGS = ("auto", "uniform", "vertex", "scalar")
_LIGHT = Light().declare()  # the ray casters' lighting properties, declared once there


class GeometryRenderer(Processor):
    """Draws an opaque triangle mesh, shaded, with a depth image for mixing with volume rendering."""

    category = "Geometry"
    inports = [Inport("geometry", Geometry), Inport("volume", Volume, optional=True)]
    outports = [Outport("image", Image), Outport("depth", Image)]
    renders_at_size = True

    camera = CameraProperty(DEFAULT_CAMERA, doc="the view; link it to the EntryExitPoints camera "
                                                "(and connect the same volume) to mix with a ray caster")
    coloring = OptionProperty("auto", choices=list(COLORINGS),
                              doc="auto: vertex colours, else scalars, else color; uniform: color; "
                                  "vertex: the vertex colours; scalar: the scalars through colormap")
    color = ColorProperty((0.8, 0.8, 0.8, 1.0), doc="the surface colour (coloring uniform)")
    colormap = OptionProperty("viridis", choices=list(COLORMAPS), doc="for scalars")
    scalar_range = VectorProperty(None, size=2, optional=True,
                                  doc="scalars at the colour map's ends; empty: the scalars' min..max")
    shading = OptionProperty("blinn_phong", choices=["none", "blinn_phong"], doc="lighting of the surface")
    light = _LIGHT["light"]
    light_direction = _LIGHT["light_direction"]
    ambient = _LIGHT["ambient"]
    diffuse = _LIGHT["diffuse"]
    specular = _LIGHT["specular"]
    shininess = _LIGHT["shininess"]
    background = ColorProperty((0.0, 0.0, 0.0, 1.0), doc="RGBA where there is no surface")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._target: dict = {}  # ctx, size, images, framebuffer, depth renderbuffer
        self._mesh: dict = {}    # ctx, geometry, buffers, vertex arrays by program
        self._colormap_texture: tuple | None = None  # ((ctx, name), texture)
        self.view_camera = None

    # --- evaluation -----------------------------------------------------------------------------
    def process(self, geometry: Geometry, volume: Volume | None) -> dict:
        ctx, size = self.gl, self.render_size
        coloring = self.resolved_coloring(geometry)
        frame, drawn, camera = self._view(geometry, volume, size)
        image, depth, framebuffer = self._targets(ctx, size)
        framebuffer.use()
        # A tile (Camera.tile) is drawn through the whole picture's projection and viewport shifted
        # to it, so it rasterises the whole picture's pixels (docs/guide/distributed.md, "Accuracy").
        whole, whole_size, offset = picture_of(camera, size)
        if max(whole_size) > min(ctx.info["GL_MAX_VIEWPORT_DIMS"]):
            whole, whole_size, offset = camera, tuple(size), (0, 0)
        ctx.viewport = (-offset[0], -offset[1], *whole_size)
        framebuffer.clear(depth=1.0)
        image.framebuffer.clear(*(float(v) for v in self.background))
        depth.framebuffer.clear(1.0, 0.0, 0.0, 0.0)
        if len(geometry.triangles) == 0:
            return {"image": image, "depth": depth}
        defines = {f"COLORING_{coloring.upper()}": True,
                   "SHADING_BLINN_PHONG": self.shading == "blinn_phong",
                   "LIGHT_HEADLIGHT": self.light == "headlight",
                   "PROJECTION_PERSPECTIVE": camera.projection == "perspective"}
        program = programs.program(ctx, *SHADERS, defines, processor=self.id)
        textures = {"colormap": self._colormap(ctx)} if coloring == "scalar" else {}
        framebuffer.use()
        bind_textures(program, textures)
        uniforms = self._uniforms(drawn, camera, size, coloring, frame)
        uniforms["view_projection"] = whole.view_projection(whole_size[0] / whole_size[1])
        uniforms["world_length"] = frame.scale
        for name, value in uniforms.items():
            set_uniform(program, name, value)
        ctx.enable(moderngl.DEPTH_TEST)
        try:
            self._vertex_array(ctx, program, drawn).render(moderngl.TRIANGLES)
            ctx.finish()  # llvmpipe keeps binned geometry of draws nobody waited for (see ProjectedTetrahedra)
        finally:
            ctx.disable(moderngl.DEPTH_TEST)
        return {"image": image, "depth": depth}

    def resolved_coloring(self, geometry: Geometry) -> str:
        """What ``coloring`` means for this geometry; PropertyError when it lacks what is asked."""
        if self.coloring == "auto":
            return "vertex" if geometry.colors is not None else (
                "scalar" if geometry.scalars is not None else "uniform")
        wanted = {"vertex": ("colors", geometry.colors), "scalar": ("scalars", geometry.scalars)}
        if self.coloring in wanted and wanted[self.coloring][1] is None:
            raise PropertyError(f"{self.id}.coloring", f"{self.coloring} colouring needs vertex "
                                f"{wanted[self.coloring][0]}, and the geometry"
                                f"{' from ' + geometry.source if geometry.source else ''} has none")
        return self.coloring

    def scalar_bounds(self, geometry: Geometry) -> tuple[float, float]:
        if self.scalar_range is not None:
            low, high = self.scalar_range
            if not low < high:
                raise PropertyError(f"{self.id}.scalar_range", f"low must be below high, got ({low:g}, {high:g})")
            return float(low), float(high)
        finite = geometry.scalars[np.isfinite(geometry.scalars)]
        if not finite.size:
            raise PropertyError(f"{self.id}.scalar_range", "the geometry's scalars are all non-finite: "
                                                           "give a range")
        low, high = float(finite.min()), float(finite.max())
        return (low, high) if low < high else (low - 0.5, low + 0.5)  # constant: the map's middle

    # --- parts ----------------------------------------------------------------------------------
    def _view(self, geometry: Geometry, volume: Volume | None, size) -> tuple[BoxFrame, Geometry, Camera]:
        """(the frame the geometry is drawn in, the geometry drawn there, the concrete camera
        there); ``view_camera`` is the camera in world units (None where a Camera cannot hold it)."""
        if volume is not None:  # the volume's view, in its box's frame (as the ray caster draws it)
            view = framed_view(self.camera, (volume,), size, self.id)
            self.view_camera = view.world_camera
            return view.frame, _in_frame(geometry, view.frame), view.camera
        low, high = (np.asarray(b, np.float64) for b in geometry.bounds)
        pad = 1e-3 * (float(np.abs(np.concatenate([low, high])).max()) + 1.0)
        low, high = np.where(high - low > 0.0, low, low - pad), np.where(high - low > 0.0, high, high + pad)
        frame = BoxFrame.of(low, high)
        try:
            in_frame, drawn = frame.camera(self.camera), _in_frame(geometry, frame)
        except ValueError:  # a stored camera many radii from a tiny box sees a speck in world units too
            frame, in_frame, drawn = BoxFrame(), self.camera, geometry
        try:
            camera = in_frame.resolved(frame.points(low), frame.points(high), size[0] / size[1])
        except ValueError as error:  # a Camera's limits (pydantic) or an impossible framing
            reason = error.errors()[0]["msg"] if hasattr(error, "errors") else str(error)
            raise PropertyError(f"{self.id}.camera", f"cannot view the geometry's box {low.tolist()} .. "
                                                     f"{high.tolist()} with this camera: {reason}") from None
        self.view_camera = frame.world_camera(camera)
        return frame, drawn, camera

    def _uniforms(self, geometry: Geometry, camera, size, coloring: str, frame: BoxFrame) -> dict:
        rays = pixel_rays(camera, size)  # a tile's pixels take the whole picture's rays
        uniforms = {"view_projection": camera.view_projection(size[0] / size[1]),
                    **{name: rays[name] for name in ("viewport_size", "pixel_offset", "near_centre",
                                                     "near_right", "near_up")}}
        if camera.projection == "perspective":
            uniforms["eye"] = vec(camera.position)
        else:
            uniforms["view_forward"] = vec(camera.basis()[2])
        if coloring == "uniform":
            uniforms["surface_color_uniform"] = tuple(float(v) for v in self.color)
        elif coloring == "scalar":
            uniforms["scalar_low"], uniforms["scalar_high"] = self.scalar_bounds(geometry)
        if self.shading == "blinn_phong":
            shading = shading_uniforms(self, 1.0, frame)  # unit normals: only a zero normal stays unshaded
            if self.light == "headlight":
                shading.pop("light_direction")
            uniforms.update(shading)
        return uniforms

    def _colormap(self, ctx):
        """The colour map as a 256 x 1 RGBA32F texture with linear filtering (the shader samples
        texel centres), made when the map or the context changes."""
        key = (ctx, self.colormap)
        if self._colormap_texture is None or self._colormap_texture[0] != key:
            table = colormap_table(self.colormap)
            texture = ctx.texture((len(table), 1), 4, table.tobytes(), dtype="f4")
            texture.repeat_x = texture.repeat_y = False
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self._colormap_texture = (key, texture)
        return self._colormap_texture[1]

    def _targets(self, ctx, size):
        """The colour and depth images with one framebuffer holding both and a depth buffer,
        kept while context and size stay."""
        target = self._target
        if target.get("ctx") is not ctx or target.get("size") != tuple(size):
            if target.get("ctx") is ctx:
                bind_default_framebuffer(ctx)
                for name in ("framebuffer", "depth_buffer"):
                    target[name].release()
            image, depth = Image.empty(ctx, size), Image.empty(ctx, size)
            depth_buffer = ctx.depth_renderbuffer(tuple(size))
            framebuffer = ctx.framebuffer(color_attachments=[image.texture, depth.texture],
                                          depth_attachment=depth_buffer)
            target.clear()
            target.update(ctx=ctx, size=tuple(size), images=(image, depth), framebuffer=framebuffer,
                          depth_buffer=depth_buffer)
        return (*target["images"], target["framebuffer"])

    def _vertex_array(self, ctx, program, geometry: Geometry):
        """Vertex array of the geometry (position, normal, colour, scalar interleaved, 11 floats a
        vertex), uploaded once per geometry and context."""
        mesh = self._mesh
        if mesh.get("ctx") is not ctx or mesh.get("geometry") is not geometry:
            for name in ("vertices", "indices"):
                if mesh.get("ctx") is ctx and name in mesh:
                    mesh[name].release()
            count = len(geometry.vertices)
            colors = geometry.colors if geometry.colors is not None else np.ones((count, 4), np.float32)
            scalars = geometry.scalars if geometry.scalars is not None else np.zeros(count, np.float32)
            interleaved = np.concatenate([geometry.vertices, geometry.vertex_normals(), colors,
                                          scalars[:, None]], axis=1).astype(np.float32)
            mesh.update(ctx=ctx, geometry=geometry, arrays={},
                        vertices=ctx.buffer(np.ascontiguousarray(interleaved).tobytes()),
                        indices=ctx.buffer(np.ascontiguousarray(geometry.triangles, np.int32).tobytes()))
        if program not in mesh["arrays"]:
            mesh["arrays"][program] = ctx.vertex_array(
                program, [(mesh["vertices"], "3f 3f 4f 1f", "position", "normal", "vertex_color", "scalar")],
                index_buffer=mesh["indices"], index_element_size=4, skip_errors=True)
        return mesh["arrays"][program]


def _in_frame(geometry: Geometry, frame: BoxFrame) -> Geometry:
    """``geometry`` moved and scaled into ``frame`` (itself for the identity frame): one copy per
    geometry while it lives, for the last frame asked (vgraph.derived); normals, colours and
    scalars are the same."""
    if frame.is_identity:
        return geometry
    return derived.value(geometry, "geometry in frame", lambda: _moved(geometry, frame), params=frame)


def _moved(geometry: Geometry, frame: BoxFrame) -> Geometry:
    normals = geometry.normals
    if normals is not None and frame.is_turned:  # a tilted volume's frame turns them too
        normals = frame.directions(normals).astype(np.float32)
    return Geometry(frame.points(geometry.vertices), geometry.triangles, colors=geometry.colors,
                    normals=normals, scalars=geometry.scalars, source=geometry.source)
