"""ProjectedTetrahedra (Shirley & Tuchman 1990; Monsalve 2016 ch. 2-4): direct volume rendering of
a tetrahedral mesh by projecting each tetrahedron to triangles and compositing them back to front.

Conventions (docs/explanations/tetrahedra-renderer.md has the long form):
- Visibility order: the tetrahedra sorted by centroid, farthest first (depth along the view
  direction for the orthographic camera, distance from the eye for the perspective one;
  vgraph.gl.tetrahedra.order), re-sorted only when the mesh or the concrete camera changes and
  uploaded as the index buffer. Not exact for every mesh; ``visibility_order = mpvo`` orders
  across shared faces instead (MPVO, exact for convex meshes; non-convex ones approximated), and
  ``mpvonc`` adds the order across a non-convex mesh's gaps, found by the pixels' rays against its
  boundary faces (vgraph.gl.tetrahedra.nonconvex; also re-sorted when the image size changes).
- Projection: the sorted index buffer is drawn as lines_adjacency, four vertices per tetrahedron;
  the geometry shader classifies the projection (classes 1-4, vgraph.gl.tetrahedra.projection)
  and emits 3 or 4 triangles fanned from the thick point with the exact front and back points of
  each pixel's ray (perspective-correct by construction: homogeneous attributes); the fragment
  stage clamps the segment to its tetrahedron (scalar range, depth extent along the view), which
  only matters for rays grazing faces seen edge-on.
- Meshes cut from a volume (VolumeToTetMesh; ``mesh.grid``) are drawn cell by cell when
  ``grid_cells`` is on: the cells in the grid's sweep order (no sort), each cell's silhouette from
  its front faces, and per pixel the ray split at the faces of the cell's five tetrahedra, each
  piece integrated as a projected tetrahedron would be (vgraph.gl.tetrahedra.cells; the same image
  from a fifth of the primitives).
- Cell scalars (``mesh.per_cell``: a file's cell array) are constant inside each tetrahedron, a
  first-class mode: every tetrahedron has four vertices of its own carrying its value
  (TetMesh.vertices), so each pixel's segment has s_front = s_back and both integrations give the
  integral of a constant, exactly (the preintegrated table read on its diagonal). The visibility
  order is computed on the shared points as for point scalars.
- Tetrahedra (cells) whose scalars all have zero opacity under the TF are neither sorted nor drawn
  (``skip_transparent``; they would add exactly nothing).
- Integration: ``averaged`` (the TF at the mean scalar, alpha = 1 - (1 - a)^(l / L)),
  ``preintegrated`` (a 128 x 128 x 32 RGBA32F table of the segment integral over (s_front,
  s_back, alpha), 8 MiB, rebuilt when the resolved TF changes; vgraph.gl.tetrahedra.preintegration)
  or ``partial`` (partial pre-integration, Moreland & Angel 2004: a 512 x 512 R32F table that does
  not depend on the TF, built once per context, and the TF's knots, with colour and extinction
  linear between them, uploaded when the resolved TF changes; each segment integrated piece by
  piece between knots; vgraph.gl.tetrahedra.partial_preintegration).
  L = mesh.opacity_length: the TF's opacity is that of one sample at rate 1, as in the RayCaster.
- Compositing: premultiplied "over" (ONE, ONE_MINUS_SRC_ALPHA) into RGBA32F cleared to the
  background, which is the same as compositing over the background afterwards.
- Outputs: ``image`` RGBA32F; ``depth`` RGBA32F with r = window depth of the front point of the
  nearest tetrahedron with opacity (1 where none), g = its distance in world units from the ray's
  start on the near plane, b = 0 (no sample count), a = 1 where there is a depth. The depth is on
  demand (drawn, with DEPTH_OUTPUT and a second render target, only when something reads it): on
  llvmpipe drawing it made a frame 1.2-1.3x slower (issue #31).
- The near plane clips: each pixel's segment starts at the near plane at the earliest, where the
  pixel's ray starts (as in the cell path and the exact reference); the far plane does not clip
  (the automatic planes enclose the mesh). A tetrahedron with a vertex behind the eye is not drawn.
- Extreme boxes (1e14 or 1e-12 across, or near the +-1e15 limit; vgraph.box_frame) are drawn in
  their box's normalised frame (vgraph.gl.tetrahedra.frame), where the camera is an ordinary one:
  the same picture as the mesh at ordinary size, the depth output's distance scaled back to world
  units (``world_length``), ``view_camera`` in world units (None where a Camera cannot hold it).
- While the user drags (the frame context's ``interactive``: the GUI's coarse frames) the mesh's
  coarse level of detail is drawn (``coarse_tetrahedra``; vgraph.mesh_lod, made once per
  mesh); the frame after the release draws the mesh itself, the same image as without the drag.
- An image left uniform although some tetrahedra are visible under the TF is reported
  (``visible_content``, scheduler.blank_image_warning).
"""

from __future__ import annotations

import moderngl
import numpy as np

from vgraph import (BoolProperty, CameraProperty, ColorProperty, Inport, IntProperty, OptionProperty, Outport,
                    Processor, PropertyError)
from vgraph.box_frame import BoxFrame
from vgraph.camera import Camera
from vgraph.frame_context import NO_CONTEXT, FrameContext
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA, picture_of, pixel_rays, vec
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.raycasting.textures import TransferFunctionTexture
from vgraph.gl.passes import bind_textures, set_uniform
from vgraph.gl.shaders import programs
from vgraph.gl.tetrahedra import partial_preintegration, preintegration
from vgraph.gl.tetrahedra.cells import cell_buffer, visible_cells_of
from vgraph.gl.tetrahedra.frame import mesh_in_frame
from vgraph.gl.tetrahedra.gl_sort import GLCentroidSort
from vgraph.gl.tetrahedra.order import VisibilityOrder, visible_tetrahedra
from vgraph.image import Image
from vgraph.mesh import TetMesh
from vgraph.mesh_lod import COARSE_TETRAHEDRA, coarse_mesh
from vgraph.properties import TransferFunctionProperty
from vgraph.shown_content import tetrahedra_under
from vgraph.transfer_function import TransferFunction

TETRAHEDRA_SHADERS = ("tetrahedra/project.vert.glsl", "tetrahedra/project.geom.glsl",
                      "tetrahedra/project.frag.glsl")
CELL_SHADERS = ("tetrahedra/cells.vert.glsl", "tetrahedra/cells.geom.glsl", "tetrahedra/cells.frag.glsl")
INTEGRATIONS = ("averaged", "preintegrated", "partial")
# The first look at any mesh's field (what `vgraph run MESH` and a ProjectedTetrahedra from the
# palette show): placed by percentiles of the scalar, so it needs no units; cool to warm over the
# whole field, the opacity rising with the value so the high end shows through the rest, and the
# low end faint but not gone (a cell array of a few values puts many cells there).
DEFAULT_TRANSFER_FUNCTION = TransferFunction(space="percentile", points=[
    (0.0, 0.1, 0.2, 0.8, 0.01), (30.0, 0.2, 0.5, 0.9, 0.02), (70.0, 0.9, 0.8, 0.3, 0.08),
    (100.0, 0.95, 0.2, 0.1, 0.5)])


class PreintegrationTable:
    """The pre-integrated table of the resolved TF as textures (linear filtering, clamp-to-edge):
    the 3D RGBA32F table and, as a 2D R32F texture, its mean extinction over (s_front, s_back)
    (the same in every alpha slice; a 2D lookup is cheaper than a 3D one on a CPU rasteriser).
    Rebuilt only when the resolved TF changes; ``builds`` counts the builds."""

    def __init__(self):
        self.textures = None
        self.key = None
        self.builds = 0

    def update(self, ctx, resolved) -> dict:
        size, slices = preintegration.TABLE_SIZE, preintegration.ALPHA_SLICES
        if self.textures is None or self.textures["preintegrated"].ctx is not ctx:
            self.textures = {"preintegrated": ctx.texture3d((size, size, slices), 4, dtype="f4"),
                             "mean_extinction": ctx.texture((size, size), 1, dtype="f4")}
            for texture in self.textures.values():
                texture.repeat_x = texture.repeat_y = False
                texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.textures["preintegrated"].repeat_z = False
            self.key = None
        if resolved != self.key:
            table = preintegration.table(resolved)
            self.textures["preintegrated"].write(np.ascontiguousarray(table).tobytes())
            self.textures["mean_extinction"].write(np.ascontiguousarray(table[0, ..., 3]).tobytes())
            self.key = resolved
            self.builds += 1
        return self.textures


class PartialPreintegrationTables:
    """Partial pre-integration's textures: ``phi`` (the TF-independent table, linear filtering,
    clamp-to-edge; written once per context) and the resolved TF's knots
    (``knot_positions`` R32F, ``knot_values`` RGBA32F, one row, read with texelFetch), rewritten
    only when the resolved TF changes; ``builds`` counts the knot uploads."""

    def __init__(self):
        self.textures = None
        self.key = None
        self.knot_count = 0
        self.builds = 0

    def update(self, ctx, resolved) -> dict:
        if self.textures is None or self.textures["phi"].ctx is not ctx:
            size = partial_preintegration.PSI_SIZE
            phi = ctx.texture((size, size), 1, partial_preintegration.phi_table().tobytes(), dtype="f4")
            phi.repeat_x = phi.repeat_y = False
            phi.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.textures, self.key = {"phi": phi}, None
        if resolved != self.key:
            positions, values = partial_preintegration.knots(resolved)
            for name, data, components in (("knot_positions", positions, 1), ("knot_values", values, 4)):
                old = self.textures.pop(name, None)
                if old is not None:
                    old.release()
                texture = ctx.texture((len(positions), 1), components,
                                      np.ascontiguousarray(data, dtype=np.float32).tobytes(), dtype="f4")
                texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
                self.textures[name] = texture
            self.knot_count, self.key = len(positions), resolved
            self.builds += 1
        return self.textures


class ProjectedTetrahedra(Processor):
    """Direct volume rendering of a tetrahedral mesh by projected tetrahedra."""

    category = "Mesh rendering"
    inports = [Inport("mesh", TetMesh)]
    outports = [Outport("image", Image), Outport("depth", Image, on_demand=True)]
    renders_at_size = True
    uses_context = ("interactive",)

    camera = CameraProperty(DEFAULT_CAMERA, doc="the view; by default it fits whatever mesh arrives")
    transfer_function = TransferFunctionProperty(
        DEFAULT_TRANSFER_FUNCTION, doc="RGBA over normalised intensity, data values or percentiles "
        "(a preset name or TF file also works); alpha per sample at rate 1, i.e. over the mesh's "
        "opacity length; by default cool to warm over the percentiles of the field")
    integration = OptionProperty("preintegrated", choices=list(INTEGRATIONS),
                                 doc="averaged: the TF at the mean scalar of each tetrahedron's "
                                     "segment (Shirley-Tuchman); preintegrated: the segment integral "
                                     "from a table of the TF (Roettger et al.); partial: partial "
                                     "pre-integration (Moreland-Angel), the segment split at the TF's "
                                     "points, each piece from a table that does not depend on the TF "
                                     "(accurate on stiff TFs)")
    background = ColorProperty((0.0, 0.0, 0.0, 1.0))
    visibility_order = OptionProperty("centroid", choices=["centroid", "centroid_gl", "mpvo", "mpvonc"],
                                      doc="centroid: sort the tetrahedra's centroids (fast, not "
                                          "exact for every mesh); centroid_gl: the same sort in "
                                          "compute shaders (GL 4.3; pays on a GPU, not on a CPU "
                                          "rasteriser); mpvo: the order across shared faces "
                                          "(exact for convex meshes, slower); mpvonc: MPVO plus the "
                                          "order across the gaps of a non-convex mesh, found by the "
                                          "pixels' rays (exact for non-convex meshes, slower still)")
    skip_transparent = BoolProperty(True, doc="leave out tetrahedra whose scalars all have zero "
                                              "opacity under the TF (same image, faster)")
    grid_cells = BoolProperty(True, doc="meshes cut from a volume (VolumeToTetMesh): draw each grid "
                                        "cell once, in the grid's sweep order, its five tetrahedra "
                                        "integrated per pixel (same image, faster); off: each "
                                        "tetrahedron by itself, in the visibility_order")
    coarse_tetrahedra = IntProperty(COARSE_TETRAHEDRA, min=0, doc="while the mouse drags in the GUI, "
                                    "draw the mesh clustered to about this many tetrahedra (made once "
                                    "per mesh), the mesh itself after the release; 0: the mesh itself "
                                    "while dragging too")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = {True: RenderTargets(2), False: RenderTargets(1)}  # by: depth output wanted
        self._order = VisibilityOrder()
        self._lut = TransferFunctionTexture()
        self._table = PreintegrationTable()
        self._partial = PartialPreintegrationTables()
        self._draw_state: dict = {}  # ctx, index buffer, vertex arrays by program
        self.view_camera = None

    def visible_content(self) -> str | None:
        mesh = self.inputs.get("mesh")
        if mesh is None:
            return None
        alpha = self.transfer_function.for_volume(mesh).lut()[:, 3]
        share = float(visible_tetrahedra(mesh, alpha).mean())
        if share == 0.0:
            return None
        return f"{share:.0%} of the tetrahedra are visible under the transfer function" if share >= 0.005 \
            else "under 1% of the tetrahedra are visible under the transfer function"

    def shown_content(self) -> list:
        """The tetrahedra its transfer function shows (vgraph.blank_causes)."""
        mesh = self.inputs.get("mesh")
        if mesh is None:
            return []
        alpha = self.transfer_function.for_volume(mesh).lut()[:, 3]
        return [tetrahedra_under("mesh", mesh, self.transfer_function, visible_tetrahedra(mesh, alpha))]

    def process(self, mesh: TetMesh, context: FrameContext = NO_CONTEXT) -> dict:
        if context.interactive and self.coarse_tetrahedra:  # a drag's frame: the coarse level of detail
            mesh = coarse_mesh(mesh, self.coarse_tetrahedra)
        ctx = self.gl
        size = self.render_size
        frame, mesh, camera = self._view(mesh, size)
        with_depth = self.wants("depth")
        targets = self._targets[with_depth]
        self._targets[not with_depth].release()  # a scene keeps the images of one kind only
        outputs = dict(zip(("image", "depth"), targets.ensure(ctx, size)))
        outputs["image"].framebuffer.clear(*(float(v) for v in self.background))
        if with_depth:
            outputs["depth"].framebuffer.clear(1.0, 0.0, 0.0, 0.0)

        by_cells = self.grid_cells and mesh.grid is not None
        shaders = CELL_SHADERS if by_cells else TETRAHEDRA_SHADERS
        defines = {"INTEGRATION_AVERAGED": self.integration == "averaged",
                   "INTEGRATION_PREINTEGRATED": self.integration == "preintegrated",
                   "INTEGRATION_PARTIAL": self.integration == "partial",
                   "TABLE_SIZE": preintegration.TABLE_SIZE,
                   "ALPHA_SLICES": preintegration.ALPHA_SLICES,
                   "PSI_SIZE": partial_preintegration.PSI_SIZE, "DEPTH_OUTPUT": with_depth,
                   "PHI_SERIES_DEPTH": partial_preintegration.PHI_SERIES_DEPTH}
        program = programs.program(ctx, shaders[0], shaders[2], defines, processor=self.id,
                                   geometry=shaders[1])
        resolved = self.transfer_function.for_volume(mesh)
        if self.integration == "preintegrated":
            textures = self._table.update(ctx, resolved)
        elif self.integration == "partial":
            textures = self._partial.update(ctx, resolved)
        else:
            textures = {"transfer_function": self._lut.update(ctx, self.transfer_function, mesh)}
        uniforms = self._uniforms(mesh, camera, size, by_cells)
        # A tile (Camera.tile) projects and orders with the whole picture's numbers and is drawn
        # through the whole picture's viewport shifted to it, so it rasterises the whole picture's
        # pixels: its own sub-frustum moved vertices by float32 rounding, enough to take or leave a
        # pixel at a face's edge (docs/guide/distributed.md, "Accuracy").
        whole, whole_size, offset = self._whole_picture(ctx, camera, size)
        uniforms["view_projection"] = whole.view_projection(whole_size[0] / whole_size[1])
        if self.integration == "partial":
            uniforms["knot_count"] = self._partial.knot_count
        uniforms["world_length"] = frame.scale
        selection = None
        if self.skip_transparent:
            visible = visible_cells_of if by_cells else visible_tetrahedra
            selection = (resolved, lambda: visible(mesh, resolved.lut()[:, 3]))
        vertex_array = self._vertex_array(ctx, program, mesh, whole, selection, by_cells, whole_size)
        if vertex_array is None:  # every tetrahedron is transparent
            return outputs

        targets.framebuffer.use()
        ctx.viewport = (-offset[0], -offset[1], *whole_size)
        bind_textures(program, textures)
        for name, value in uniforms.items():
            set_uniform(program, name, value)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA
        ctx.blend_equation = moderngl.FUNC_ADD
        try:
            vertex_array.render(moderngl.POINTS if by_cells else moderngl.LINES_ADJACENCY)
            # llvmpipe keeps the binned geometry of draws nobody waited for: frames that are never
            # read back grew the process by ~0.5 MB each (tests/test_leaks.py); a finish keeps it flat.
            ctx.finish()
        finally:
            ctx.blend_func = moderngl.DEFAULT_BLENDING
            ctx.disable(moderngl.BLEND)
        return outputs

    @staticmethod
    def _whole_picture(ctx, camera, size):
        """picture_of(camera, size), or the tile itself where the GL cannot hold the whole
        picture's viewport."""
        whole, whole_size, offset = picture_of(camera, size)
        if max(whole_size) > min(ctx.info["GL_MAX_VIEWPORT_DIMS"]):
            return camera, tuple(size), (0, 0)
        return whole, whole_size, offset

    def _view(self, mesh: TetMesh, size) -> tuple[BoxFrame, TetMesh, Camera]:
        """(the frame ``mesh`` is drawn in, the mesh drawn there, the concrete camera there): an
        extreme box is drawn in its normalised frame (vgraph.gl.tetrahedra.frame). ``view_camera``
        is the camera in world units (None where a Camera cannot hold it: a box near 1e15)."""
        frame, drawn = mesh_in_frame(mesh)
        try:
            in_frame = frame.camera(self.camera)
        except ValueError:  # a stored camera many radii from a tiny box sees a speck in world units too
            frame, drawn, in_frame = BoxFrame(), mesh, self.camera
        try:
            camera = in_frame.resolved(*drawn.box, size[0] / size[1])
        except ValueError as error:  # a Camera's limits (pydantic) or an impossible framing
            reason = error.errors()[0]["msg"] if hasattr(error, "errors") else str(error)
            raise PropertyError(f"{self.id}.camera", f"cannot view the mesh's box "
                                                     f"{[list(c) for c in mesh.box]} with this camera: "
                                                     f"{reason}") from None
        self.view_camera = frame.world_camera(camera)
        return frame, drawn, camera

    @staticmethod
    def _uniforms(mesh: TetMesh, camera, size, by_cells: bool) -> dict:
        rays = pixel_rays(camera, size)  # a tile's pixels take the whole picture's rays
        uniforms = {"view_projection": camera.view_projection(size[0] / size[1]),
                    "inverse_opacity_length": 1.0 / float(mesh.opacity_length),
                    "viewport_size": rays["viewport_size"], "pixel_offset": rays["pixel_offset"]}
        if by_cells:  # rays from the pixel (origin and direction) and the cells' size
            uniforms.update(rays, spacing=vec(mesh.grid.spacing))
        else:  # where the pixel's ray starts (the depth output's distance), the view direction
            uniforms.update({name: rays[name] for name in ("near_centre", "near_right", "near_up")},
                            view_forward=vec(camera.basis()[2]))
        return uniforms

    def _vertex_array(self, ctx, program, mesh: TetMesh, camera, selection, by_cells: bool, size):
        """The vertex array of the mesh's points (or grid cells) with the tetrahedra (cells) to
        draw in visibility order (None when there are none)."""
        state = self._draw_state
        if state.get("ctx") is not ctx or state.get("mesh") is not mesh or state.get("by_cells") != by_cells:
            self._order = VisibilityOrder()  # another context, mesh or primitive: order and upload afresh
            state.clear()
            state.update(ctx=ctx, mesh=mesh, by_cells=by_cells, arrays={})
        method = "sweep" if by_cells else self.visibility_order
        index_buffer = (self._gl_sorted(ctx, mesh, camera, selection) if method == "centroid_gl"
                        else self._uploaded_order(ctx, mesh, camera, selection, method, size))
        if index_buffer is None:
            return None
        arrays = state["arrays"]
        if program not in arrays:
            if by_cells:
                content = [(cell_buffer(ctx, mesh), "4f 4f 4f", "cell", "scalars_low", "scalars_high")]
            else:
                content = [(mesh.buffers(ctx)["points"], "4f", "point")]
            arrays[program] = ctx.vertex_array(program, content, index_buffer=index_buffer,
                                               index_element_size=4)
        return arrays[program]

    def _uploaded_order(self, ctx, mesh, camera, selection, method, size):
        """The index buffer of the order computed with numpy (None: nothing to draw)."""
        state = self._draw_state
        indices, changed = self._order.update(mesh, camera, selection, method, size)
        if indices.size == 0:
            return None
        if changed or "indices" not in state:
            if "indices" in state and state["indices"].size == indices.nbytes:
                state["indices"].write(indices.tobytes())
            else:
                state["indices"] = ctx.buffer(indices.tobytes())
                state["arrays"] = {}
        return state["indices"]

    def _gl_sorted(self, ctx, mesh, camera, selection):
        """The index buffer sorted on the GL side (None: nothing to draw); the tetrahedra to draw
        are uploaded when the selection changes, sorted when the camera does."""
        state = self._draw_state
        selected = None if selection is None else selection[0]
        if "gl_sort" not in state or state["gl_sort_for"] != selected:
            mask = self._order.selected(mesh, selection)
            tets = mesh.vertex_indices if mask is None else mesh.vertex_indices[mask]
            if state.get("gl_sort"):
                state["gl_sort"].release()
            state.update(gl_sort=GLCentroidSort(ctx, mesh.buffers(ctx)["points"], tets) if len(tets) else None,
                         gl_sort_for=selected, gl_sorted_for=None, arrays={})
        sorter, view = state["gl_sort"], camera.model_dump_json()
        if sorter is not None and state["gl_sorted_for"] != view:
            sorter.sort(camera)
            state["gl_sorted_for"] = view
            self._order.sorts += 1
        return None if sorter is None else sorter.sorted
