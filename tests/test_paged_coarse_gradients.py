"""Shaded coarse frames difference a coarse brick's samples one voxel of level 0 apart, in the single
pass (raycasting/gradients.glsl's voxel_step; bricks/paged_sampling.glsl's raw_sample reads the
run's slot, whose apron covers them) and by passes (vgraph.bricks.sampling's brick_binding; the
brick's halo of 2 of its voxels covers them): nearer the level-0 image (the truth: the RayCaster's)
than one voxel of the brick's level apart, which the pass per brick took before. Checked: the
single pass's frames at levels 1 and 2 (shaded dvr with central and Sobel differences, shaded iso;
a smooth field, 48 x 48) are at least as near it as the floors below, set halfway between the PSNRs
measured with the level-0 step and with the level's step, so a renderer that differenced one voxel
of the level apart fails; and both methods, which sample a coarse level on the same lattice (dvr:
PAGED_STRIDE), give the same frame within float rounding. On the bonsai and a 128^3 ball too: the
PSNR table of docs/explanations/bricked-ray-casting.md, "Coarse levels sample their own lattice"
(`python bench/bench_paged_variants.py gradients`). No timings."""

import numpy as np
import pytest

from helpers.bricked import WINDOW, big_volume, oblique, psnr, render

SIZE = (48, 48)
AGREEMENT = 5e-5  # float rounding: measured up to 8.7e-6 (iso, level 2); 0.004-0.09 with the level's step by passes
SHADED = {"dvr central": {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 0.99,
                          "shading": "blinn_phong", "derivatives": "central"},
          "dvr sobel": {"compositing": "dvr", "transfer_function": WINDOW, "early_termination": 0.99,
                        "shading": "blinn_phong", "derivatives": "sobel"},
          "iso": {"compositing": "iso", "iso_level": 0.3, "shading": "blinn_phong", "derivatives": "central"}}
# PSNR (dB) against level 0 on llvmpipe: (differences one level-0 voxel apart, one voxel of the level)
MEASURED = {("dvr central", 1): (59.73, 58.09), ("dvr central", 2): (45.73, 45.07),
            ("dvr sobel", 1): (59.78, 55.52), ("dvr sobel", 2): (45.75, 42.59),
            ("iso", 1): (54.36, 53.68), ("iso", 2): (39.34, 39.09)}


@pytest.fixture(scope="module")
def volume():
    return big_volume()


@pytest.mark.parametrize("level", [1, 2])
@pytest.mark.parametrize("case", list(SHADED))
def test_a_coarse_shaded_single_pass_frame_differences_level_0_voxels(volume, case, level):
    properties = SHADED[case]
    camera = oblique(volume)
    truth, _, _ = render(volume, camera, "RayCaster", size=SIZE, **properties)
    image, _, rc = render(volume, camera, size=SIZE, brick_size=16, finest_level=level, lod_bias=-16.0,
                          method="single_pass", **properties)
    assert rc.last_frame["levels"] == [level] and rc.last_frame["complete"]
    assert image[..., 3].max() > 0.5  # something in the picture
    floor = sum(MEASURED[case, level]) / 2.0
    assert psnr(image, truth) >= floor, (psnr(image, truth), MEASURED[case, level])


@pytest.mark.parametrize("level", [1, 2])
@pytest.mark.parametrize("case", list(SHADED))
def test_a_coarse_shaded_frame_is_the_same_in_one_pass_and_by_passes(volume, case, level):
    """The pass per brick differences one voxel of level 0 apart too (vgraph.bricks.sampling)."""
    camera = oblique(volume)
    frames = []
    for method in ("single_pass", "passes"):
        image, _, rc = render(volume, camera, size=SIZE, brick_size=16, finest_level=level, lod_bias=-16.0,
                              method=method, **SHADED[case])
        assert rc.last_frame["levels"] == [level]
        frames.append(image)
    assert np.abs(frames[0] - frames[1]).max() <= AGREEMENT, np.abs(frames[0] - frames[1]).max()
