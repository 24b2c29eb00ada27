"""The Volume data type: geometry, value ranges, histogram, GPU upload, and refusing bad arrays."""

import numpy as np
import pytest

from vgraph import VGraphError, Volume


def test_geometry_follows_the_conventions():
    volume = Volume(np.zeros((4, 3, 2), np.uint8), spacing=(1, 2, 3), origin=(10, 20, 30))
    assert volume.dims == (2, 3, 4)
    np.testing.assert_allclose(volume.extent, [1, 4, 9])
    np.testing.assert_allclose(volume.voxel_to_world([1, 2, 3]), [11, 24, 39])
    np.testing.assert_allclose(volume.world_to_voxel([11, 24, 39]), [1, 2, 3])


@pytest.mark.parametrize("data, declared, expected", [
    (np.array([[[3, 9]]], np.uint8), None, (0, 255)),
    (np.array([[[3, 9]]], np.uint16), None, (0, 65535)),
    (np.array([[[3, 9]]], np.uint16), (0, 4095), (0, 4095)),
    (np.array([[[-3, 9]]], np.int16), None, (-3, 9)),
    (np.array([[[0.5, np.nan, 2.0, np.inf]]], np.float32), None, (0.5, 2.0)),
    (np.full((2, 2, 2), 7.0), None, (7.0, 8.0)),  # constant: still a usable range
])
def test_value_range_rules(data, declared, expected):
    assert Volume(data, declared_range=declared).value_range == expected


@pytest.mark.parametrize("data, message", [
    (np.zeros((0, 4, 4)), "zero-size dimension"),
    (np.zeros((4, 4)), "expected a 3D"),
    (np.array([[["a"]]]), "unsupported data type"),
])
def test_bad_arrays_are_refused(data, message):
    with pytest.raises(VGraphError, match=message):
        Volume(data, source="scan.raw")


@pytest.mark.parametrize("kwargs, message", [
    ({"spacing": (1, 0, 1)}, "spacing must be positive"),
    ({"spacing": (1, 1)}, "spacing must be three finite numbers"),
    ({"origin": (0, np.nan, 0)}, "origin must be three finite numbers"),
    ({"declared_range": (5, 5)}, "value_range must be finite with low < high"),
])
def test_bad_geometry_is_refused_naming_the_source(kwargs, message):
    with pytest.raises(VGraphError, match=rf"volume from scan.raw: {message}"):
        Volume(np.zeros((2, 2, 2)), source="scan.raw", **kwargs)


def test_nonfinite_voxels_are_counted_and_skipped_by_the_histogram():
    data = np.linspace(0, 1, 27, dtype=np.float32).reshape(3, 3, 3)
    data[0, 0, 0], data[1, 1, 1] = np.nan, -np.inf
    volume = Volume(data)
    counts, edges = volume.histogram(bins=4)
    assert volume.nonfinite_count == 2 and counts.sum() == 25
    assert edges[0] == 0.0 and edges[-1] == 1.0


@pytest.mark.parametrize("dtype, components_format", [(np.uint8, "nu2"), (np.uint16, "nu2"), (np.float32, "f4"),
                                                      (np.int16, "f4")])
def test_texture_upload_maps_samples_to_normalised_intensity(gl, dtype, components_format):
    rng = np.random.default_rng(1)
    data = rng.integers(0, 200, size=(3, 4, 5)).astype(dtype)
    volume = Volume(data, declared_range=(10, 190))
    texture = volume.texture(gl)
    assert texture is volume.texture(gl)  # uploaded once per context
    assert texture.size == (5, 4, 3) and texture.dtype == components_format
    raw = np.frombuffer(texture.read(), dtype={"nu2": np.uint16, "f4": np.float32}[components_format])
    samples = raw.astype(np.float64) / {"nu2": 65535.0, "f4": 1.0}[components_format]
    scale, offset = volume.texture_scale_offset()
    np.testing.assert_allclose(samples * scale + offset, volume.normalized(data).ravel(), atol=1e-6)


def test_nonfinite_voxels_upload_clamped(gl):
    data = np.array([[[np.nan, np.inf, -np.inf, 0.5, 1.0, 0.0]]], np.float32)
    volume = Volume(data)
    uploaded = np.frombuffer(volume.texture(gl).read(), np.float32)
    np.testing.assert_array_equal(uploaded, [0.0, 1.0, 0.0, 0.5, 1.0, 0.0])


def test_the_texture_is_released_with_its_volume(gl):
    import gc
    texture = Volume(np.zeros((2, 2, 2), np.float32)).texture(gl)
    gc.collect()
    with pytest.raises(AttributeError):
        texture.read()  # moderngl's released objects have no GL name left


def test_consumers_refuse_the_wrong_kind_with_what_to_do():
    samples = Volume(np.zeros((2, 2, 2)))
    coefficients = samples.with_data(np.zeros((2, 2, 2), np.float32), is_spline_coefficients=True)
    assert samples.require_samples("RayCaster 'rc'") is samples
    with pytest.raises(VGraphError, match="RayCaster 'rc' needs voxel samples .* disable or remove the CubicSplineProcessor"):
        coefficients.require_samples("RayCaster 'rc'")
    with pytest.raises(VGraphError, match="insert a CubicSplineProcessor"):
        samples.require_coefficients("CurvatureRaycaster 'c'")
