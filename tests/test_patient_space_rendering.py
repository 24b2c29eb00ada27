"""Ray casters draw volumes in patient space: a volume stored on mirrored, reordered or tilted axes
gives the picture of the same anatomy, for every named view (docs/explanations/conventions.md)."""

import math

import numpy as np
import pytest

from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.volume import BrickedVolume
from vgraph.camera import VIEW_NAMES, Camera
from vgraph.clipping import ClipPlane
from vgraph.errors import VGraphError
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume

SIZE = (48, 40)
SPACING = (1.0, 1.5, 2.0)
ORIGIN = (-20.0, 5.0, 30.0)


def head() -> np.ndarray:
    """An asymmetric 'head' [z, y, x]: a ball, a 'nose' towards +y (anterior), an 'ear' on +x
    (the patient's right) and a brighter 'crown' at +z, so that every view differs."""
    z, y, x = np.mgrid[0:20, 0:22, 0:24].astype(np.float64)
    centre = np.array([9.5, 10.5, 11.5])
    ball = ((z - centre[0]) * 2.0) ** 2 + ((y - centre[1]) * 1.5) ** 2 + (x - centre[2]) ** 2 < 81.0
    nose = (abs(z - 9) < 2) & (y > 15) & (y < 21) & (abs(x - 11.5) < 2)
    ear = (abs(z - 10) < 3) & (abs(y - 10) < 2) & (x > 19) & (x < 23)
    crown = ball & (z > 13)
    return (ball * 100.0 + nose * 160.0 + ear * 220.0 + crown * 60.0).astype(np.float32)


def ras_volume() -> Volume:
    return Volume(head(), spacing=SPACING, origin=ORIGIN, source="ras")


def stored(volume: Volume, order, signs) -> Volume:
    """The same voxels at the same world points, stored on index axes reordered (new axis w is
    old axis order[w]) and mirrored (signs[w] = -1): what another scanner or tool writes."""
    data = np.transpose(volume.data, [2 - order[2 - a] for a in range(3)])
    data = np.ascontiguousarray(np.flip(data, axis=[2 - w for w in range(3) if signs[w] < 0]))
    old_direction = np.asarray(volume.direction)
    direction = np.zeros((3, 3))
    origin = np.asarray(volume.origin, dtype=np.float64).copy()
    for w, (axis, sign) in enumerate(zip(order, signs)):
        direction[:, w] = sign * old_direction[:, axis]
        if sign < 0:
            origin += old_direction[:, axis] * volume.spacing[axis] * (volume.dims[axis] - 1)
    return Volume(data, spacing=tuple(volume.spacing[a] for a in order), origin=tuple(origin),
                  direction=tuple(map(tuple, direction)), source="stored")


EEP_PROPERTIES = ("crop_box", "clip_planes")


def render(volume: Volume, camera: Camera, **properties) -> np.ndarray:
    """The RayCaster's picture; ``properties`` of the EntryExitPoints (crop box, clip planes) or
    of the ray caster."""
    network = ray_caster_network(volume, camera, transfer_function="auto", shading="blinn_phong")
    for name, value in properties.items():
        network.set(f"{'eep' if name in EEP_PROPERTIES else 'rc'}.{name}", value)
    return network.evaluate("rc.image", size=SIZE)


LPS = ((0, 1, 2), (-1, -1, 1))
CORONAL_ORDER = ((0, 2, 1), (1, -1, 1))  # slices along y, stored as a coronal series


@pytest.mark.parametrize("view", VIEW_NAMES)
def test_an_lps_copy_and_a_ras_copy_of_one_head_give_the_same_picture_from_every_named_view(view):
    camera = DEFAULT_CAMERA.viewed_from(view)
    ras = render(ras_volume(), camera)
    lps = render(stored(ras_volume(), *LPS), camera)
    assert ras[..., 3].max() > 0.5  # something is drawn
    np.testing.assert_allclose(lps, ras, atol=2e-6)


def test_a_volume_stored_in_coronal_order_gives_the_same_picture():
    camera = DEFAULT_CAMERA.viewed_from("left")
    np.testing.assert_allclose(render(stored(ras_volume(), *CORONAL_ORDER), camera),
                               render(ras_volume(), camera), atol=2e-6)


def reach(image: np.ndarray) -> dict[str, float]:
    """How far the drawn silhouette reaches from the image centre to each side, in pixels."""
    rows, columns = np.nonzero(image[..., :3].max(axis=-1) > 0.05)
    height, width = image.shape[:2]
    return {"left": (width - 1) / 2 - columns.min(), "right": columns.max() - (width - 1) / 2,
            "up": (height - 1) / 2 - rows.min(), "down": rows.max() - (height - 1) / 2}


@pytest.mark.parametrize("volume", [ras_volume(), stored(ras_volume(), *LPS)], ids=["RAS", "LPS"])
def test_named_views_are_patient_directions(volume):
    """The ear on the patient's right shows on the image's left from the front (anterior) and on
    its right from behind; from above (superior) the nose points up."""
    anterior = reach(render(volume, DEFAULT_CAMERA.viewed_from("anterior")))
    posterior = reach(render(volume, DEFAULT_CAMERA.viewed_from("posterior")))
    superior = reach(render(volume, DEFAULT_CAMERA.viewed_from("superior")))
    assert anterior["left"] > anterior["right"] + 1
    assert posterior["right"] > posterior["left"] + 1
    assert superior["up"] > superior["down"] + 1 and superior["right"] > superior["left"] + 1


def tilted(volume: Volume, degrees: float) -> Volume:
    """The volume turned about the world x axis through its centre (a tilted acquisition)."""
    angle = math.radians(degrees)
    rotation = np.array([[1, 0, 0], [0, math.cos(angle), -math.sin(angle)], [0, math.sin(angle), math.cos(angle)]])
    centre = volume.voxel_to_world((np.array(volume.dims) - 1) / 2.0)
    origin = centre + rotation @ (np.asarray(volume.origin) - centre)
    return Volume(volume.data, spacing=volume.spacing, origin=tuple(origin),
                  direction=tuple(map(tuple, rotation)), source="tilted")


def x_rotation(degrees: float) -> np.ndarray:
    angle = math.radians(degrees)
    return np.array([[1, 0, 0], [0, math.cos(angle), -math.sin(angle)], [0, math.sin(angle), math.cos(angle)]])


def turned(camera: Camera, rotation: np.ndarray) -> Camera:
    return camera._replace(position=tuple(rotation @ np.asarray(camera.position)),
                           focus=tuple(rotation @ np.asarray(camera.focus)),
                           up=tuple(rotation @ np.asarray(camera.up)))


@pytest.mark.parametrize("light", ["headlight", "direction"])
def test_a_tilted_volume_seen_by_a_camera_turned_with_it_gives_the_untilted_picture(light):
    """Turning the volume, the camera and the light together changes nothing: the tilt is kept,
    not dropped."""
    volume, degrees = ras_volume(), 35.0
    camera, light_direction = DEFAULT_CAMERA.viewed_from("left"), np.array([0.2, -1.0, 0.5])
    rotation = x_rotation(degrees)
    straight = render(volume, camera, light=light, light_direction=tuple(light_direction))
    tilted_view = render(tilted(volume, degrees), turned(camera, rotation), light=light,
                         light_direction=tuple(rotation @ light_direction))
    np.testing.assert_allclose(tilted_view, straight, atol=2e-3)
    # and the tilt shows: the same camera sees the tilted head differently
    assert np.abs(render(tilted(volume, degrees), camera) - straight).max() > 0.2


def test_a_crop_box_cuts_a_tilted_volume_in_world_axes():
    volume = tilted(ras_volume(), 35.0)
    camera = DEFAULT_CAMERA.viewed_from("left")
    low, high = volume.world_box()
    whole = render(volume, camera)
    middle = (low[2] + high[2]) / 2.0
    cropped = render(volume, camera, crop_box=(*low, high[0], high[1], middle))
    by_plane = render(volume, camera, clip_planes=(ClipPlane(normal=(0, 0, -1), point=(0, 0, middle)),))
    assert np.abs(cropped - whole).max() > 0.2
    np.testing.assert_allclose(cropped, by_plane, atol=2e-3)
    with pytest.raises(VGraphError, match=r"eep\.crop_box.*tilted"):
        render(volume, camera, crop_box=(*low, *high),
               clip_planes=tuple(ClipPlane(normal=(0, 0, 1), point=(0, 0, -1e3 - i)) for i in range(3)))


def test_a_stored_camera_is_kept_in_world_for_an_lps_volume():
    ras = ras_volume()
    camera = Camera.looking_at_box(*ras.world_box(), direction=(0.3, -1.0, -0.2), up=(0, 0, 1))
    np.testing.assert_allclose(render(stored(ras, *LPS), camera), render(ras, camera), atol=2e-6)


def test_the_bricked_ray_caster_draws_a_tilted_volume_as_the_ray_caster_does():
    volume = tilted(ras_volume(), 35.0)
    camera = DEFAULT_CAMERA.viewed_from("anterior")
    want = render(volume, camera, early_termination=1.0)
    network = ray_caster_network(volume, camera, "BrickedRayCaster", transfer_function="auto",
                                 shading="blinn_phong", brick_size=8, lod_bias=-16.0)
    np.testing.assert_allclose(network.evaluate("rc.image", size=SIZE), want, atol=2e-3)


def test_a_turned_brick_store_is_drawn_as_the_same_volume_in_memory():
    volume = tilted(ras_volume(), 35.0)
    bricked = BrickedVolume(ArrayPyramid(volume.data, volume.spacing, volume.origin, brick=(8, 8, 8)),
                            direction=volume.direction)
    camera = DEFAULT_CAMERA.viewed_from("left")
    np.testing.assert_allclose(render(bricked, camera), render(volume, camera), atol=2e-3)


def test_a_mirrored_brick_store_is_refused_by_name():
    volume = stored(ras_volume(), (0, 1, 2), (-1, 1, 1))
    bricked = BrickedVolume(ArrayPyramid(volume.data, volume.spacing, volume.origin, brick=(8, 8, 8),
                                         source="mirrored.zarr"), direction=volume.direction)
    with pytest.raises(VGraphError, match=r"mirrored\.zarr: its axes are mirrored.*vgraph convert"):
        render(bricked, DEFAULT_CAMERA)
