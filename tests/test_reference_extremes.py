"""The exact CPU references at the extremes (issue 30, items 4 and 6): optical depths from 1e-8 to
1e8 and opacities from 1e-9 to 1 - 1e-9 give finite images that agree with closed forms (the
opacity correction against 50-digit decimal arithmetic, segments and whole images against
1 - exp(-depth) and its limits), in a bounded amount of memory (tracemalloc sees numpy's buffers)."""

import math
import tracemalloc
from decimal import Decimal, localcontext

import numpy as np
import pytest
from scipy import integrate

from vgraph.camera import Camera
from vgraph.mesh import TetMesh
from vgraph.numerics import reference_raycast, reference_tetra
from vgraph.numerics.reference_boxes import volume_box
from vgraph.numerics.reference_raycast import corrected_opacity
from vgraph.numerics.reference_tetra import MAX_OPACITY, ray_segments, segment_integral
from vgraph.tetrahedralize import volume_tetrahedra
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

CLEAR = (0.0, 0.0, 0.0, 0.0)
RGB = np.array([0.9, 0.4, 0.1])
OPACITIES = [1e-9, 1e-6, 0.5, 1.0 - 1e-9]
DEPTHS = [1e-8, 1e-3, 1.0, 1e3, 1e8]  # optical depth of a segment or of the thickest ray
FLOAT32_RTOL = 2e-6  # images are float32: a few units in the last place of 2^-24
# Working memory ceilings (tracemalloc peak) of a whole render. Measured: 92 MiB for the tetrahedra
# case below, where the reference before its quadrature stopped at saturation and its rays went in
# bands raised MemoryError at 4.7 GiB (under a 5 GB limit, after 15 s); 4.5 MiB for the ray caster.
TETRA_CEILING_MIB = 200
RAYCAST_CEILING_MIB = 64


def constant_tf(alpha, rgb=RGB):
    return TransferFunction(points=[(0.0, *rgb, alpha), (1.0, *rgb, alpha)])


def exact_correction(alpha: float, exponent: float) -> float:
    """1 - (1 - alpha) ** exponent in 50-digit decimal arithmetic."""
    with localcontext() as context:
        context.prec = 50
        return float(1 - (1 - Decimal(alpha)) ** Decimal(exponent))


# --- the opacity correction ---------------------------------------------------------------------
@pytest.mark.parametrize("alpha", [1e-15, 1e-12, 1e-9, 1e-6, 0.3, 1.0 - 1e-9])
@pytest.mark.parametrize("exponent", [1e-3, 0.5, 3.0, 1e4])
def test_opacity_correction_keeps_every_digit(alpha, exponent):
    """-expm1(x log1p(-a)) to the last digits, where 1 - (1 - a) ** x loses the small opacities
    (a = 1e-12: 1e-4 relative; a = 1e-9: 1e-7)."""
    assert corrected_opacity(np.array([alpha]), exponent)[0] == pytest.approx(
        exact_correction(alpha, exponent), rel=1e-14)


def test_opacity_correction_keeps_zero_one_and_rate_one():
    alphas = np.array([0.0, 1e-9, 0.25, 1.0 - 1e-9, 1.0])
    assert np.array_equal(corrected_opacity(alphas, 1.0), alphas)  # sampling rate 1: as it is
    corrected = corrected_opacity(alphas, 0.37)
    assert corrected[0] == 0.0 and corrected[-1] == 1.0 and np.all(np.isfinite(corrected))


# --- one segment of the tetrahedra reference ----------------------------------------------------
@pytest.mark.parametrize("alpha", OPACITIES)
@pytest.mark.parametrize("depth", DEPTHS)
def test_constant_segment_at_every_depth(alpha, depth):
    """alpha = 1 - exp(-depth) and rgb = c alpha from optical depth 1e-8 to 1e8; an opacity above
    MAX_OPACITY counts as MAX_OPACITY (module docstring, rule 3)."""
    extinction = -math.log1p(-min(alpha, MAX_OPACITY))  # per L
    length = depth / extinction  # L = 1
    result = segment_integral(0.2, 0.8, length, constant_tf(alpha), 1.0)
    expected = -math.expm1(-depth)
    assert np.all(np.isfinite(result))
    assert result[3] == pytest.approx(expected, rel=1e-13)
    np.testing.assert_allclose(result[:3], RGB * expected, rtol=1e-13)


RAMP = TransferFunction(points=[(0.0, 1.0, 0.2, 0.0, 0.2), (1.0, 0.0, 0.4, 1.0, 0.6)])


def test_thin_sloped_segment_is_the_emission_integral():
    """At optical depth ~1e-8 absorption inside the segment is negligible (relative 1e-8): alpha
    and rgb are the integrals of tau and c tau along it (scipy quad)."""
    K = 1e-8 / 0.5  # length / L; the mean extinction per L is about 0.5

    def rgba(u):
        return RAMP(u)

    tau = integrate.quad(lambda u: -math.log1p(-rgba(u)[3]), 0.0, 1.0, epsabs=0, epsrel=1e-13)[0]
    emitted = [integrate.quad(lambda u, c=c: rgba(u)[c] * -math.log1p(-rgba(u)[3]), 0.0, 1.0,
                              epsabs=0, epsrel=1e-13)[0] for c in range(3)]
    result = segment_integral(0.0, 1.0, K, RAMP, 1.0)
    assert result[3] == pytest.approx(K * tau, rel=1e-7)
    np.testing.assert_allclose(result[:3], K * np.array(emitted), rtol=1e-7)


def test_deep_sloped_segment_shows_its_front():
    """At optical depth 1e8 the light comes from within ~1e-8 of the segment's length behind its
    front: rgb is the TF's colour there, alpha is 1."""
    for s_front, s_back in ((0.0, 1.0), (1.0, 0.0), (0.3, 0.7)):
        result = segment_integral(s_front, s_back, 1e8, RAMP, 1.0)
        assert result[3] == 1.0
        np.testing.assert_allclose(result[:3], RAMP(s_front)[:3], atol=1e-7)


def test_a_ramp_from_almost_clear_to_almost_opaque_at_every_depth():
    """Opacities from 1e-9 to 1 - 1e-9 along one segment: finite, alpha = 1 - exp(-tau) with tau
    the integral of the extinction (scipy quad; the TF's point opacities clamped at MAX_OPACITY as
    the model says), premultiplied colours within [0, alpha]."""
    tf = TransferFunction(points=[(0.0, 0.0, 1.0, 0.0, 1e-9), (1.0, 1.0, 0.0, 0.0, 1.0 - 1e-9)])
    clamped = TransferFunction(points=[(0.0, 0.0, 1.0, 0.0, 1e-9), (1.0, 1.0, 0.0, 0.0, MAX_OPACITY)])
    tau = integrate.quad(lambda u: -math.log1p(-clamped(u)[3]), 0.0, 1.0,
                         epsabs=0, epsrel=1e-13, limit=200)[0]
    for depth in DEPTHS:
        K = depth / tau
        result = segment_integral(0.0, 1.0, K, tf, 1.0)
        assert np.all(np.isfinite(result))
        assert result[3] == pytest.approx(-math.expm1(-depth), rel=1e-12)
        assert np.all(result[:3] >= 0.0) and np.all(result[:3] <= result[3] * (1.0 + 1e-12))


# --- whole images of the tetrahedra reference ---------------------------------------------------
def small_mesh(reference_length: float) -> TetMesh:
    """A 10 x 9 x 8 grid of a smooth field cut into tetrahedra (about 3000)."""
    z, y, x = np.mgrid[:8, :9, :10].astype(np.float64)
    data = np.sin(x / 3.0) + np.cos(y / 4.0) + z / 8.0
    points, tets, voxels = volume_tetrahedra(data, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    return TetMesh(points, tets, data.reshape(-1)[voxels], reference_length=reference_length)


CAMERA = Camera(fit_to_data=True).viewed_from("iso")
SIZE = (40, 32)


@pytest.mark.parametrize("alpha", [1e-9, 0.5, 1.0 - 1e-9])
@pytest.mark.parametrize("depth", [1e-8, 1e8])
def test_tetrahedra_image_at_extreme_depth_is_the_closed_form(alpha, depth):
    """A constant TF: every pixel is 1 - exp(-thickness * extinction), its colour c times that,
    with the thickest ray at optical depth 1e-8 or 1e8."""
    thickness = ray_segments(small_mesh(1.0), CAMERA, SIZE).thickness(SIZE)
    extinction_per_l = -math.log1p(-min(alpha, MAX_OPACITY))
    length = thickness.max() * extinction_per_l / depth
    image = reference_tetra.render(small_mesh(length), CAMERA, constant_tf(alpha), SIZE, background=CLEAR)
    expected = -np.expm1(-thickness * extinction_per_l / length)
    assert np.all(np.isfinite(image))
    np.testing.assert_allclose(image[..., 3], expected, rtol=FLOAT32_RTOL, atol=1e-45)
    np.testing.assert_allclose(image[..., :3], RGB * expected[..., None], rtol=FLOAT32_RTOL, atol=1e-45)
    if depth > 1.0:
        assert np.all(image[..., 3][thickness > thickness.max() * 1e-6] == 1.0)


@pytest.mark.parametrize("length", [1e-12, 1e8])
def test_tetrahedra_image_with_a_stiff_tf_at_extreme_depth(length):
    """A spike TF (opacity 1e-9 off the spike, 1 - 1e-9 on it, one hundredth of the range wide) at
    opacity_length 1e-12 (optical depths up to 1e14) and 1e8 (down to 1e-18): finite, alpha
    between the closed forms of the least and the most opaque TF entry over the ray's
    thickness, premultiplied colours within [0, alpha]."""
    tf = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 1e-9), (0.495, 0.1, 0.2, 0.9, 1e-9),
                                  (0.5, 1.0, 0.8, 0.1, 1.0 - 1e-9), (0.505, 0.1, 0.2, 0.9, 1e-9),
                                  (1.0, 0.1, 0.2, 0.9, 1e-9)])
    image = reference_tetra.render(small_mesh(length), CAMERA, tf, SIZE, background=CLEAR)
    thickness = ray_segments(small_mesh(1.0), CAMERA, SIZE).thickness(SIZE).astype(np.float64)
    least = -np.expm1(thickness / length * math.log1p(-1e-9))
    most = -np.expm1(thickness / length * math.log1p(-MAX_OPACITY))
    alpha = image[..., 3]
    assert np.all(np.isfinite(image)) and (thickness > 0.0).any()
    assert np.all(alpha >= least * (1.0 - FLOAT32_RTOL)) and np.all(alpha <= most * (1.0 + FLOAT32_RTOL))
    assert np.all(image[..., :3] >= 0.0) and np.all(image[..., :3] <= image[..., 3:] * (1.0 + 1e-6))
    if length < 1.0:
        assert np.all(alpha[thickness > 0.1] == 1.0)  # optical depth 1e2 and more


def test_bands_of_rows_give_the_same_image_bit_for_bit():
    mesh = small_mesh(0.5)
    tf = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.02), (0.45, 0.9, 0.6, 0.1, 0.2),
                                  (1.0, 1.0, 1.0, 0.3, 0.4)])
    whole, whole_depth = reference_tetra.render(mesh, CAMERA, tf, SIZE, return_depth=True)
    banded, banded_depth = reference_tetra.render(mesh, CAMERA, tf, SIZE, return_depth=True,
                                                  band_pairs=500)
    assert np.array_equal(whole, banded) and np.array_equal(whole_depth, banded_depth)


def traced_peak_mib(render) -> float:
    tracemalloc.start()
    try:
        render()
        return tracemalloc.get_traced_memory()[1] / 2 ** 20
    finally:
        tracemalloc.stop()


def test_tetrahedra_reference_at_extreme_depth_stays_in_bounded_memory():
    """opacity_length 1e-5 on a mesh about 10 units across (optical depths ~1e5 to 1e6 per
    ray): the quadrature stops where the depth saturates and the rays go in bands."""
    tf = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.02), (0.45, 0.9, 0.6, 0.1, 0.2),
                                  (1.0, 1.0, 1.0, 0.3, 0.4)])
    mesh = small_mesh(1e-5)
    peak = traced_peak_mib(lambda: reference_tetra.render(mesh, CAMERA, tf, (96, 96)))
    assert peak < TETRA_CEILING_MIB, f"{peak:.0f} MiB"


# --- the reference ray caster -------------------------------------------------------------------
def uniform_volume():
    return Volume(np.full((12, 10, 16), 0.5, dtype=np.float32), declared_range=(0.0, 1.0))


@pytest.mark.parametrize("alpha", [1e-9, 0.5, 1.0 - 1e-9])
@pytest.mark.parametrize("rate", [1e-3, 0.5, 1.0, 16.0])
def test_ray_caster_at_extreme_opacities_is_the_closed_form(alpha, rate):
    """A constant TF over a uniform volume, every sample taken: alpha = 1 - (1 - a)^(n / rate) with
    a the float32 LUT's opacity (1 - 1e-9 is 1 there) and n the samples of the ray."""
    image, samples = reference_raycast.render(uniform_volume(), CAMERA, constant_tf(alpha), SIZE,
                                              sampling_rate=rate, early_termination=1.0,
                                              background=CLEAR, return_samples=True)
    a = float(np.float32(alpha))
    with np.errstate(divide="ignore"):
        expected = -np.expm1(samples / rate * math.log1p(-a)) if a < 1.0 else (samples > 0) * 1.0
    rgb = np.asarray(constant_tf(alpha).lut()[0, :3], dtype=np.float64)
    assert np.all(np.isfinite(image)) and samples.max() > 0
    np.testing.assert_allclose(image[..., 3], expected, rtol=FLOAT32_RTOL, atol=1e-45)
    np.testing.assert_allclose(image[..., :3], rgb * expected[..., None], rtol=FLOAT32_RTOL, atol=1e-45)


def test_ray_caster_reference_at_a_high_sampling_rate_stays_in_bounded_memory():
    """Sampling rate 64 (about 1500 samples per ray) over 128 x 128 rays: marched in chunks of rays,
    the working memory does not grow with the samples."""
    peak = traced_peak_mib(lambda: reference_raycast.render(
        uniform_volume(), CAMERA, constant_tf(1e-9), (128, 128), sampling_rate=64.0,
        early_termination=1.0))
    assert peak < RAYCAST_CEILING_MIB, f"{peak:.0f} MiB"



def test_chunks_of_rays_give_the_same_image_bit_for_bit():
    """The ray caster and multi-volume references march chunk_rays rays at a time: any chunk size
    gives the same picture."""
    from vgraph.numerics.multivolume_reference import render_channels

    z, y, x = np.mgrid[:12, :10, :16] / 10.0
    volume = Volume((np.sin(3 * x) * np.cos(2 * y) + z).astype(np.float32))
    moved = Volume(volume.data[::-1].copy(), origin=(2.0, 1.0, 0.0))
    tf = TransferFunction(points=[(0.0, 0.1, 0.2, 0.9, 0.0), (0.5, 0.9, 0.6, 0.1, 0.3),
                                  (1.0, 1.0, 1.0, 0.3, 0.8)])
    for rate in (0.7, 2.0):
        whole = reference_raycast.render(volume, CAMERA, tf, SIZE, sampling_rate=rate)
        assert np.array_equal(whole, reference_raycast.render(volume, CAMERA, tf, SIZE, sampling_rate=rate,
                                                              chunk_rays=97))
        whole = render_channels([(volume, tf), (moved, tf)], CAMERA, SIZE, sampling_rate=rate)
        assert np.array_equal(whole, render_channels([(volume, tf), (moved, tf)], CAMERA, SIZE,
                                                     sampling_rate=rate, chunk_rays=97))

# --- the GL side: the stable opacity arithmetic (shaders/raycasting/opacity.glsl) ----------------
OPACITY_PROBE = """#version 430
#include "raycasting/opacity.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Inputs { vec2 inputs[]; };
layout(std430, binding = 1) writeonly buffer Outputs { vec4 outputs[]; };
uniform uint count;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    float a = inputs[i].x, x = inputs[i].y;
    outputs[i] = vec4(corrected_alpha(a, x), 1.0 - exp2(x * log2(1.0 - a)),
                      opacity_of_depth(a), 1.0 - exp(-a));
}
"""
SMALL_OPACITY = 1.0 / 64.0  # shaders/raycasting/opacity.glsl
GL_RELATIVE_TOLERANCE = 1e-6  # of the stable forms; measured on llvmpipe: 5.3e-7 and 6.7e-7


def gl_opacities(gl, tmp_path, a, x):
    """(corrected_alpha(a, x), the plain 1 - exp2(x log2(1 - a)), opacity_of_depth(a), the plain
    1 - exp(-a)) evaluated by the GPU, float64 arrays."""
    from vgraph.gl.shaders import ProgramCache

    (tmp_path / "probe.comp.glsl").write_text(OPACITY_PROBE)
    cache = ProgramCache()
    try:
        shader = cache.compute(gl, str(tmp_path / "probe.comp.glsl"))
        inputs = gl.buffer(np.stack([a, x], axis=1).astype(np.float32).tobytes())
        outputs = gl.buffer(reserve=len(a) * 16)
        inputs.bind_to_storage_buffer(0)
        outputs.bind_to_storage_buffer(1)
        shader["count"].value = len(a)
        shader.run(group_x=(len(a) + 63) // 64)
        found = np.frombuffer(outputs.read(), dtype=np.float32).reshape(-1, 4).astype(np.float64)
        inputs.release()
        outputs.release()
        return found.T
    finally:
        cache.clear()


def test_gl_opacity_correction_keeps_small_opacities(gl, tmp_path):
    """Below SMALL_OPACITY corrected_alpha keeps 5e-7 of the exact value where the plain float32
    form loses up to all of it (opacities under 3e-8); at and above it, it is the plain form bit
    for bit. opacity_of_depth likewise against 1 - exp(-d)."""
    rng = np.random.default_rng(3)
    a = np.exp(rng.uniform(math.log(1e-9), math.log(0.999), 4000)).astype(np.float32)
    x = np.exp(rng.uniform(math.log(1e-2), math.log(1e2), 4000)).astype(np.float32)
    stable, plain, depth_stable, depth_plain = gl_opacities(gl, tmp_path, a, x)
    a64, x64 = a.astype(np.float64), x.astype(np.float64)
    exact = -np.expm1(x64 * np.log1p(-a64))
    small = a64 < SMALL_OPACITY
    relative = np.abs(stable - exact) / exact
    print(f"measured corrected_alpha below 1/64, relative: {relative[small].max():.2g}")  # for the report (-s)
    assert relative[small].max() < GL_RELATIVE_TOLERANCE
    assert np.array_equal(stable[~small], plain[~small])
    assert (np.abs(plain - exact) / exact)[small].max() > 0.5  # what the plain form does there
    exact_depth = -np.expm1(-a64)
    print(f"measured opacity_of_depth, relative: {(np.abs(depth_stable - exact_depth) / exact_depth).max():.2g}")
    assert (np.abs(depth_stable - exact_depth) / exact_depth).max() < GL_RELATIVE_TOLERANCE
    zero = gl_opacities(gl, tmp_path, np.zeros(1, np.float32), np.ones(1, np.float32))
    assert zero[0][0] == 0.0 and zero[2][0] == 0.0  # nothing stays nothing


# --- the GL renderers at the extremes, against the references ------------------------------------
# Relative error of the alpha of a faint medium (opacity 1e-9 .. 0.5 at optical depths 1e-8 and
# 1e-3), median over the covered pixels and the largest (silhouette pixels, where the rasterised and
# the exact geometry differ in thickness), measured on llvmpipe: ray caster 8.7e-8 and 1.7e-7;
# projected tetrahedra 7.2e-7 and 1.8e-3. With 1 - exp2(x log2(1 - a)) they were 100 % (a = 1e-9),
# 7.3 % (the ray caster, a = 1e-6 at rate 2) and 2.5e2 (tetrahedra at optical depth 1e-8).
GL_MEDIAN_RTOL = 2e-6
GL_MAX_RTOL = 5e-3


def relative_alpha_error(gl_image, reference, case: str):
    """(median, max) relative error of alpha over the covered pixels, printed for the report's
    table: ``pytest -s -q tests/test_reference_extremes.py -k gl_ | grep measured``."""
    covered = reference[..., 3] > 0.0
    reference_alpha = reference[..., 3][covered].astype(np.float64)
    error = np.abs(gl_image[..., 3][covered] - reference_alpha) / reference_alpha
    print(f"measured {case}: median {np.median(error):.2g}, max {error.max():.2g}")
    return np.median(error), error.max()


@pytest.mark.parametrize("alpha", [1e-9, 1e-6, 1e-3])
@pytest.mark.parametrize("rate", [0.5, 2.0])
def test_gl_ray_caster_keeps_small_opacities(alpha, rate):
    """Opacity correction on (rate != 1): the RayCaster's faint medium is the reference's to
    float32 precision, every pixel finite."""
    from vgraph.testing import ray_caster_network

    volume = uniform_volume()
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    properties = {"transfer_function": constant_tf(alpha), "shading": "none", "sampling_rate": rate,
                  "early_termination": 1.0, "background": CLEAR, "empty_space_skipping": False}
    gl_image = ray_caster_network(volume, camera, "RayCaster", **properties).evaluate("rc.image", size=SIZE)
    reference = reference_raycast.render(volume, camera, constant_tf(alpha), SIZE, sampling_rate=rate,
                                         early_termination=1.0, background=CLEAR)
    assert np.all(np.isfinite(gl_image))
    median, largest = relative_alpha_error(gl_image, reference, f"RayCaster, opacity {alpha:g}, rate {rate:g}")
    assert median < GL_MEDIAN_RTOL and largest < GL_MAX_RTOL, (median, largest)


@pytest.mark.parametrize("integration", ["averaged", "preintegrated", "partial"])
@pytest.mark.parametrize("alpha, depth", [(1e-9, 1e-8), (1e-6, 1e-3), (0.5, 1e-8), (1e-6, 1e8),
                                          (1.0 - 1e-9, 1e8)])
def test_gl_projected_tetrahedra_at_extreme_depths(integration, alpha, depth):
    """ProjectedTetrahedra with a constant TF at the thickest ray's optical depth 1e-8 .. 1e8:
    finite, within [0, 1], within 1e-5 of the reference everywhere, and within GL_MEDIAN_RTOL
    (median) and GL_MAX_RTOL of its alpha."""
    from vgraph.processors.projected_tetrahedra import ProjectedTetrahedra

    thickness = ray_segments(small_mesh(1.0), CAMERA, SIZE).thickness(SIZE)
    mesh = small_mesh(thickness.max() * -math.log1p(-min(alpha, MAX_OPACITY)) / depth)
    camera = CAMERA.resolved(*mesh.bounds, SIZE[0] / SIZE[1])
    processor = ProjectedTetrahedra(transfer_function=constant_tf(alpha), integration=integration,
                                    background=CLEAR, camera=camera)
    processor.render_size = SIZE
    gl_image = processor.process(mesh)["image"].to_numpy()
    reference = reference_tetra.render(mesh, camera, constant_tf(alpha), SIZE, background=CLEAR)
    assert np.all(np.isfinite(gl_image)) and gl_image.min() >= 0.0 and gl_image.max() <= 1.0
    np.testing.assert_allclose(gl_image, reference, atol=1e-5)
    median, largest = relative_alpha_error(gl_image, reference, f"ProjectedTetrahedra {integration}, opacity "
                                                                f"{alpha:g}, optical depth {depth:g}")
    assert median < GL_MEDIAN_RTOL and largest < GL_MAX_RTOL, (median, largest)
