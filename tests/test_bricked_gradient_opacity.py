"""Gradient opacity brick by brick (vgraph.gl.raycasting.gradient_classification with
``from_samples``: central differences of the sampled intensity inside the brick, no gradient
volume): at level 0 with every brick resident the BrickedRayCaster's dvr image equals the
RayCaster's (which reads the precomputed gradient volume) within one 8-bit step, in both methods,
shaded or not; off, the image is the plain one; a store over its budget takes its scale from one
pass over level 0; the 2D TF too (skipping by its largest opacity per value); mip and max_error\n< 1 with the 2D TF are refused by name."""

import numpy as np
import pytest

from vgraph import VGraphError
from vgraph.gradient_opacity import GradientOpacity

from helpers.bricked import FINEST, SIZE, WINDOW, odd_volume, oblique, render

# float32 differences of the interpolated field against the gradient volume's 16-bit rounding
# (the same numbers otherwise: the shader says why), far below one step of an 8-bit image.
TOLERANCE = 1e-4  # measured <= 3.2e-6 on llvmpipe
# The 2D table's gradient axis has 256 entries over the fraction: the same rounding moves a
# sample's lookup more than the curve's 1024-entry one; still far below an 8-bit step.
TOLERANCE_2D = 1e-3  # measured 1.42e-4 on llvmpipe (both methods, skipping or not)
STEEP = GradientOpacity(points=[(0.0, 0.0), (0.15, 0.0), (0.6, 1.0), (1.0, 1.0)])


def images(volume, method, **properties):
    properties = {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 1.0, **properties}
    want, _, _ = render(volume, oblique(volume), "RayCaster", size=SIZE, **properties)
    got, _, rc = render(volume, oblique(volume), size=SIZE, brick_size=16, lod_bias=FINEST, method=method,
                        **properties)
    assert rc.drawn_method == method and rc.last_frame["levels"] == [0] and rc.last_frame["complete"]
    return got, want


@pytest.mark.parametrize("method", ["passes", "single_pass"])
@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
@pytest.mark.parametrize("curve", ["boundaries", "steep"])
def test_gradient_opacity_brick_by_brick_equals_the_raycasters(method, shading, curve):
    volume = odd_volume()
    opacity = {"boundaries": "boundaries", "steep": STEEP}[curve]
    got, want = images(volume, method, shading=shading, gradient_opacity=opacity)
    plain, _ = images(volume, method, shading=shading)
    assert np.abs(want - plain).max() > 0.02  # the curve changes the image (9 steps at least)
    assert np.abs(got - want).max() <= TOLERANCE, np.abs(got - want).max()


@pytest.mark.parametrize("method", ["passes", "single_pass"])
@pytest.mark.parametrize("skipping", [True, False])
def test_the_2d_tf_brick_by_brick_equals_the_raycasters(method, skipping):
    """The 2D TF at (value, gradient fraction) with the central-difference gradient; bricks and
    blocks skipped by its largest opacity per value (with and without block skipping: the same
    image, so nothing it draws is skipped)."""
    volume = odd_volume()
    got, want = images(volume, method, transfer_function_2d="boundaries", empty_space_skipping=skipping)
    plain, _ = images(volume, method)
    assert np.abs(want - plain).max() > 0.02 and want[..., 3].max() > 0.1  # the 2D TF draws something else
    assert np.abs(got - want).max() <= TOLERANCE_2D, np.abs(got - want).max()


def test_max_error_with_the_2d_tf_and_mip_are_refused_by_name():
    volume = odd_volume()
    with pytest.raises(VGraphError, match=r"rc\.max_error: the error bounds of a level go by the 1D transfer "
                                          r"function, not transfer_function_2d; set rc\.max_error to 1"):
        render(volume, oblique(volume), brick_size=16, transfer_function_2d="boundaries", max_error=0.1)
    with pytest.raises(VGraphError, match=r"rc\.gradient_opacity: .* compositing mip does not take"):
        render(volume, oblique(volume), brick_size=16, compositing="mip", gradient_opacity="boundaries")


def test_a_store_over_its_budget_has_the_in_memory_scale_and_image(tmp_path, monkeypatch):
    """A store over its memory budget: its largest voxel gradient from one pass over level 0, slab
    by slab (slabs of 3 slices here, so the halo between slabs counts) equals the same store's in
    memory bit for bit (the same voxels and float64 arithmetic); its image with gradient opacity
    equals the RayCaster's of the store in memory within TOLERANCE; the pass runs once."""
    pytest.importorskip("zarr")
    from vgraph import derived
    from vgraph.bricks.volume import BrickedVolume
    from vgraph.gl.raycasting import gradient_classification
    from vgraph.io.convert import convert
    np.save(tmp_path / "field.npy", (odd_volume().data * 65535).astype(np.uint16))
    convert(tmp_path / "field.npy", tmp_path / "field.zarr", brick=16, progress=False)
    memory = BrickedVolume.open(tmp_path / "field.zarr")
    store = BrickedVolume.open(tmp_path / "field.zarr", memory_budget_mb=0.05)
    assert memory.fits_budget and not store.fits_budget
    nz, ny, nx = store.shape
    monkeypatch.setattr(gradient_classification, "SLAB_VOXELS", 3 * ny * nx)
    largest = gradient_classification.largest_magnitude(store)
    assert largest > 0.0 and largest == gradient_classification.largest_magnitude(memory)
    derived.forget(store)
    derived.reset_stats()
    properties = {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 1.0,
                  "gradient_opacity": STEEP}
    want, _, _ = render(memory, oblique(memory), "RayCaster", size=SIZE, **properties)
    got, _, rc = render(store, oblique(store), size=SIZE, brick_size=16, lod_bias=FINEST, **properties)
    assert rc.last_frame["levels"] == [0] and rc.last_frame["complete"]
    assert np.abs(got - want).max() <= TOLERANCE, np.abs(got - want).max()
    misses = derived.stats()[gradient_classification.LARGEST].misses
    again, _, _ = render(store, oblique(store), size=SIZE, brick_size=16, lod_bias=FINEST, **properties)
    counts = derived.stats()[gradient_classification.LARGEST]
    assert counts.misses == misses and counts.hits >= 1  # the second frame reads no voxel for it
    assert np.array_equal(again, got)
    with pytest.raises(Exception, match="memory budget"):
        store.data  # never loaded whole


def test_the_raycaster_hands_gradient_opacity_over_to_the_bricks(monkeypatch):
    volume = odd_volume()
    properties = {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 1.0,
                  "gradient_opacity": STEEP}
    want, _, _ = render(volume, oblique(volume), "RayCaster", size=SIZE, **properties)
    import vgraph.processors.raycaster as raycaster
    monkeypatch.setattr(raycaster, "needs_bricks", lambda volume, ctx: True)  # as for a store over budget
    got, _, rc = render(volume, oblique(volume), "RayCaster", size=SIZE, brick_size=16, lod_bias=FINEST,
                        **properties)
    assert rc.last_frame and rc.last_frame["complete"] and rc.last_frame["levels"] == [0]
    assert np.abs(got - want).max() <= TOLERANCE, np.abs(got - want).max()
