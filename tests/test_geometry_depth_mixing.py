"""Opaque geometry mixed with volume rendering at the right depth (issue #18 item 4): a sphere
mesh inside a constant-density fog is dimmed by the fog in front of it and hides the fog behind
it. GeometryRenderer -> GeometryEntryExit -> RayCaster -> ImageCompositor against the analytic
law T = exp(-tau * L), L the path from the entry into the box to the analytic sphere."""

import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.geometry import Geometry
from vgraph.network import Network
from vgraph.testing import GivenVolume
from vgraph.volume import Volume

from helpers.geometry import GivenGeometry

SIZE = (72, 60)
ALPHA = 0.02           # opacity of one fog sample at sampling rate 1 (one step of min spacing)
FOG, SURFACE = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)  # blue fog, red sphere: red is the transmittance
SPACING, ORIGIN, DIMS = (0.05, 0.04, 0.06), (-0.6, 0.3, 1.0), (25, 31, 21)


def fog_volume() -> Volume:
    return Volume(np.full(DIMS[::-1], 0.5, np.float32), spacing=SPACING, origin=ORIGIN)


def fog_tf() -> dict:
    return {"points": [[0.0, *FOG, ALPHA], [1.0, *FOG, ALPHA]]}


def box() -> tuple[np.ndarray, np.ndarray]:
    low = np.array(ORIGIN)
    return low, low + (np.array(DIMS) - 1) * np.array(SPACING)


def camera() -> Camera:
    low, high = box()
    return Camera.looking_at_box(low, high, direction=(-0.3, -0.4, -1.0))


def fog_network(volume: Volume, view: Camera, mixed: bool = False) -> Network:
    """EntryExitPoints -> RayCaster of the fog; ``mixed``: the rays pass GeometryEntryExit first."""
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("EntryExitPoints", id="eep", camera=view)
    network.add("RayCaster", id="rc", transfer_function=fog_tf(), early_termination=1.0)
    network.link("eep.camera", "rc.camera")
    rays = "gee" if mixed else "eep"
    for source, target in (("src.volume", "eep.volume"), ("src.volume", "rc.volume"),
                           (f"{rays}.entry", "rc.entry"), (f"{rays}.exit", "rc.exit")):
        if not (mixed and source.startswith("gee")):
            network.connect(source, target)
    return network


def mixing_network(volume: Volume, geometry: Geometry, view: Camera) -> Network:
    """The fog network with the sphere: its depth cuts the rays, the fog goes over its image."""
    network = fog_network(volume, view, mixed=True)
    network.set("rc.background", (0.0, 0.0, 0.0, 0.0))
    network.add(GivenGeometry(id="mesh", geometry=geometry))
    network.add("GeometryRenderer", id="gr", shading="none", color=(*SURFACE, 1.0))
    network.add("GeometryEntryExit", id="gee")
    network.add("ImageCompositor", id="mix")
    for follower in ("gr.camera", "gee.camera"):
        network.link("eep.camera", follower)
    for source, target in (("mesh.geometry", "gr.geometry"), ("src.volume", "gr.volume"),
                           ("src.volume", "gee.volume"), ("eep.entry", "gee.entry"),
                           ("eep.exit", "gee.exit"), ("gr.depth", "gee.depth"),
                           ("gee.entry", "rc.entry"), ("gee.exit", "rc.exit"),
                           ("rc.image", "mix.front"), ("gr.image", "mix.back")):
        network.connect(source, target)
    return network


def analytic(view: Camera, centre, radius):
    """Per pixel: the ray's entry and exit distances in the box (inf where it misses) and its
    distance to the sphere (inf where it misses), from the near-plane start of Camera.rays."""
    origins, directions = view.rays(*SIZE)
    low, high = box()
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (low - origins) / directions, (high - origins) / directions
    near_t = np.maximum(np.minimum(t0, t1).max(axis=-1), 0.0)
    far_t = np.maximum(t0, t1).min(axis=-1)
    entry = np.where(near_t < far_t, near_t, np.inf)
    offset = origins - np.asarray(centre)
    b = np.einsum("ijk,ijk->ij", offset, directions)
    disc = b * b - (np.einsum("ijk,ijk->ij", offset, offset) - radius ** 2)
    sphere = np.where(disc > 0.0, -b - np.sqrt(np.maximum(disc, 0.0)), np.inf)
    # how close each ray passes the silhouette, as a fraction of the radius (tessellation band)
    rim = np.sqrt(np.maximum(disc, 0.0)) / radius
    return entry, far_t, sphere, rim


@pytest.fixture
def view(gl):
    # stored: both networks see the same view; the near plane is moved closer than the automatic
    # one (which encloses the volume only) so that a sphere sticking out of the box is not cut
    resolved = camera().resolved(*box(), SIZE[0] / SIZE[1])
    return Camera(**{**resolved.model_dump(), "near": resolved.near * 0.5})


def tau() -> float:
    """Extinction per world unit of the fog: ALPHA per step of the smallest spacing."""
    return -np.log(1.0 - ALPHA) / min(SPACING)


def test_a_sphere_inside_fog_is_dimmed_by_the_fog_in_front_and_hides_the_fog_behind(view):
    low, high = box()
    centre, radius = (low + high) / 2, 0.3 * float((high - low).min())
    volume, sphere = fog_volume(), Geometry.sphere((low + high) / 2, radius, subdivisions=5)
    network = mixing_network(volume, sphere, view)
    image, front = (network.evaluate(target, size=SIZE) for target in ("mix.image", "rc.image"))
    fog_alone = fog_network(volume, view).evaluate("rc.image", size=SIZE)
    entry, exit_t, hit, rim = analytic(view, centre, radius)

    on_sphere = np.isfinite(hit) & (rim > 0.2)  # away from the tessellated silhouette
    assert on_sphere.sum() > 200
    transmitted = np.exp(-tau() * (hit[on_sphere] - entry[on_sphere]))
    # T from the picture: red is the sphere seen through the fog, and the fog's own alpha agrees
    np.testing.assert_allclose(image[..., 0][on_sphere], transmitted, atol=ALPHA + 2e-3)
    # ... and exactly the ray caster's discrete law: one sample each step from the entry point up
    # to the sphere (floor(L / step) + 1 samples), wherever L is not close to a whole step
    steps = (hit[on_sphere] - entry[on_sphere]) / min(SPACING)
    clear_count = np.abs(steps - np.round(steps)) > 0.05
    discrete = (1.0 - ALPHA) ** (np.floor(steps + 1e-3) + 1)
    np.testing.assert_allclose(image[..., 0][on_sphere][clear_count], discrete[clear_count], atol=1e-5)
    np.testing.assert_allclose(1.0 - front[..., 3][on_sphere], image[..., 0][on_sphere], atol=1e-5)
    np.testing.assert_allclose(image[..., 2][on_sphere], 1.0 - image[..., 0][on_sphere], atol=1e-5)
    # the fog behind the sphere is hidden: less fog than along the whole ray through the box
    assert np.all(front[..., 3][on_sphere] < 1.0 - np.exp(-tau() * (exit_t - entry))[on_sphere] - 0.05)

    far_off = ~np.isfinite(analytic(view, centre, radius * 1.05)[2])
    np.testing.assert_allclose(image[far_off], fog_alone[far_off], atol=1e-6)


def test_geometry_in_front_of_the_volume_empties_the_ray(view):
    """A sphere sticking out of the box's front: where it is nearer than the entry point the
    pixel is the sphere's colour alone; where it is inside, the fog in front dims it."""
    low, high = box()
    radius = 0.35 * float((high - low).min())
    toward_eye = np.asarray(view.position) - (low + high) / 2
    centre = (low + high) / 2 + toward_eye / np.linalg.norm(toward_eye) * 0.45 * float(np.linalg.norm(high - low))
    sphere = Geometry.sphere(centre, radius, subdivisions=5)
    image = mixing_network(fog_volume(), sphere, view).evaluate("mix.image", size=SIZE)
    entry, _, hit, rim = analytic(view, centre, radius)
    clear = np.isfinite(hit) & (hit < entry - 0.01) & (rim > 0.2)
    assert clear.sum() > 50
    np.testing.assert_allclose(image[clear], [[*SURFACE, 1.0]] * int(clear.sum()), atol=1e-6)
    dimmed = np.isfinite(hit) & np.isfinite(entry) & (hit > entry + 0.05) & (rim > 0.2)
    if dimmed.any():
        np.testing.assert_allclose(image[..., 0][dimmed], np.exp(-tau() * (hit - entry))[dimmed],
                                   atol=ALPHA + 2e-3)


def test_images_of_different_sizes_are_refused(gl):
    network = Network()
    from vgraph.image import Image
    network.add("ImageCompositor", id="mix")
    with pytest.raises(Exception, match="one size"):
        network.processors["mix"].process(Image.empty(gl, (8, 8)), Image.empty(gl, (8, 9)))


def test_the_head_example_shows_skin_mesh_and_bone_volume_from_the_cli(tmp_path):
    """networks/head_skin_mesh_bone_volume.json: the skin mesh (cut at x = 100) covers one side
    of the face, the bone volume shows on the other, over a black background."""
    from vgraph.cli import main
    from helpers.paths import DATA, REPO
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    out = tmp_path / "head.npy"
    assert main(["run", str(REPO / "networks" / "head_skin_mesh_bone_volume.json"), "--size", "96x96",
                 "--data", str(out), "-o", str(tmp_path / "head.png")]) == 0
    image = np.load(out)
    skin = (image[..., 0] > image[..., 2] + 0.1) & (image[..., 3] == 1.0)  # the mesh's skin colour
    bone = (np.abs(image[..., 0] - image[..., 2]) < 0.12) & (image[..., :3].min(axis=-1) > 0.3)  # whitish
    assert skin.sum() > 200 and bone.sum() > 500
    # the camera looks from +x: the bone (skin cut away there) is left, the skin right of it
    assert np.mean(np.nonzero(bone)[1]) < np.mean(np.nonzero(skin)[1])
    np.testing.assert_allclose(image[[0, 0, -1, -1], [0, -1, 0, -1], :3], 0.0, atol=1e-6)


def test_the_head_example_renders_in_the_window_as_on_the_cli(window, data_dir):
    """The GUI's render process draws the skin mesh and bone volume as `vgraph run` does."""
    from helpers.gui import open_and_compare_with_run
    from helpers.paths import REPO
    open_and_compare_with_run(window, REPO / "networks" / "head_skin_mesh_bone_volume.json")
    network = window.workspace.network
    assert all(network.get(f"{pid}.camera") == network.get("eep.camera")
               for pid in ("skin_renderer", "cut_rays", "bone"))
