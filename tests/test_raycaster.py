"""RayCaster: images against the CPU reference ray caster and closed-form answers (MIP = max over
z, average = mean over z, opaque TF = one sample, iso depth = the sphere), opacity correction,
anisotropic spacing, a camera inside the volume, shading formulas, and recompiles only when the
define set changes."""

import numpy as np
import pytest

from vgraph import ProcessorError
from vgraph.camera import Camera
from vgraph.gl.shaders import programs
from vgraph.implicit import sample
from vgraph.numerics.reference_raycast import Shading, VolumeSampler, render, volume_box
from vgraph.scheduler import BlankImageWarning
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import rendering_network
from helpers.raycaster import COLOURED, IDENTITY, REFERENCE_TOLERANCE, SIZE, oblique_camera


def constant_tf(rgb, alpha):
    return TransferFunction(points=[(0.0, *rgb, alpha), (1.0, *rgb, alpha)])


def aligned_volume(seed=0, shape=(9, 6, 10), dtype=np.float32):
    data = np.random.default_rng(seed).random(shape).astype(dtype)
    return Volume(data, spacing=(0.8, 0.8, 0.4), origin=(1.0, -2.0, 3.0))


def aligned_camera(volume):
    """Orthographic, looking down -z, pixel centres on voxel centres: image (row, col) shows voxel
    column (x = col, y = ny - 1 - row); steps of the smallest spacing (z) land on slices."""
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    return Camera(projection="orthographic", position=(centre[0], centre[1], hi[2] + 5.0),
                  focus=tuple(centre), near=1.0, far=50.0,
                  parallel_scale=volume.dims[1] * volume.spacing[1] / 2)


def render_gl(volume, camera, size=SIZE, output="image", **properties):
    network = rendering_network(volume, camera, **properties)
    return network.evaluate(f"rc.{output}", size=size)


@pytest.fixture(scope="module")
def torus():
    return sample("torus", 32, "float32")


# --- against the CPU reference ------------------------------------------------------------------
@pytest.mark.parametrize("mode, rate, shaded", [("dvr", 1.0, False), ("dvr", 2.5, False),
                                                ("dvr", 1.0, True), ("mip", 1.0, False),
                                                ("mip", 0.5, False)])
def test_matches_the_cpu_reference(torus, mode, rate, shaded):
    camera = oblique_camera(torus)
    gl = render_gl(torus, camera, compositing=mode, sampling_rate=rate, transfer_function=COLOURED,
                   shading="blinn_phong" if shaded else "none", background=(0.1, 0.2, 0.3, 1.0))
    reference = render(torus, camera, COLOURED, SIZE, mode=mode, sampling_rate=rate,
                       shading=Shading() if shaded else None, background=(0.1, 0.2, 0.3, 1.0))
    assert np.abs(reference - reference[0, 0]).max() > 0.3  # the torus is in the picture
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


@pytest.mark.parametrize("data_type", ["uint8", "uint16"])
def test_integer_volumes_match_the_reference(data_type):
    """uint8 is sampled from an R16 copy: with llvmpipe's 8-bit filter weights this would fail."""
    volume = sample("sphere", 24, data_type)
    camera = oblique_camera(volume)
    gl = render_gl(volume, camera, transfer_function=COLOURED)
    np.testing.assert_allclose(gl, render(volume, camera, COLOURED, SIZE), atol=REFERENCE_TOLERANCE)


def test_camera_inside_the_volume_still_renders(torus):
    camera = Camera(position=(0.0, -0.1, 0.85), focus=(0.4, 0.0, 0.0), near=0.01, far=10.0, fov=70)
    tf = TransferFunction(points=[(0.0, 0.2, 0.3, 0.9, 0.05), (0.5, 1.0, 0.6, 0.2, 0.3),
                                  (1.0, 1.0, 1.0, 1.0, 0.6)])
    gl = render_gl(torus, camera, transfer_function=tf)
    reference = render(torus, camera, tf, SIZE)
    assert np.all(gl[..., 3] > 0.5)  # every ray starts inside and gathers opacity
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


# --- closed-form answers ------------------------------------------------------------------------
def test_orthographic_mip_equals_the_maximum_over_z():
    volume = aligned_volume()
    nx, ny, _ = volume.dims
    image = render_gl(volume, aligned_camera(volume), (nx, ny), compositing="mip",
                      transfer_function=IDENTITY)
    expected = volume.normalized(volume.data).max(axis=0)[::-1, :]  # row 0 = largest y
    for channel in range(3):
        np.testing.assert_allclose(image[..., channel], expected, atol=1e-5)


def test_orthographic_xray_equals_the_mean_over_z():
    volume = aligned_volume(seed=3)
    nx, ny, _ = volume.dims
    image = render_gl(volume, aligned_camera(volume), (nx, ny), compositing="xray",
                      transfer_function=IDENTITY)
    expected = volume.normalized(volume.data).mean(axis=0)[::-1, :]
    np.testing.assert_allclose(image[..., 0], expected, atol=1e-5)


@pytest.mark.parametrize("skipping", [True, False])
def test_opaque_tf_stops_each_ray_after_its_first_sample(skipping):
    volume = aligned_volume(seed=1)
    nx, ny, _ = volume.dims
    network = rendering_network(volume, aligned_camera(volume), transfer_function=IDENTITY,
                                empty_space_skipping=skipping)
    image = network.evaluate("rc.image", size=(nx, ny))
    depth = network.evaluate("rc.depth", size=(nx, ny))
    assert np.all(depth[..., 2] == 1.0)  # the sample counter
    front_slice = volume.normalized(volume.data[-1])[::-1, :]  # the entry face, z = max
    np.testing.assert_allclose(image[..., 0], front_slice, atol=1e-5)
    # Depth of the first sample: 5 - 1 world units from the near plane (camera 5 above the box).
    np.testing.assert_allclose(depth[..., 1], 4.0, atol=1e-5)
    assert np.all(depth[..., 3] == 1.0)


def test_transparent_tf_takes_every_sample():
    volume = aligned_volume()
    nx, ny, nz = volume.dims
    depth = render_gl(volume, aligned_camera(volume), (nx, ny), output="depth", sampling_rate=2.0,
                      transfer_function=constant_tf((1, 1, 1), 0.0), empty_space_skipping=False)
    assert np.all(depth[..., 2] == (nz - 1) * 2 + 1)
    assert np.all(depth[..., 3] == 0.0) and np.all(depth[..., 0] == 1.0)  # no depth sample


def test_sampling_rate_keeps_the_brightness(torus):
    """Opacity correction: a soft TF rendered at rates 0.5 .. 4 keeps its mean brightness."""
    tf = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (0.5, 1, 1, 1, 0.08), (1.0, 1, 1, 1, 0.15)])
    camera = oblique_camera(torus)
    means = [render_gl(torus, camera, sampling_rate=rate, transfer_function=tf)[..., 0].mean()
             for rate in (0.5, 1.0, 2.0, 4.0)]
    assert means[1] > 0.1
    np.testing.assert_allclose(means, means[1], rtol=0.02)
    # Without the correction the brightness would grow with the rate: 1 - 0.92^4 vs 0.08.
    assert abs(means[3] - means[1]) < 0.1 * (means[1] * (1 - 0.92 ** 4) / 0.08 - means[1])


def test_anisotropic_sphere_with_half_the_slices_renders_as_a_sphere():
    """A sphere sampled on 33 x 33 x 33 voxels of spacing 1 and on 33 x 33 x 17 voxels of spacing
    (1, 1, 2): seen from the side (the image's vertical axis is z) both are the same disc."""
    def sphere(nz, dz):
        z, y, x = np.meshgrid(np.arange(nz) * dz, np.arange(33.0), np.arange(33.0), indexing="ij")
        return Volume((12.0 - np.sqrt((x - 16) ** 2 + (y - 16) ** 2 + (z - 16) ** 2)).astype(np.float32),
                      spacing=(1.0, 1.0, dz), declared_range=(-20.0, 20.0))

    camera = Camera(projection="orthographic", position=(16.0, -40.0, 16.0), focus=(16.0, 16.0, 16.0),
                    up=(0.0, 0.0, 1.0), parallel_scale=16.0, near=1.0, far=100.0)
    masks = []
    for volume in (sphere(33, 1.0), sphere(17, 2.0)):
        depth = render_gl(volume, camera, (64, 64), output="depth", compositing="iso",
                          iso_level=0.5)
        masks.append(depth[..., 3] > 0)
    rows, cols = np.nonzero(masks[1])
    assert (rows.max() - rows.min() + 1) / 2 == pytest.approx(24.0, abs=1.0)  # 2 pixels per unit
    assert (cols.max() - cols.min() + 1) / 2 == pytest.approx(24.0, abs=1.0)
    assert np.count_nonzero(masks[0] != masks[1]) <= 0.01 * masks[0].sum()


def test_iso_depth_is_the_distance_to_the_sphere():
    """The refined hit lies on the level set of the trilinear reconstruction (found here by
    bisection on the CPU reference's sampler) and, up to the reconstruction error, on the sphere."""
    volume = sample("sphere", 40, "float32")  # f = 0.7 - |p| on [-1, 1]^3; level 0.5 is f = 0
    camera = Camera(projection="orthographic", position=(0.0, 0.0, 5.0), focus=(0.0, 0.0, 0.0),
                    parallel_scale=1.0, near=1.0, far=10.0)
    depth = render_gl(volume, camera, (48, 48), output="depth", compositing="iso", iso_level=0.5)
    origins, directions = camera.rays(48, 48)
    r2 = origins[..., 0] ** 2 + origins[..., 1] ** 2
    inside = r2 < 0.6 ** 2  # away from the silhouette, where the surface is grazed
    assert np.all(depth[..., 3][inside] == 1.0)
    assert np.all(depth[..., 3][r2 > 0.72 ** 2] == 0.0)
    sphere = origins[..., 2] - np.sqrt(np.maximum(0.7 ** 2 - r2, 0.0))
    np.testing.assert_allclose(depth[..., 1][inside], sphere[inside], atol=3e-3)
    sampler = VolumeSampler(volume)
    lo, hi = np.full(inside.sum(), 3.0), np.full(inside.sum(), 4.0)  # f(lo) < 0.5 <= f(hi)
    points = lambda t: origins[inside] + t[:, None] * directions[inside]
    for _ in range(40):
        middle = (lo + hi) / 2
        below = sampler(points(middle)) < 0.5
        lo, hi = np.where(below, middle, lo), np.where(below, hi, middle)
    np.testing.assert_allclose(depth[..., 1][inside], lo, atol=1e-5)


def test_first_hit_points_are_entry_points_for_an_opaque_tf(torus):
    camera = oblique_camera(torus)
    network = rendering_network(torus, camera, compositing="first_hit", transfer_function=IDENTITY,
                                background=(0.0, 0.0, 0.0, 0.0))
    image = network.evaluate("rc.image", size=SIZE)
    entry = network.evaluate("eep.entry", size=SIZE)
    np.testing.assert_allclose(image, entry, atol=1e-6)


def test_nearest_interpolation_returns_voxel_values():
    volume = aligned_volume(seed=5)
    nx, ny, _ = volume.dims
    camera = aligned_camera(volume).pan(0.3 / ny, 0.2 / ny)  # pixel centres between voxel centres
    image = render_gl(volume, camera, (nx, ny), compositing="mip", interpolation="nearest",
                      transfer_function=IDENTITY)
    values = np.unique(volume.normalized(volume.data).astype(np.float32))
    hit = image[..., 3] > 0
    nearest = np.abs(image[..., 0][hit][:, None] - values[None, :]).min(axis=1)
    assert hit.sum() > 20 and nearest.max() < 1e-6


# --- shading ----------------------------------------------------------------------------------
LINEAR_GRADIENT = np.array([0.3, -0.2, -0.5])  # per world unit; decreasing towards +z


def linear_volume():
    """f = 0.3 x - 0.2 y - 0.5 z on 21^3 voxels of spacing (0.5, 0.5, 0.25): every difference
    scheme gives the exact gradient. Over x, y in [3, 7] the level f = -0.75 lies at z in
    [0.5, 4.5], so first hits and their stencils stay a voxel away from the volume's faces."""
    z, y, x = np.meshgrid(np.arange(21) * 0.25, np.arange(21) * 0.5, np.arange(21) * 0.5,
                          indexing="ij")
    f = LINEAR_GRADIENT[0] * x + LINEAR_GRADIENT[1] * y + LINEAR_GRADIENT[2] * z
    return Volume(f.astype(np.float32), spacing=(0.5, 0.5, 0.25), declared_range=(-5.0, 5.0))


@pytest.mark.parametrize("derivatives", ["forward", "backward", "central", "sobel"])
@pytest.mark.parametrize("light", ["headlight", "direction"])
def test_blinn_phong_with_every_gradient_matches_the_formula(derivatives, light):
    volume = linear_volume()
    level = (-0.75 + 5.0) / 10.0
    tf = TransferFunction(points=[(0.0, 0.6, 0.5, 0.4, 0.0), (level, 0.6, 0.5, 0.4, 0.0),
                                  (level, 0.6, 0.5, 0.4, 1.0), (1.0, 0.6, 0.5, 0.4, 1.0)])
    camera = Camera(projection="orthographic", position=(5.0, 5.0, 20.0), focus=(5.0, 5.0, 0.0),
                    parallel_scale=3.0, near=1.0, far=40.0)
    light_direction = np.array([0.3, 0.5, 1.0])
    image = render_gl(volume, camera, (24, 24), transfer_function=tf, shading="blinn_phong",
                      derivatives=derivatives, light=light, light_direction=tuple(light_direction),
                      ambient=0.2, diffuse=0.6, specular=0.4, shininess=8.0)
    normal = LINEAR_GRADIENT / np.linalg.norm(LINEAR_GRADIENT)
    view = np.array([0.0, 0.0, 1.0])
    normal = normal if normal @ view >= 0 else -normal
    if light == "headlight":
        lambert = highlight = normal @ view
    else:
        to_light = light_direction / np.linalg.norm(light_direction)
        halfway = (to_light + view) / np.linalg.norm(to_light + view)
        lambert, highlight = max(normal @ to_light, 0.0), max(normal @ halfway, 0.0)
    expected = np.clip((0.2 + 0.6 * lambert) * np.array([0.6, 0.5, 0.4]) + 0.4 * highlight ** 8,
                       0, 1)
    np.testing.assert_allclose(image[4:20, 4:20, :3], np.broadcast_to(expected, (16, 16, 3)),
                               atol=2e-5)


# --- errors and resources ---------------------------------------------------------------------
def test_spline_coefficients_are_refused():
    volume = aligned_volume()
    coefficients = volume.with_data(volume.data, is_spline_coefficients=True)
    with pytest.raises(ProcessorError, match="CubicSplineProcessor"):
        render_gl(coefficients, aligned_camera(volume))


def test_shading_without_a_gradient_names_the_fix(torus):
    with pytest.raises(ProcessorError, match="rc.derivatives to central"):
        render_gl(torus, oblique_camera(torus), shading="blinn_phong", derivatives="none")


def test_unshaded_mip_compiles_no_gradient_or_shading_code(torus):
    network = rendering_network(torus, oblique_camera(torus), compositing="mip", shading="blinn_phong")

    def compiled_defines():
        network.evaluate("rc.image", size=(16, 16))
        return network["rc"].passes[-1][1]  # the ray-casting pass (after the missed fill)
    defines = compiled_defines()
    assert defines["COMPOSITING_MIP"] and not any(
        value for key, value in defines.items() if key.startswith(("GRADIENT", "SHADING")))
    network.set("rc.compositing", "dvr")
    assert compiled_defines()["GRADIENT_CENTRAL"]


def test_recompiles_only_when_the_define_set_changes(torus):
    programs.clear()
    network = rendering_network(torus, oblique_camera(torus), sampling_rate=1.5,
                                transfer_function=COLOURED)

    def compiles(**changes):
        before = programs.compile_count
        for name, value in changes.items():
            network.set(f"rc.{name}", value)
        network.evaluate("rc.image", size=(24, 24))
        return programs.compile_count - before

    # The faces pass of both entry and exit points, the ray caster and the fill of the pixels
    # outside the box's footprint (ray bounds are off by default); the far plane does not cut the
    # box, so the capping pass neither runs nor compiles.
    assert compiles() == 3
    assert compiles(sampling_rate=3.0, early_termination=0.9, background=(1, 1, 1, 1)) == 0
    recoloured = TransferFunction(points=[(p[0], p[3], p[2], p[1], p[4]) for p in COLOURED.points])
    assert compiles(transfer_function=recoloured) == 0
    # A TF with no transparent range leaves no empty space: skipping (a define) is switched off.
    assert compiles(transfer_function=constant_tf((1, 0, 0), 0.2)) == 1
    assert compiles(transfer_function=COLOURED) == 0
    assert compiles(derivatives="sobel", light="direction") == 0  # shading is off: same defines
    assert compiles(camera=oblique_camera(torus).rotate(0.3, 0.1)) == 0
    assert compiles(compositing="mip") == 1
    assert compiles(compositing="dvr") == 0  # cached
    assert compiles(shading="blinn_phong") == 1
    assert compiles(ambient=0.5, shininess=10.0) == 0


def test_outputs_are_reused_while_the_size_stays(torus):
    network = rendering_network(torus, oblique_camera(torus))
    network.evaluate("rc.image", size=(16, 16))
    first = network["rc"].outputs["image"]
    network.set("rc.sampling_rate", 2.0)
    network.evaluate("rc.image", size=(16, 16))
    assert network["rc"].outputs["image"] is first


@pytest.mark.parametrize("mode", ["dvr", "mip", "iso", "first_hit"])
def test_empty_space_skipping_changes_no_pixel(torus, mode):
    camera = oblique_camera(torus)
    images, samples = [], []
    network = rendering_network(torus, camera, compositing=mode, transfer_function=COLOURED)
    for skipping in (True, False):
        network.set("rc.empty_space_skipping", skipping)
        images.append(network.evaluate("rc.image", size=SIZE))
        samples.append(network.evaluate("rc.depth", size=SIZE)[..., 2].sum())
    np.testing.assert_array_equal(images[0], images[1])
    assert samples[0] < samples[1]


def test_block_ranges_cover_each_block_with_a_voxel_of_margin():
    from vgraph.gl.raycasting.empty_space import BLOCK, WALK_BLOCK, block_ranges, occupied_blocks, skip_radii
    ramp = np.arange(30) / 29.0  # along x, so that blocks have different ranges
    data = (ramp + 0.05 * np.random.default_rng(2).random((21, 17, 30))).astype(np.float32)
    data[3, 4, 5], data[20, 16, 0] = np.nan, np.inf  # uploaded as the range's ends
    volume = Volume(data)
    clean = np.nan_to_num(data, nan=volume.value_range[0], posinf=volume.value_range[1])
    for block in (BLOCK, WALK_BLOCK):  # the larger ones reduced from the smaller (odd counts too)
        low, high = block_ranges(volume, block)
        assert low.shape == tuple(-(-n // block) for n in data.shape)
        for index in np.ndindex(low.shape):
            window = clean[tuple(slice(max(b * block - 1, 0), (b + 1) * block + 2) for b in index)]
            assert low[index] == pytest.approx(volume.normalized(window.min()), abs=1e-6)
            assert high[index] == pytest.approx(volume.normalized(window.max()), abs=1e-6)
    low, high = block_ranges(volume)
    alpha = np.zeros(4096, dtype=np.float32)
    alpha[3500:] = 0.5  # only intensities >= 0.855 are visible
    occupied = occupied_blocks(low, high, alpha)
    # LUT entries floor(low * 4095) - 1 .. ceil(high * 4095) + 1 are looked at (one of margin).
    np.testing.assert_array_equal(occupied, np.ceil(high * 4095) + 1 >= 3500)
    assert 0 < occupied.sum() < occupied.size
    radii = skip_radii(np.pad(np.ones((1, 1, 1), bool), 3))  # one occupied block in a 7^3 grid
    assert radii[3, 3, 3] == 0 and radii[3, 3, 4] == 1 and radii[0, 3, 3] == 3 and radii[0, 0, 6] == 3


def test_the_depth_output_is_drawn_only_when_something_reads_it(torus):
    """A scene that shows only the image leaves the depth pass out (no second target, no
    DEPTH_OUTPUT code); asking for the depth later draws it, with the same image."""
    network = rendering_network(torus, oblique_camera(torus), transfer_function=COLOURED)
    image = network.evaluate("rc.image", size=SIZE)
    caster = network["rc"]
    assert caster.outputs.get("depth") is None
    assert not caster.passes[-1][1].get("DEPTH_OUTPUT")
    depth = network.evaluate("rc.depth", size=SIZE)
    assert caster.passes[-1][1]["DEPTH_OUTPUT"] and (depth[..., 3] == 1.0).any()
    np.testing.assert_array_equal(network.evaluate("rc.image", size=SIZE), image)


@pytest.mark.parametrize("compositing", ["dvr", "mip"])
def test_pixels_outside_the_box_footprint_are_not_drawn_yet_come_out_the_same(torus, compositing, monkeypatch):
    """The pass draws only inside the entry image's covered rectangle and clears the rest to what a
    missed ray writes: image and depth are those of drawing every pixel, also with a background."""
    centre = tuple(np.mean(volume_box(torus), axis=0))
    far = Camera(position=(4.0, 3.0, 12.0), focus=centre, near=1.0, far=40.0)
    network = rendering_network(torus, far, transfer_function=COLOURED, compositing=compositing,
                                background=(0.1, 0.2, 0.3, 0.7))
    image, depth = network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)
    x, y, width, height = network.output("eep.entry").covered
    assert 0 < width * height < 0.5 * SIZE[0] * SIZE[1]  # most pixels are not drawn
    monkeypatch.setattr("vgraph.processors.entry_exit_points.footprint", lambda *args: None)
    network["eep"].invalidate()
    np.testing.assert_array_equal(network.evaluate("rc.image", size=SIZE), image)
    np.testing.assert_array_equal(network.evaluate("rc.depth", size=SIZE), depth)
    assert network.output("eep.entry").covered is None


def test_a_crop_box_that_leaves_nothing_shows_the_background(torus):
    network = rendering_network(torus, oblique_camera(torus), transfer_function=COLOURED,
                                background=(0.1, 0.2, 0.3, 0.7))
    network.set("eep.crop_box", (50.0, 50.0, 50.0, 60.0, 60.0, 60.0))
    with pytest.warns(BlankImageWarning):  # the user is told why the picture is empty
        image = network.evaluate("rc.image", size=SIZE)
    depth = network.evaluate("rc.depth", size=SIZE)
    np.testing.assert_array_equal(image, np.broadcast_to(np.float32([0.1, 0.2, 0.3, 0.7]), image.shape))
    np.testing.assert_array_equal(depth, np.broadcast_to(np.float32([1.0, 0.0, 0.0, 0.0]), depth.shape))
