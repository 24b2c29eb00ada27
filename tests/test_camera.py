"""Camera math: gluLookAt / gluPerspective / glOrtho conventions, pixel-centre rays, trackball
helpers, framing and JSON validation."""

import json
import math

import numpy as np
import pytest
from pydantic import ValidationError

from vgraph.camera import Camera

BOX = (np.array([-1.0, 2.0, 0.5]), np.array([3.0, 5.0, 1.5]))


def corners(box_min, box_max):
    return np.array([[x, y, z] for x in (box_min[0], box_max[0]) for y in (box_min[1], box_max[1])
                     for z in (box_min[2], box_max[2])])


def to_ndc(matrix, points):
    clip = np.c_[points, np.ones(len(points))] @ matrix.T
    return clip[:, :3] / clip[:, 3:4]


def oblique(projection="perspective"):
    return Camera(projection=projection, position=(4.0, -3.0, 7.0), focus=(1.0, 1.0, 0.5),
                  up=(0.2, 1.0, 0.1), fov=40.0, parallel_scale=2.5, near=0.5, far=30.0)


def test_view_matrix_maps_eye_to_origin_and_focus_to_negative_z():
    camera = oblique()
    view = camera.view_matrix()
    assert view.shape == (4, 4) and view.dtype == np.float64
    np.testing.assert_allclose(view @ [*camera.position, 1.0], [0, 0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(view @ [*camera.focus, 1.0], [0, 0, -camera.distance, 1], atol=1e-12)
    np.testing.assert_allclose(view[:3, :3] @ view[:3, :3].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(view[:3, :3]) == pytest.approx(1.0)  # right-handed, no mirror
    # The stored up ends up in the upper half of the eye's y axis, the right vector on +x.
    right, true_up, forward = camera.basis()
    np.testing.assert_allclose(view[:3, :3] @ right, [1, 0, 0], atol=1e-12)
    assert (view[:3, :3] @ np.asarray(camera.up))[1] > 0


def test_projection_matrices_follow_opengl_conventions():
    camera = oblique()
    proj = camera.projection_matrix(1.5)
    cot = 1.0 / math.tan(math.radians(20.0))
    expected = [[cot / 1.5, 0, 0, 0], [0, cot, 0, 0],
                [0, 0, (30.5) / (0.5 - 30.0), 2 * 30.0 * 0.5 / (0.5 - 30.0)], [0, 0, -1, 0]]
    np.testing.assert_allclose(proj, expected)
    for projection in ("perspective", "orthographic"):
        proj = oblique(projection).projection_matrix(1.5)
        eye_points = np.array([[0, 0, -0.5], [0, 0, -30.0]])
        np.testing.assert_allclose(to_ndc(proj, eye_points)[:, 2], [-1, 1], atol=1e-12)
    ortho = oblique("orthographic").projection_matrix(1.5)
    # parallel_scale is the half height; the half width is parallel_scale * aspect.
    np.testing.assert_allclose(to_ndc(ortho, np.array([[3.75, 2.5, -5.0]]))[0, :2], [1, 1])
    np.testing.assert_allclose(camera.view_projection(2.0),
                               camera.projection_matrix(2.0) @ camera.view_matrix())


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_rays_pass_through_pixel_centres_of_the_inverse_view_projection(projection):
    camera, width, height = oblique(projection), 7, 4
    origins, directions = camera.rays(width, height)
    assert origins.shape == directions.shape == (height, width, 3)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=-1), 1.0)
    inverse = np.linalg.inv(camera.view_projection(width / height))
    for row, col in [(0, 0), (0, width - 1), (height - 1, 0), (2, 3)]:
        ndc_x, ndc_y = (col + 0.5) / width * 2 - 1, 1 - (row + 0.5) / height * 2
        near, far = (inverse @ [ndc_x, ndc_y, z, 1.0] for z in (-1.0, 1.0))
        near, far = near[:3] / near[3], far[:3] / far[3]
        np.testing.assert_allclose(origins[row, col], near, atol=1e-9)
        np.testing.assert_allclose(directions[row, col], (far - near) / np.linalg.norm(far - near),
                                   atol=1e-9)
        # far_distance() reaches exactly the far plane.
        t_far = camera.far_distance(directions[row, col])
        np.testing.assert_allclose(origins[row, col] + t_far * directions[row, col], far, atol=1e-8)
    # Row 0 is the top of the image: its rays point further along the camera's up.
    _, true_up, _ = camera.basis()
    assert (origins[0, 3] + directions[0, 3]) @ true_up > (origins[-1, 3] + directions[-1, 3]) @ true_up


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("aspect", [0.5, 1.0, 2.0])
def test_framing_puts_the_whole_box_inside_ndc(projection, aspect):
    camera = oblique(projection).framing(*BOX, aspect=aspect)
    np.testing.assert_allclose(camera.focus, (BOX[0] + BOX[1]) / 2)
    np.testing.assert_allclose(camera.basis()[2], oblique().basis()[2], atol=1e-12)  # direction kept
    assert camera.up == oblique().up
    ndc = to_ndc(camera.view_projection(aspect), corners(*BOX))
    assert np.all(np.abs(ndc) <= 1.0)
    # ... and fills a sensible part of the view (it is a tight fit, not a tiny one).
    assert np.abs(ndc[:, :2]).max() > 0.5


def test_framing_fits_the_bounding_sphere_exactly():
    camera = Camera(fov=60.0).framing([-1, -1, -1], [1, 1, 1], aspect=1.0)
    radius = math.sqrt(3.0)
    assert camera.distance == pytest.approx(radius / math.sin(math.radians(30.0)))
    assert camera.parallel_scale == pytest.approx(radius)
    assert camera.near == pytest.approx((camera.distance - radius) * (1 - 1e-3))
    assert camera.far == pytest.approx((camera.distance + radius) * (1 + 1e-3))
    wide = Camera(fov=60.0).framing([-1, -1, -1], [1, 1, 1], aspect=0.5)
    assert wide.distance > camera.distance  # the narrower horizontal fov limits
    assert wide.parallel_scale == pytest.approx(2 * radius)


def test_looking_at_box_views_along_the_direction():
    camera = Camera.looking_at_box(*BOX, direction=(0, 0, -1), projection="orthographic")
    np.testing.assert_allclose(camera.basis()[2], [0, 0, -1])
    assert camera.projection == "orthographic"
    assert np.all(np.abs(to_ndc(camera.view_projection(1.0), corners(*BOX))) <= 1.0)


def test_rotate_orbits_around_the_focus():
    camera = oblique()
    for dx, dy in [(0.3, 0.0), (0.0, -0.7), (1.1, 0.4)]:
        turned = camera.rotate(dx, dy)
        assert turned.focus == camera.focus
        assert turned.distance == pytest.approx(camera.distance)
        right, true_up, forward = turned.basis()
        np.testing.assert_allclose(np.asarray(turned.up), true_up, atol=1e-12)
    turned = camera.rotate(0.3, 0.0)
    cos_angle = camera.basis()[2] @ turned.basis()[2]
    assert cos_angle == pytest.approx(math.cos(0.3))
    back = camera.rotate(2 * math.pi, 0.0)
    np.testing.assert_allclose(back.position, camera.position, atol=1e-12)


def test_rotate_turns_the_scene_with_the_mouse():
    camera = Camera(position=(0.0, 0.0, 5.0), focus=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
    # Drag right: the camera orbits to the left (-x), the scene turns right.
    np.testing.assert_allclose(camera.rotate(math.pi / 2, 0.0).position, [-5, 0, 0], atol=1e-12)
    # Drag up: the camera orbits downwards and its up tilts to keep looking at the focus.
    tilted = camera.rotate(0.0, math.pi / 2)
    np.testing.assert_allclose(tilted.position, [0, -5, 0], atol=1e-12)
    np.testing.assert_allclose(tilted.up, [0, 0, 1], atol=1e-12)


def test_zoom_dollies_perspective_and_scales_orthographic():
    camera = oblique().framing(*BOX)
    closer = camera.zoom(2.0)
    assert closer.distance == pytest.approx(camera.distance / 2)
    assert closer.focus == camera.focus
    np.testing.assert_allclose(closer.basis()[2], camera.basis()[2], atol=1e-12)
    shift = camera.distance / 2
    assert closer.far == pytest.approx(camera.far - shift)
    assert 0 < closer.near < closer.far
    # Framing planes stay attached to the scene: the box still lies between them after zooming out.
    farther = camera.zoom(0.25)
    ndc = to_ndc(farther.view_projection(1.0), corners(*BOX))
    assert np.all(np.abs(ndc[:, 2]) <= 1.0)
    ortho = oblique("orthographic")
    zoomed = ortho.zoom(4.0)
    assert zoomed.parallel_scale == pytest.approx(ortho.parallel_scale / 4)
    assert zoomed.position == ortho.position
    for bad in (0.0, -1.0, math.inf):
        with pytest.raises(ValueError, match="factor"):
            ortho.zoom(bad)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_pan_moves_the_scene_by_fractions_of_the_view_height(projection):
    camera, aspect = oblique(projection), 1.6
    moved = camera.pan(0.1, -0.2)
    shift = np.subtract(moved.position, camera.position)
    np.testing.assert_allclose(np.subtract(moved.focus, camera.focus), shift, atol=1e-12)
    assert abs(shift @ camera.basis()[2]) < 1e-12  # in the view plane
    # The old focus now appears at 2 * (dx / aspect, dy) in NDC: it moved with the "mouse".
    ndc = to_ndc(moved.view_projection(aspect), np.array([camera.focus]))[0]
    np.testing.assert_allclose(ndc[:2], [0.2 / aspect, -0.4], atol=1e-12)


def test_json_round_trip_keeps_the_form():
    camera = oblique().rotate(0.2, 0.1).pan(0.1, 0.0).zoom(1.5)
    data = json.loads(camera.model_dump_json())
    assert set(data) == {"projection", "position", "focus", "up", "fov", "parallel_scale", "near", "far",
                         "fit_to_data"}
    assert Camera.model_validate_json(camera.model_dump_json()) == camera
    with pytest.raises(ValidationError):
        camera.fov = 10.0  # frozen


@pytest.mark.parametrize("change, message", [
    ({"fov": 0}, "fov"),
    ({"fov": 180}, "fov"),
    ({"parallel_scale": -1}, "parallel_scale"),
    ({"near": 0}, "near"),
    ({"near": 5, "far": 1}, "near"),
    ({"projection": "fisheye"}, "projection"),
    ({"position": [0, 0, 0], "focus": [0, 0, 0]}, "position and focus must differ"),
    ({"up": [0, 0, 1]}, "up must not be parallel"),
    ({"position": [0, 0]}, "position"),
    ({"zoom": 2}, "zoom"),
])
def test_invalid_json_values_are_rejected(change, message):
    data = {"projection": "perspective", "position": [0, 0, 3], "focus": [0, 0, 0],
            "up": [0, 1, 0], "fov": 30, "parallel_scale": 1, "near": 0.01, "far": 100}
    data.update(change)
    with pytest.raises(ValidationError, match=message):
        Camera.model_validate_json(json.dumps(data))


def test_helpers_reject_bad_arguments():
    camera = oblique()
    with pytest.raises(ValueError, match="aspect"):
        camera.projection_matrix(0.0)
    with pytest.raises(ValueError, match="size"):
        camera.rays(0, 4)
    with pytest.raises(ValueError, match="dx"):
        camera.rotate(math.nan, 0.0)
    with pytest.raises(ValueError, match="box_max"):
        camera.framing([1, 1, 1], [0, 0, 0])


# --- automatic parts: fit to data, near/far from the box, named views ------------------------------
MM_BOX = ([0.0, 0.0, 0.0], [255.0, 255.0, 180.0])  # a head measured in mm


def test_automatic_planes_enclose_the_box_from_wherever_the_camera_stands():
    camera = Camera(position=(127.5, 127.5, 700.0), focus=(127.5, 127.5, 90.0))  # no planes given
    assert camera.near is None and camera.far is None
    with pytest.raises(ValueError, match="automatic"):
        camera.view_projection(1.0)
    resolved = camera.resolved(*MM_BOX)
    centre, radius = np.mean(MM_BOX, axis=0), np.linalg.norm(np.subtract(*MM_BOX[::-1])) / 2
    depth = np.linalg.norm(centre - camera.position)
    assert resolved.near < depth - radius < depth + radius < resolved.far  # far 100 used to clip it
    assert resolved.position == camera.position and not resolved.fit_to_data


def test_explicit_planes_are_kept_and_automatic_ones_never_cross_them():
    camera = Camera(position=(0.0, 0.0, 500.0), near=1.0)
    assert camera.resolved(*MM_BOX).near == 1.0
    deep = Camera(position=(0.0, 0.0, 500.0), near=5000.0).resolved(*MM_BOX)
    assert deep.near == 5000.0 < deep.far


def test_fit_to_data_frames_each_box_keeping_the_direction():
    camera = Camera(position=(0.0, 0.0, 3.0), fit_to_data=True)
    small, large = camera.resolved([-1, -1, -1], [1, 1, 1]), camera.resolved(*MM_BOX)
    for resolved, box in ((small, ([-1, -1, -1], [1, 1, 1])), (large, MM_BOX)):
        assert np.allclose(resolved.focus, np.mean(box, axis=0))
        assert np.allclose(resolved.basis()[2], camera.basis()[2])
    assert large.distance > 100 * small.distance


@pytest.mark.parametrize("name, towards_eye", [("front", (0, 1, 0)), ("anterior", (0, 1, 0)),
                                                ("back", (0, -1, 0)), ("left", (-1, 0, 0)),
                                                ("right", (1, 0, 0)), ("top", (0, 0, 1)),
                                                ("superior", (0, 0, 1)), ("bottom", (0, 0, -1)),
                                                ("iso", (1, 1, 1))])
def test_named_views_look_from_their_side_and_fit_the_data(name, towards_eye):
    camera = oblique().viewed_from(name)
    assert camera.fit_to_data and camera.near is None
    resolved = camera.resolved(*MM_BOX)
    assert np.allclose(-resolved.basis()[2], np.asarray(towards_eye) / np.linalg.norm(towards_eye))
    assert np.allclose(resolved.focus, np.mean(MM_BOX, axis=0))


def test_an_unknown_view_lists_the_names():
    with pytest.raises(ValueError, match="front, back, left, right, top, bottom, iso, anterior"):
        oblique().viewed_from("sideways")
