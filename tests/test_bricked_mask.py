"""Masks and cut-aways brick by brick (vgraph.gl.raycasting.mask in BrickSampling's passes and
PagedSampling's single pass): at level 0 with every brick resident the BrickedRayCaster's image with
a mask (on the volume's grid, or on its own coarser grid) or a cut-away equals the RayCaster's within
one 8-bit step (dvr, mip, iso, both methods), and the RayCaster drawing a volume brick by brick
passes its mask and cut-away on instead of refusing them."""

import numpy as np
import pytest

from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.volume import Volume

from helpers.bricked import FINEST, SIZE, WINDOW, odd_volume, oblique
from helpers.networks import UNSHADED_RAMP

ONE_STEP = 1.0 / 255.0  # what the task promises: equal within one step of an 8-bit image
MODES = {"dvr": {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 1.0},
         "mip": {"compositing": "mip"},
         "iso": {"compositing": "iso", "iso_level": 0.55}}


def label_mask(volume: Volume) -> Volume:
    """Labels on the volume's grid: 1 in the left third, 2 in a slab across the middle, else 0."""
    labels = np.zeros(volume.data.shape, np.uint8)
    nz, ny, nx = labels.shape
    labels[:, :, : nx // 3] = 1
    labels[:, ny // 3: 2 * ny // 3, :] = 2
    return Volume(labels, spacing=volume.spacing, origin=volume.origin)


def coarse_mask(volume: Volume) -> Volume:
    """A binary mask on its own grid (half the resolution, shifted): a box over the volume's left half."""
    shape = tuple((n + 1) // 2 for n in volume.data.shape)
    data = np.zeros(shape, np.uint8)
    data[1:-1, 1:-1, 1: shape[2] // 2] = 1
    return Volume(data, spacing=tuple(2.0 * s for s in volume.spacing),
                  origin=tuple(o + 0.7 for o in volume.origin))


def image(volume, mask, processor, **properties):
    if processor == "BrickedRayCaster":
        properties = {"brick_size": 16, "lod_bias": FINEST, **properties}
    network = ray_caster_network(volume, oblique(volume), processor, **{**UNSHADED_RAMP, **properties})
    if mask is not None:
        network.add(GivenVolume(id="m", volume=mask))
        network.connect("m.volume", "rc.mask")
    return np.asarray(network.evaluate("rc.image", size=SIZE)), network["rc"]


CASES = {"kept label 2": ("labels", {"mask_labels": "2"}),
         "hidden label 1, smooth": ("labels", {"mask_labels": "1", "mask_mode": "hide", "mask_boundary": "smooth"}),
         "coarse shifted mask hides": ("coarse", {"mask_mode": "hide"}),
         "sphere cut away": (None, {"cutaway": "sphere", "cutaway_size": (20.0, 20.0, 20.0)}),
         "box cut away and a mask": ("labels", {"mask_labels": "1, 2", "cutaway": "box",
                                                "cutaway_size": (12.0, 40.0, 12.0)})}


@pytest.mark.parametrize("method", ["passes", "single_pass"])
@pytest.mark.parametrize("mode", list(MODES))
@pytest.mark.parametrize("case", list(CASES))
def test_the_bricked_image_with_a_mask_or_cutaway_equals_the_raycasters(case, mode, method):
    volume = odd_volume()
    kind, properties = CASES[case]
    if properties.get("cutaway"):
        centre = volume.voxel_to_world(np.asarray(volume.dims, float)[None] / 2.0)[0]
        properties = {**properties, "cutaway_center": tuple(float(c) for c in centre)}
    mask = {"labels": label_mask, "coarse": coarse_mask, None: lambda v: None}[kind](volume)
    properties = {**MODES[mode], **properties}
    want, _ = image(volume, mask, "RayCaster", **properties)
    plain, _ = image(volume, None, "RayCaster", **MODES[mode])
    got, rc = image(volume, mask, "BrickedRayCaster", method=method, **properties)
    assert rc.drawn_method == method and rc.last_frame["levels"] == [0] and rc.last_frame["complete"]
    assert np.abs(want - plain).max() > 0.1  # the mask or cut-away changes the image
    assert np.abs(got - want).max() <= ONE_STEP, np.abs(got - want).max()


@pytest.mark.parametrize("compositing", ["dvr", "mip", "iso"])
def test_the_raycaster_passes_the_mask_on_to_the_bricks(compositing, monkeypatch):
    volume = odd_volume()
    properties = {**MODES[compositing], "mask_labels": "2", "cutaway": "sphere", "cutaway_size": (15.0, 15.0, 15.0),
                  "cutaway_center": tuple(float(c) for c in volume.voxel_to_world(
                      np.asarray(volume.dims, float)[None] / 2.0)[0])}
    want, _ = image(volume, label_mask(volume), "RayCaster", **properties)
    import vgraph.processors.raycaster as raycaster
    monkeypatch.setattr(raycaster, "needs_bricks", lambda volume, ctx: True)  # as for a store over budget
    got, rc = image(volume, label_mask(volume), "RayCaster", brick_size=16, lod_bias=FINEST, **properties)
    assert rc.last_frame and rc.last_frame["complete"] and rc.last_frame["levels"] == [0]
    assert np.abs(got - want).max() <= ONE_STEP, np.abs(got - want).max()
