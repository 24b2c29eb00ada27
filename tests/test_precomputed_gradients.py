"""RayCaster derivatives = precomputed: the gradient volume (central differences at the voxels,
RGBA16 with the value in alpha, one fetch a shaded sample) against numpy and the CPU reference's
Shading(gradients="precomputed"), its cache, and that nothing builds it unless a frame is shaded
with it."""

import gc
import weakref

import moderngl
import numpy as np
import pytest

from vgraph.camera import Camera
from vgraph.gl_context import get_context
from vgraph.gl.raycasting import gradient_volume
from vgraph.gl.raycasting.gradient_volume import gradient_texture, holds_values, is_cached
from vgraph.gl.shaders import compose
from vgraph.implicit import sample
from vgraph.numerics.reference_raycast import Shading, VolumeSampler, lookup, render, shade_points, volume_box
from vgraph.numerics.reference_sampling import GRADIENT_STEPS, central_differences, quantized_gradients
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import rendering_network

# Max |GL - reference| per channel with the quantised reference, measured on llvmpipe: 2.1e-6
# (dvr, uint8 torus), 1.1e-6 (iso hits); the tolerance is a few times that.
PRECOMPUTED_TOLERANCE = 1e-5
COLOURED = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.45, 0.2, 0.4, 0.9, 0.0),
                                    (0.55, 1.0, 0.7, 0.2, 0.5), (1.0, 1, 1, 1, 0.8)])
SIZE = (56, 44)
BACKGROUND = (0.1, 0.2, 0.3, 1.0)


def oblique_camera(volume):
    return Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))


def anisotropic_torus_with_nan():
    volume = sample("torus", 20, "float32")
    data = volume.data.copy()
    data[3, 4, 5] = np.nan  # uploaded (and differentiated) as the range's low end
    return Volume(data, spacing=(0.1, 0.1, 0.05), origin=(-1.0, -1.0, -0.5),
                  declared_range=volume.value_range)


VOLUMES = {"torus float32": lambda: sample("torus", 32, "float32"),
           "torus uint8": lambda: sample("torus", 24, "uint8"),
           "sphere uint8": lambda: sample("sphere", 24, "uint8"),
           "anisotropic with NaN": anisotropic_torus_with_nan}


def numpy_gradients(volume):
    """(nz, ny, nx, 3) central differences with edge values beyond the faces, by np.gradient."""
    lo, hi = volume.value_range
    values = volume.normalized(np.nan_to_num(volume.data.astype(np.float64), nan=lo, posinf=hi, neginf=lo))
    hx, hy, hz = volume.spacing
    gz, gy, gx = np.gradient(np.pad(values, 1, mode="edge"), hz, hy, hx)
    inner = (slice(1, -1),) * 3
    return np.stack([gx[inner], gy[inner], gz[inner]], axis=-1)


def texels(texture, volume):
    nx, ny, nz = volume.dims
    return np.frombuffer(texture.read(alignment=1), dtype=np.uint16).reshape(nz, ny, nx, 4)


# --- the texture ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(VOLUMES))
def test_texture_holds_the_central_differences_in_16_bit_steps(name, monkeypatch):
    volume = VOLUMES[name]()
    monkeypatch.setattr(gradient_volume, "SLAB_VOXELS", 1500)  # several slabs, uneven last one
    texture, scale = gradient_texture(get_context(), volume)
    stored = texels(texture, volume)
    steps = stored[..., :3].astype(np.int64) - GRADIENT_STEPS  # 32767 + steps
    expected = numpy_gradients(volume)
    np.testing.assert_array_equal(scale, np.abs(expected).reshape(-1, 3).max(axis=0))
    assert np.abs(steps).max() == GRADIENT_STEPS
    # Rounded to the nearest step of scale / 32767 (up to float64 rounding of the quotient).
    error = np.abs(steps * (scale / GRADIENT_STEPS) - expected)
    assert np.all(error <= scale / (2 * GRADIENT_STEPS) * (1 + 1e-9))
    # Bit for bit the reference's steps (Shading(gradients="precomputed")).
    normalised = VolumeSampler(volume).flat.reshape(volume.data.shape)
    reference = central_differences(np.pad(normalised, 1, mode="edge"), volume.spacing)
    np.testing.assert_array_equal(steps, quantized_gradients(reference, scale))
    # Alpha: the volume texture's own texels where that texture is R16 (8-bit: value * 257).
    values = volume.data.astype(np.uint16) * 257 if volume.data.dtype == np.uint8 else 0
    np.testing.assert_array_equal(stored[..., 3], values)
    assert holds_values(volume) == (volume.data.dtype == np.uint8)
    assert texture.dtype == "nu2" and texture.components == 4  # 8 bytes a voxel


def test_the_shader_reads_value_and_signed_gradient_in_one_fetch(tmp_path):
    """gradients.glsl's decoding of the texels (negative gradients included) and the value in
    alpha, at the voxel centres of a row along x."""
    ctx = get_context()
    volume = Volume(np.array([[[0, 255, 64, 0]]], dtype=np.uint8))
    texture, scale = gradient_texture(ctx, volume)
    probe = tmp_path / "probe.frag.glsl"
    probe.write_text('#version 330\n#include "raycasting/volume_sampling.glsl"\n'
                     '#include "raycasting/gradients.glsl"\nout vec4 c;\nvoid main() {\n'
                     '    vec3 t = vec3((floor(gl_FragCoord.x) + 0.5) / 4.0, 0.5, 0.5);\n'
                     '    vec4 texel = shading_texel(t);\n'
                     '    c = vec4(texel_gradient(t, texel), texel.a);\n}\n')
    source = compose(str(probe), {"GRADIENT_PRECOMPUTED": True, "GRADIENT_HOLDS_VALUE": True})
    program = ctx.program(
        vertex_shader="#version 330\nin vec2 p; void main() { gl_Position = vec4(p, 0.0, 1.0); }",
        fragment_shader=source.text)
    target = ctx.simple_framebuffer((4, 1), components=4, dtype="f4")
    triangle = ctx.buffer(np.array([-1, -1, 3, -1, -1, 3], dtype="f4").tobytes())
    target.use()
    texture.use(0)
    program["gradients"] = 0
    program["gradient_scale"] = tuple(float(v) for v in scale)
    ctx.vertex_array(program, [(triangle, "2f", "p")]).render(moderngl.TRIANGLES)
    read = np.frombuffer(target.read(components=4, dtype="f4"), dtype=np.float32).reshape(4, 4)
    exact = np.array([0.5, 64 / 510, -0.5, -64 / 510])  # (F[i + 1] - F[i - 1]) / 2, edges repeated
    stored = np.rint(exact / scale[0] * GRADIENT_STEPS) * scale[0] / GRADIENT_STEPS
    assert np.abs(stored - exact).max() > 1e-6  # 64 / 510 is not a whole number of steps
    np.testing.assert_allclose(read[:, 0], stored, atol=1e-7)
    np.testing.assert_array_equal(read[:, 1:3], 0.0)
    np.testing.assert_allclose(read[:, 3], np.array([0, 255, 64, 0]) / 255, atol=1e-7)


def test_texture_is_cached_per_volume_and_released_with_it():
    ctx = get_context()
    volume = sample("sphere", 16, "float32")
    texture, _ = gradient_texture(ctx, volume)
    assert gradient_texture(ctx, volume)[0] is texture and is_cached(volume)
    alive = weakref.ref(volume)
    del volume
    gc.collect()
    assert alive() is None and isinstance(texture.mglo, moderngl.InvalidObject)


def test_large_volumes_show_progress_on_stderr(monkeypatch, capsys):
    monkeypatch.setattr(gradient_volume, "PROGRESS_VOXELS", 1000)
    gradient_texture(get_context(), sample("sphere", 16, "float32"))
    captured = capsys.readouterr()
    assert "gradients" in captured.err and captured.out == ""


# --- the reference ----------------------------------------------------------------------------
def test_unquantised_voxel_gradients_equal_the_on_the_fly_central_differences():
    """Trilinear interpolation commutes with whole-voxel shifts and edge padding is clamping:
    inside the box the two models are one (reference rule 6)."""
    volume = anisotropic_torus_with_nan()
    sampler = VolumeSampler(volume)
    lo, hi = volume_box(volume)
    points = lo + np.random.default_rng(4).random((4000, 3)) * (hi - lo)
    central = sampler.gradient(points)
    np.testing.assert_allclose(sampler.voxel_gradient(points, quantized=False), central, atol=1e-12)
    steps = np.abs(sampler.voxel_gradient(points) - central).max(axis=0)
    assert np.all(steps > 0) and np.all(steps <= np.abs(numpy_gradients(volume)).reshape(-1, 3).max(0) / 65534)


def test_reference_refuses_an_unknown_gradient_mode():
    from vgraph.errors import VGraphError
    volume = sample("sphere", 16, "float32")
    with pytest.raises(VGraphError, match="gradients must be one of"):
        render(volume, oblique_camera(volume), COLOURED, (4, 4), shading=Shading(gradients="sobel"))


# --- images against the reference --------------------------------------------------------------
@pytest.mark.parametrize("name", list(VOLUMES))
def test_shaded_dvr_matches_the_reference(name):
    volume = VOLUMES[name]()
    camera = oblique_camera(volume)
    network = rendering_network(volume, camera, transfer_function=COLOURED, shading="blinn_phong",
                                derivatives="precomputed", background=BACKGROUND)
    gl = network.evaluate("rc.image", size=SIZE)
    reference = render(volume, camera, COLOURED, SIZE, shading=Shading(gradients="precomputed"),
                       background=BACKGROUND)
    assert np.abs(reference - reference[0, 0]).max() > 0.3  # the object is in the picture
    np.testing.assert_allclose(gl, reference, atol=PRECOMPUTED_TOLERANCE)
    assert network["rc"].passes[-1][1]["GRADIENT_PRECOMPUTED"]


@pytest.mark.parametrize("name", ["torus float32", "sphere uint8"])
def test_shaded_iso_surface_matches_the_reference_at_its_hits(name):
    """The reference has no iso mode: it shades the GL's hit points (from the depth output) with
    TF(level).rgb, so this checks the shading of the surface, not the search for it."""
    volume = VOLUMES[name]()
    network = rendering_network(volume, oblique_camera(volume), compositing="iso", iso_level=0.5,
                                transfer_function=COLOURED, shading="blinn_phong",
                                derivatives="precomputed")
    image = network.evaluate("rc.image", size=SIZE)
    depth = network.evaluate("rc.depth", size=SIZE)
    origins, directions = network["rc"].view_camera.rays(*SIZE)
    hit = depth[..., 3] > 0
    assert hit.sum() > 100
    points = origins[hit] + depth[..., 1][hit][:, None].astype(np.float64) * directions[hit]
    colour = lookup(COLOURED.for_volume(volume).lut().astype(np.float64), np.array([0.5]))[0, :3]
    expected = shade_points(volume, Shading(gradients="precomputed"), points, directions[hit],
                            np.broadcast_to(colour, (len(points), 3)))
    assert np.ptp(expected[:, 0]) > 0.3  # lit and unlit parts of the surface
    np.testing.assert_allclose(image[hit][:, :3], expected, atol=PRECOMPUTED_TOLERANCE)


# --- built only when used -----------------------------------------------------------------------
@pytest.mark.parametrize("changes", [dict(shading="none"), dict(compositing="mip"),
                                     dict(compositing="first_hit"), dict(derivatives="central")])
def test_no_gradient_volume_unless_a_shaded_frame_uses_it(changes):
    volume = sample("torus", 16, "float32")
    settings = dict(shading="blinn_phong", derivatives="precomputed", transfer_function=COLOURED)
    network = rendering_network(volume, oblique_camera(volume), **{**settings, **changes})
    network.evaluate("rc.image", size=(16, 12))
    assert not is_cached(volume)
    assert "GRADIENT_PRECOMPUTED" not in network["rc"].passes[-1][1]
    network.set("rc.compositing", "dvr")
    network.set("rc.shading", "blinn_phong")
    network.set("rc.derivatives", "precomputed")
    network.evaluate("rc.image", size=(16, 12))
    assert is_cached(volume)


def test_bricked_frames_use_central_differences():
    """The RayCaster's brick sampling draws precomputed derivatives as central ones (a gradient
    volume of a volume that large is what bricking avoids); the others as they are."""
    from vgraph.bricks.sampling import BrickSampling
    from vgraph.gl.raycasting.light import Gradients
    from vgraph.processors.raycaster import RayCaster
    caster = RayCaster("rc", compositing="iso", shading="blinn_phong", derivatives="precomputed")
    bricks = caster.parts[BrickSampling]
    assert bricks.derivatives() == "central"
    assert caster.parts[Gradients].defines(bricks.derivatives()) == {"GRADIENT_CENTRAL": True}
    caster.set_property("derivatives", "sobel")
    assert bricks.derivatives() == "sobel"


def test_a_store_drawn_brick_by_brick_is_shaded_with_central_differences(tmp_path):
    """End to end: a BrickedVolume over its memory budget, shaded with precomputed derivatives,
    renders as with central ones and builds no gradient volume."""
    pytest.importorskip("zarr")
    from vgraph.io.convert import convert
    from vgraph.bricks.volume import BrickedVolume
    np.save(tmp_path / "v.npy", sample("sphere", 32, "uint16").data)
    convert(tmp_path / "v.npy", tmp_path / "v.zarr", brick=16, progress=False)
    store = BrickedVolume.open(tmp_path / "v.zarr", memory_budget_mb=0.01)
    images = []
    for derivatives in ("precomputed", "central"):
        network = rendering_network(store, oblique_camera(store), compositing="iso", iso_level=0.5,
                                    shading="blinn_phong", derivatives=derivatives)
        images.append(network.evaluate("rc.image", size=(24, 20)))
        assert network["rc"].last_frame  # drawn from bricks: iso in one pass (vgraph.bricks.methods)
        [one_pass] = [p for p in network["rc"].passes if p.shader == "raycasting/raycaster.frag.glsl"]
        assert one_pass.defines.get("GRADIENT_CENTRAL") and one_pass.defines.get("PAGE_LEVELS")
    assert images[0][..., 3].max() == 1.0
    np.testing.assert_array_equal(images[0], images[1])
    assert not is_cached(store)


def test_an_error_flag_left_by_earlier_gl_work_does_not_fail_the_build():
    """PyOpenGL checks glGetError after its calls: a flag someone else left pending (here an
    invalid texture unit, which moderngl does not check) must not be blamed on the gradient
    volume (it failed bench_sample_rate once)."""
    ctx = get_context()
    stray = ctx.texture((4, 4), 4)
    stray.use(location=1 << 20)  # GL_INVALID_ENUM, left pending
    volume = sample("sphere", 16, "float32")
    texture, _ = gradient_texture(ctx, volume)
    assert texture.size == (16, 16, 16)
    stray.release()
