"""dvr in the single pass on each level's own lattice (define PAGED_STRIDE: shaders/bricks/paged_stride.glsl,
vgraph.bricks.paged_strides): a frame of coarse bricks takes of level 0's samples only a brick's first
and those whose index is a multiple of its level's stride, each with the opacity of the level-0 steps
it stands for, as the pass per brick does (shaders/bricks/brick_span.glsl). Checked: a frame of
coarse bricks, or of several levels, equals the pass per brick's frame of the same plan within
float rounding, over the frame-wide walk and without skipping; it evaluates about a stride-th of
the samples; a level-0 frame compiles without it (its shader is the one before, token for token);
and frames still refining under a load limit, whose cells drawn from a resident ancestor border
finer ones inside the ancestor's cell, have no gap and no overlap there (a uniform medium gives the
level-0 picture). No timings: images and counts."""

import numpy as np
import pytest

import vgraph.bricks.paged_sampling as paged_sampling
from vgraph.bricks.cache import LoadLimit
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.sampling import BrickSampling
from vgraph.frame_context import FrameContext
from vgraph.testing import ray_caster_network

from helpers.bricked import FINEST, FLAT, WINDOW, big_volume, oblique, render
from helpers.networks import UNSHADED_RAMP

ROUNDING = 1e-5  # float32 sums of a few hundred samples, regrouped by the passes' blending
SIZE = (48, 48)


def level_strides(rc) -> np.ndarray:
    """The frame's strides per level, negative where a level is not whole (paged_strides)."""
    return np.asarray(rc.parts[PagedSampling].frame_binding.uniforms["level_strides"])


def both(volume, camera, **properties):
    """(single pass, pass per brick) images and the single pass's processor."""
    single, depth, rc = render(volume, camera, size=SIZE, method="single_pass", **properties)
    passes, _, rc_passes = render(volume, camera, size=SIZE, method="passes", **properties)
    assert rc.last_frame["levels"] == rc_passes.last_frame["levels"]
    return single, passes, depth, rc


@pytest.mark.parametrize("skipping", [True, False])
@pytest.mark.parametrize("plan", [{"finest_level": 1, "lod_bias": FINEST}, {"finest_level": 2, "lod_bias": FINEST},
                                  {"lod_bias": -1.0}, {"lod_bias": 0.0}])  # (levels 0 and 1, 1 and 2)
def test_a_coarse_single_pass_frame_is_the_pass_per_brick_frame(plan, skipping):
    volume = big_volume()
    single, passes, _, rc = both(volume, oblique(volume), transfer_function=WINDOW, brick_size=16,
                                 empty_space_skipping=skipping, **plan)
    levels = rc.last_frame["levels"]
    assert max(levels) >= 1 and rc.last_frame["complete"]
    if "finest_level" not in plan:
        assert len(levels) >= 2, levels  # levels by footprint: seams between levels
    defines = rc.passes[-1].defines
    # every level whole: runs span cells, no look-ups at their borders
    assert defines.get("PAGED_STRIDE") and defines.get("PAGED_STRIDE_WHOLE") and (level_strides(rc) > 0).all()
    assert list(level_strides(rc)[:3]) == [1, 2, 4]
    # skipping: the frame-wide walk, or the slots' distances where the walk would not pay
    assert bool(defines.get("PAGED_WALK") or defines.get("PAGED_BLOCKS")) is skipping
    assert single[..., 3].max() > 0.5  # something in the picture
    assert np.abs(single - passes).max() <= ROUNDING, np.abs(single - passes).max()


def test_a_coarse_frame_evaluates_a_stride_th_of_the_samples(monkeypatch):
    volume = big_volume()
    camera = oblique(volume)
    properties = dict(transfer_function=WINDOW, brick_size=16, finest_level=2, lod_bias=FINEST,
                      method="single_pass", empty_space_skipping=False, size=SIZE)
    _, strided, rc = render(volume, camera, **properties)
    assert rc.last_frame["levels"] == [2] and rc.passes[-1].defines.get("PAGED_STRIDE")
    monkeypatch.setattr(paged_sampling, "stride_binding", lambda *args: None)  # every level-0 sample, as before
    _, every, rc = render(volume, camera, **properties)
    assert not rc.passes[-1].defines.get("PAGED_STRIDE")
    ratio = strided[..., 2].sum() / every[..., 2].sum()  # the depth output's sample counter
    assert 0.2 <= ratio <= 0.3, ratio  # level 2's stride is 4 (plus each brick's first sample)


def test_level_0_frames_compile_without_it():
    volume = big_volume()
    _, _, _, rc = both(volume, oblique(volume), transfer_function=WINDOW, brick_size=16, lod_bias=FINEST)
    assert rc.last_frame["levels"] == [0]
    assert "PAGED_STRIDE" not in rc.passes[-1].defines


def test_frames_refining_under_a_load_limit_have_no_gap_at_the_borders_of_ancestors():
    """A uniform medium: a pixel depends only on the length its ray runs through it, so any gap or
    overlap where a cell drawn from a coarse ancestor meets a finer cell shows."""
    volume = big_volume()
    camera = oblique(volume)
    network = ray_caster_network(volume, camera, "BrickedRayCaster", method="single_pass", brick_size=16,
                                 lod_bias=FINEST, **{**UNSHADED_RAMP, "transfer_function": FLAT})
    # two sampling rates in turn, so that each frame is drawn anew: the level-0 picture of each (a
    # ray's count of samples may change with the rate)
    rates = (1.0, 1.0 + 1e-6)
    want = []
    for rate in rates:
        network.set("rc.sampling_rate", rate)
        want.append(np.asarray(network.evaluate("rc.image", size=SIZE)))
        assert network["rc"].last_frame["levels"] == [0]
    network["rc"].parts[BrickSampling].cache.clear()  # nothing in memory: read again, a few bricks a frame
    network["rc"].parts[PagedSampling].atlas.release()
    limited = FrameContext(load_limit=LoadLimit(bricks=24))
    mixed = 0
    for count in range(40):
        network.set("rc.sampling_rate", rates[count % 2])
        image = np.asarray(network.evaluate("rc.image", size=SIZE, context=limited))
        frame = network["rc"].last_frame
        if len(frame["levels"]) > 1:
            mixed += 1
            assert network["rc"].passes[-1].defines.get("PAGED_STRIDE")
            partial = level_strides(network["rc"]) < 0
            assert partial[max(frame["levels"])] and not partial[0]  # ancestors beside finer cells
            assert not network["rc"].passes[-1].defines.get("PAGED_STRIDE_WHOLE")
        assert np.abs(image - want[count % 2]).max() <= ROUNDING, (frame["levels"], np.abs(image - want[count % 2]).max())
        if frame["complete"]:
            break
    assert frame["complete"] and mixed >= 2
