"""The single-pass bricked ray caster's dvr (unshaded and shaded) over a frame-wide grid of skip radii
(PAGED_WALK: vgraph.bricks.walk_grids.skip_radii, walked by the RayCaster's own empty_space.glsl code
in march.glsl): where the atlas holds every planned brick, image and depth sample as the plain
march (no skipping), fewer samples, and the image within an 8-bit step of the in-core RayCaster's;
iso, which walks a grid of its own (test_paged_iso_grid), the same checks; bricks of 16 (two of
the grid's blocks of 8 voxels) and 8 on a volume of 45^3 (its last cores smaller than a block)."""

import numpy as np
import pytest

from vgraph.implicit import sample
from vgraph.testing import ray_caster_network

from vgraph.transfer_function import TransferFunction

from helpers.skipping import SIZE, assert_same_picture, cameras

# transparent below 0.4: the torus's outer parts are empty space (its values lie in (0, 0.61))
WINDOW = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 0.0), (0.4, 0.2, 0.5, 0.9, 0.0),
                                  (0.5, 0.9, 0.6, 0.3, 0.6), (1.0, 1.0, 0.9, 0.6, 1.0)])

CASES = {"dvr": {"compositing": "dvr", "early_termination": 1.0, "shading": "none"},
         # iso walks a grid of its own (PAGED_ISO_GRID, test_paged_iso_grid), not this one
         "shaded": {"compositing": "dvr", "shading": "blinn_phong", "early_termination": 0.99},
         "iso": {"compositing": "iso", "iso_level": 0.5, "shading": "none"}}


@pytest.mark.parametrize("n, brick", [(64, 16), (45, 8)])
@pytest.mark.parametrize("case", list(CASES))
def test_single_pass_walk_changes_neither_image_nor_depth(case, n, brick):
    volume = sample("torus", n, "float32")
    walks = case in ("dvr", "shaded")
    for camera_name in ("perspective", "inside"):
        camera = cameras(volume)[camera_name]
        network = ray_caster_network(volume, camera, "BrickedRayCaster", transfer_function=WINDOW, brick_size=brick,
                                     lod_bias=-16.0, method="single_pass", **CASES[case])
        outputs = []
        for skipping in (True, False):
            network.set("rc.empty_space_skipping", skipping)
            outputs.append((network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)))
            assert network["rc"].passes[-1].defines.get("PAGED_WALK", False) is (skipping and walks)
        assert np.ptp(np.asarray(outputs[1][0])[..., 0]) > 0.1  # something varied is in the picture
        assert_same_picture(*outputs)
        assert outputs[0][1][..., 2].sum() < outputs[1][1][..., 2].sum()  # fewer samples evaluated
        reference = ray_caster_network(volume, camera, transfer_function=WINDOW, **CASES[case])
        image = reference.evaluate("rc.image", size=SIZE)
        assert np.abs(np.asarray(outputs[0][0]) - np.asarray(image)).max() <= 1 / 255
