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
    # min..max for every type: a type's full scale ([0, 65535]) made 12-bit scans render black
    (np.array([[[3, 9]]], np.uint8), None, (3, 9)),
    (np.array([[[3, 9]]], np.uint16), None, (3, 9)),
    (np.array([[[3, 9]]], np.uint16), (0, 4095), (0, 4095)),
    (np.zeros((2, 2, 2), np.uint8), None, (0, 1)),
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


def twelve_bit_with_an_outlier(shape=(24, 32, 40)) -> np.ndarray:
    """The acceptance case of the value-range rule: 12-bit content (0..1500) in uint16 with one
    outlier voxel of 30393, as a scanner writes a metal artefact or a calibration marker."""
    data = np.random.default_rng(7).integers(0, 1501, size=shape).astype(np.uint16)
    data[3, 4, 5] = 30393
    return data


def test_a_twelve_bit_scan_in_uint16_maps_its_own_range_not_the_type_range():
    volume = Volume(twelve_bit_with_an_outlier())
    assert volume.value_range == (0.0, 30393.0)
    bulk = volume.normalized(volume.data[volume.data <= 1500])
    assert bulk.max() == pytest.approx(1500 / 30393)  # was 1500 / 65535 with the type's range
    low, high = volume.percentiles([0.5, 99.5])
    assert 0 <= low <= 10 and 1490 <= high <= 1500  # the bulk, without the outlier


PERCENTS = [0, 0.5, 1, 5, 25, 33.3, 50, 75, 95, 99, 99.5, 100]


@pytest.mark.parametrize("dtype, low, high", [(np.uint8, 0, 255), (np.uint16, 0, 4095),
                                              (np.int16, -1024, 3071), (np.int8, -128, 127)])
def test_percentiles_of_integer_data_equal_numpy(dtype, low, high):
    data = np.random.default_rng(1).integers(low, high + 1, size=(20, 30, 40)).astype(dtype)
    np.testing.assert_allclose(Volume(data).percentiles(PERCENTS), np.percentile(data, PERCENTS),
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize("make", [
    lambda r: r.normal(size=(20, 30, 40)).astype(np.float32),
    lambda r: r.normal(size=(20, 30, 40)) * 1e300,                  # float64 beyond float32
    lambda r: r.uniform(-1, 1, size=(20, 30, 40)) * 1.7e308,        # max - min overflows float64
    lambda r: r.integers(-2**31, 2**31 - 1, size=(20, 30, 40)).astype(np.int32),  # > 65536 values
    lambda r: r.exponential(size=(20, 30, 40)).astype(np.float32) ** 4,  # skewed: a long tail
], ids=["float32", "float64-1e300", "float64-near-max", "int32-wide", "skewed"])
def test_percentiles_are_within_a_65536th_of_the_range(make):
    data = make(np.random.default_rng(2))
    got = Volume(data).percentiles(PERCENTS)
    expected = np.percentile(data, PERCENTS)
    width = (float(data.max()) / 65536 - float(data.min()) / 65536)  # no overflow near 1.8e308
    assert np.all(np.abs(got - expected) <= width)
    assert got[0] == data.min() and got[-1] == data.max()  # the ends are exact


def test_percentiles_between_the_ends_of_float64_do_not_overflow():
    volume = Volume(np.array([[[-1.7e308, 1.7e308]]]))
    np.testing.assert_array_equal(volume.percentiles([0, 50, 100]), [-1.7e308, 0.0, 1.7e308])


def test_percentiles_ignore_nonfinite_voxels_and_work_slab_by_slab(monkeypatch):
    data = np.random.default_rng(3).normal(size=(16, 16, 16)).astype(np.float32)
    data[0, 0, :6] = [np.nan, np.inf, -np.inf, np.nan, np.inf, -np.inf]
    finite = data[np.isfinite(data)]
    whole = Volume(data.copy()).percentiles(PERCENTS)
    monkeypatch.setattr("vgraph.volume.SLAB_VOXELS", 1000)  # 5 slabs, one partial
    sliced = Volume(data.copy())
    np.testing.assert_array_equal(sliced.percentiles(PERCENTS), whole)
    assert sliced.value_range == (float(finite.min()), float(finite.max()))
    width = (finite.max() - finite.min()) / 65536
    assert np.all(np.abs(whole - np.percentile(finite, PERCENTS)) <= width)


def test_percentiles_are_computed_once_per_volume(monkeypatch):
    volume = Volume(twelve_bit_with_an_outlier())
    volume.percentiles([50])
    monkeypatch.setattr(Volume, "_slabs", lambda self: pytest.fail("the data were read again"))
    assert volume.percentiles(np.array([[10, 90]])).shape == (1, 2)  # shaped like the input


@pytest.mark.parametrize("data, expected", [
    (np.full((2, 2, 2), 7.5), [7.5, 7.5, 7.5]),                          # constant
    (np.full((2, 2, 2), 200, np.uint8), [200, 200, 200]),
    (np.full((2, 2, 2), np.nan), [0.0, 0.5, 1.0]),                       # nothing finite: the range
])
def test_percentiles_of_degenerate_volumes(data, expected):
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(Volume(data).percentiles([0, 50, 100]), expected)


@pytest.mark.parametrize("percents", [[-1], [100.5], [np.nan], [50, 101]])
def test_percentiles_outside_0_to_100_are_refused_naming_the_source(percents):
    with pytest.raises(VGraphError, match=r"volume from scan.raw: percentiles must lie in \[0, 100\]"):
        Volume(np.zeros((2, 2, 2)), source="scan.raw").percentiles(percents)


def test_time_steps_are_kept_by_with_data_and_checked():
    volume = Volume(np.zeros((2, 2, 2)), time_steps=5)
    assert volume.with_data(np.ones((2, 2, 2))).time_steps == 5
    assert Volume(np.zeros((2, 2, 2))).time_steps == 1
    for bad in (0, -1, 2.5, True):
        with pytest.raises(VGraphError, match="time_steps must be a positive integer"):
            Volume(np.zeros((2, 2, 2)), time_steps=bad)
