"""GeometryRenderer (issue #18 item 4): the pixels of a sphere mesh against the analytic sphere:
silhouette, depth in the RayCaster's convention, Blinn-Phong shading, colour map of scalars; the
errors for what the geometry lacks."""

import numpy as np
import pytest

from vgraph import PropertyError
from vgraph.camera import Camera
from vgraph.geometry import Geometry
from vgraph.gl.curvature import colormap_table
from vgraph.network import Network
from vgraph.processors.geometry_renderer import GeometryRenderer
from vgraph.testing import GivenVolume
from vgraph.volume import Volume

from helpers.geometry import GivenGeometry

SIZE = (80, 64)
CENTRE, RADIUS = np.array([1.0, 2.0, 3.0]), 2.0
CAMERAS = {
    "perspective": Camera(position=(4.0, 5.0, 12.0), focus=tuple(CENTRE), near=4.0, far=20.0),
    "orthographic": Camera(projection="orthographic", position=(1.0, -7.0, 3.0), focus=tuple(CENTRE),
                           up=(0.0, 0.0, 1.0), parallel_scale=2.5, near=4.0, far=20.0),
}


def render(geometry, camera, **properties):
    renderer = GeometryRenderer("gr", camera=camera, **properties)
    renderer.render_size = SIZE
    outputs = renderer.process(geometry, None)
    return outputs["image"].to_numpy(), outputs["depth"].to_numpy()


def sphere_hits(camera):
    """Per pixel: distance from the ray's near-plane start to the sphere (inf: miss), the hit
    point, and how far inside the silhouette the ray passes (fraction of the radius)."""
    origins, directions = camera.rays(*SIZE)
    offset = origins - CENTRE
    b = np.einsum("ijk,ijk->ij", offset, directions)
    disc = b * b - (np.einsum("ijk,ijk->ij", offset, offset) - RADIUS ** 2)
    t = np.where(disc > 0.0, -b - np.sqrt(np.maximum(disc, 0.0)), np.inf)
    points = origins + np.where(np.isfinite(t), t, 0.0)[..., None] * directions
    return t, points, np.sqrt(np.maximum(disc, 0.0)) / RADIUS


def window_depth(camera, points):
    clip = np.einsum("ij,...j->...i", camera.view_projection(SIZE[0] / SIZE[1]),
                     np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1))
    return clip[..., 2] / clip[..., 3] * 0.5 + 0.5


@pytest.mark.parametrize("projection", list(CAMERAS))
def test_silhouette_and_depth_match_the_analytic_sphere(gl, projection):
    camera = CAMERAS[projection]
    image, depth = render(Geometry.sphere(CENTRE, RADIUS, 5), camera, shading="none",
                          color=(1.0, 0.5, 0.25, 1.0), background=(0.0, 0.0, 0.0, 0.0))
    t, points, rim = sphere_hits(camera)
    hit = np.isfinite(t)
    drawn = image[..., 3] == 1.0
    # a pixel whose ray passes the analytic silhouette by more than the tessellation (subdivision
    # 5: the faces lie within 1.2e-3 radius of the sphere) is drawn exactly when it hits
    certain = (rim > 0.06) | ~np.isfinite(t) & (rim == 0.0)
    assert hit.sum() > 500 and np.array_equal(drawn[certain], hit[certain])
    np.testing.assert_allclose(image[drawn], [[1.0, 0.5, 0.25, 1.0]] * int(drawn.sum()))
    np.testing.assert_allclose(image[~drawn], 0.0)
    inner = rim > 0.3
    np.testing.assert_allclose(depth[..., 1][inner], t[inner], atol=1.2e-3 * RADIUS)  # world units; measured 7.7e-4 R (the flat faces)
    np.testing.assert_allclose(depth[..., 0][inner], window_depth(camera, points)[inner], atol=2e-4)
    np.testing.assert_allclose(depth[..., 3], drawn.astype(np.float32))
    np.testing.assert_allclose(depth[~drawn], [[1.0, 0.0, 0.0, 0.0]] * int((~drawn).sum()))


def test_the_nearer_of_two_surfaces_is_seen(gl):
    camera = CAMERAS["perspective"]
    towards_eye = (np.asarray(camera.position) - CENTRE) / np.linalg.norm(np.asarray(camera.position) - CENTRE)
    front, back = Geometry.sphere(CENTRE + 2.5 * towards_eye, 0.5, 3), Geometry.sphere(CENTRE, RADIUS, 4)
    # the far sphere is listed after the near one: the depth test, not the order, decides
    both = Geometry(np.concatenate([front.vertices, back.vertices]),
                    np.concatenate([front.triangles, back.triangles + len(front.vertices)]),
                    colors=np.concatenate([np.tile([0.0, 1.0, 0.0, 1.0], (len(front.vertices), 1)),
                                           np.tile([1.0, 0.0, 0.0, 1.0], (len(back.vertices), 1))]))
    image, depth = render(both, camera, shading="none")  # auto colouring: the vertex colours
    centre_pixel = image[SIZE[1] // 2, SIZE[0] // 2]
    np.testing.assert_allclose(centre_pixel, [0.0, 1.0, 0.0, 1.0])  # the small sphere in front
    assert (image[..., 0] == 1.0).sum() > 300  # the big one around it


@pytest.mark.parametrize("light", ["headlight", "direction"])
def test_blinn_phong_shading_matches_the_formula_with_the_spheres_normals(gl, light):
    camera = CAMERAS["perspective"]
    rgb = np.array([0.9, 0.6, 0.3])
    settings = dict(ambient=0.2, diffuse=0.6, specular=0.3, shininess=16.0, light=light,
                    light_direction=(1.0, 2.0, 2.0))
    image, _ = render(Geometry.sphere(CENTRE, RADIUS, 5), camera, color=(*rgb, 1.0), **settings)
    t, points, rim = sphere_hits(camera)
    inner = rim > 0.3
    normal = (points - CENTRE) / RADIUS
    view = np.asarray(camera.position) - points
    view /= np.linalg.norm(view, axis=-1, keepdims=True)
    if light == "headlight":
        lambert = np.abs(np.einsum("ijk,ijk->ij", normal, view))
        highlight = lambert
    else:
        to_light = np.array(settings["light_direction"]) / 3.0
        lambert = np.maximum(np.einsum("ijk,k->ij", normal, to_light), 0.0)
        halfway = to_light + view
        halfway /= np.linalg.norm(halfway, axis=-1, keepdims=True)
        highlight = np.where(lambert > 0.0, np.maximum(np.einsum("ijk,ijk->ij", normal, halfway), 0.0), 0.0)
    expected = np.clip((0.2 + 0.6 * lambert)[..., None] * rgb + 0.3 * (highlight ** 16.0)[..., None], 0.0, 1.0)
    # interpolated vertex normals of the icosphere differ from the sphere's by < 1e-3 rad
    np.testing.assert_allclose(image[..., :3][inner], expected[inner], atol=2e-3)  # measured 3.7e-4
    assert np.abs(image[..., :3][inner] - expected[inner]).mean() < 2e-4


def test_scalars_are_coloured_through_the_colour_map(gl):
    camera = CAMERAS["orthographic"]
    sphere = Geometry.sphere(CENTRE, RADIUS, 5)
    heights = Geometry(sphere.vertices, sphere.triangles, normals=sphere.normals, scalars=sphere.vertices[:, 2])
    low, high = CENTRE[2] - RADIUS, CENTRE[2] + RADIUS
    image, _ = render(heights, camera, shading="none", colormap="jet")
    t, points, rim = sphere_hits(camera)
    inner = rim > 0.3
    table = colormap_table("jet").astype(np.float64)
    position = (points[..., 2] - low) / (high - low) * (len(table) - 1)
    expected = np.stack([np.interp(position, np.arange(len(table)), table[:, c]) for c in range(3)], axis=-1)
    # viewed along y, a pixel fixes x and z: the face's interpolated z is the sphere's (5e-7 measured)
    np.testing.assert_allclose(image[..., :3][inner], expected[inner], atol=1e-4)
    # a range of one's own: values beyond it take the map's ends
    image, _ = render(heights, camera, shading="none", colormap="jet", scalar_range=(high + 1, high + 2))
    np.testing.assert_allclose(image[..., :3][inner], np.broadcast_to(table[0, :3], expected[inner].shape), atol=1e-5)


def test_what_the_geometry_lacks_is_refused_naming_the_property(gl):
    sphere = Geometry.sphere(CENTRE, RADIUS, 1)
    with pytest.raises(PropertyError, match=r"gr\.coloring.*scalar colouring needs vertex scalars"):
        render(sphere, CAMERAS["perspective"], coloring="scalar")
    with pytest.raises(PropertyError, match=r"gr\.coloring.*vertex colouring needs vertex colors"):
        render(sphere, CAMERAS["perspective"], coloring="vertex")
    scalars = Geometry(sphere.vertices, sphere.triangles, scalars=np.zeros(len(sphere.vertices)))
    with pytest.raises(PropertyError, match=r"gr\.scalar_range.*low must be below high"):
        render(scalars, CAMERAS["perspective"], scalar_range=(1.0, 1.0))


def test_with_a_volume_connected_the_view_is_the_entry_exit_points_view(gl):
    """Default cameras (fit to data, automatic planes) resolve against the volume's box in both
    processors, so the geometry's pixels line up with the ray caster's rays."""
    volume = Volume(np.zeros((20, 30, 40), np.float32), spacing=(0.5, 0.4, 0.3), origin=(1.0, -2.0, 0.5))
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("EntryExitPoints", id="eep")
    network.add("GeometryRenderer", id="gr")
    network.link("eep.camera", "gr.camera")
    network.add(GivenGeometry(id="mesh", geometry=Geometry.sphere((5.0, 3.0, 3.0), 1.0, 2)))
    for source, target in (("src.volume", "eep.volume"), ("src.volume", "gr.volume"),
                           ("mesh.geometry", "gr.geometry")):
        network.connect(source, target)
    network.update("eep.entry", "gr.image", size=(48, 40))
    assert network["gr"].view_camera == network["eep"].view_camera



def test_a_surface_file_renders_from_a_json_network_on_the_cli(tmp_path):
    """SurfaceSource -> GeometryRenderer -> Canvas, saved as .json and run by `vgraph run`: without
    a volume the default camera frames the mesh, so it fills the middle of the picture."""
    import json

    import meshio

    from vgraph.cli import main
    sphere = Geometry.sphere((10.0, -4.0, 2.0), 3.0, 3)
    meshio.write_points_cells(tmp_path / "ball.stl", sphere.vertices.astype(np.float64),
                              [("triangle", sphere.triangles)])
    network = {"format": "vgraph-network", "version": 2, "processors": [
        {"id": "surface", "type": "SurfaceSource", "properties": {"path": "ball.stl"}},
        {"id": "gr", "type": "GeometryRenderer", "properties": {"color": [0.2, 0.6, 1.0, 1.0]}},
        {"id": "canvas", "type": "Canvas", "properties": {"size": [64, 48]}}],
        "connections": [{"from": "surface.geometry", "to": "gr.geometry"},
                        {"from": "gr.image", "to": "canvas.image"}], "links": []}
    (tmp_path / "ball.json").write_text(json.dumps(network))
    assert main(["run", str(tmp_path / "ball.json"), "--data", str(tmp_path / "ball.npy"),
                 "-o", str(tmp_path / "ball.png")]) == 0
    image = np.load(tmp_path / "ball.npy")
    drawn = image[..., 2] > 0.1
    assert image.shape == (48, 64, 4) and 0.1 < drawn.mean() < 0.8
    np.testing.assert_allclose(image[[0, 0, -1, -1], [0, -1, 0, -1]], [[0.0, 0.0, 0.0, 1.0]] * 4)
    # the middle faces the headlight: (ambient + diffuse) colour + specular = colour + 0.2
    np.testing.assert_allclose(image[23:25, 31:33, :3].mean(axis=(0, 1)), [0.4, 0.8, 1.0], atol=0.02)


def test_a_geometry_refuses_non_finite_vertices_and_wrong_shapes():
    from vgraph import VGraphError
    with pytest.raises(VGraphError, match="geometry from bad.obj has non-finite vertex coordinates"):
        Geometry([[0.0, 0.0, 0.0], [1.0, np.nan, 0.0], [0.0, 1.0, 0.0]], [[0, 1, 2]], source="bad.obj")
    with pytest.raises(VGraphError, match=r"geometry scalars must be \(3,\) \(one per vertex\)"):
        Geometry(np.eye(3), [[0, 1, 2]], scalars=[1.0, 2.0])
    with pytest.raises(VGraphError, match="index vertices that do not exist"):
        Geometry(np.eye(3), [[0, 1, 3]])
