"""Which bricked method draws (issue #33, item 3; vgraph.bricks.methods): the BrickedRayCaster's
``method`` auto draws dvr, iso and mip in one pass through the page table, a frame of the leaves
split and a leaf table past the budgets by passes; the RayCaster hands a volume
one texture cannot hold over by the same rule. Images within one 8-bit step of the in-core
RayCaster's (level 0, every brick resident)."""

import warnings

import numpy as np
import pytest

from vgraph import ProcessorError
from vgraph.bricks.methods import leaf_table_need
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.selection import LeafPass
from vgraph.frame_context import FrameContext
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume

from helpers.bricked import FINEST, SIZE, WINDOW, field, oblique, odd_volume, render

ONE_STEP = 1.0 / 255.0
BRICK_SHADER, ONE_PASS_SHADER = "bricks/brick.frag.glsl", "raycasting/raycaster.frag.glsl"


def shaders(rc) -> set[str]:
    return {p.shader for p in rc.passes}


@pytest.mark.parametrize("compositing, drawn", [("dvr", "single_pass"), ("iso", "single_pass"), ("mip", "single_pass")])
def test_auto_draws_dvr_iso_and_mip_in_one_pass_like_the_raycaster(compositing, drawn):
    volume = odd_volume()
    camera = oblique(volume)
    properties = {"compositing": compositing, "transfer_function": WINDOW, "iso_level": 0.45,
                  "early_termination": 1.0}
    want, _, _ = render(volume, camera, "RayCaster", **properties)
    got, _, rc = render(volume, camera, method="auto", brick_size=16, lod_bias=FINEST, **properties)
    assert rc.drawn_method == drawn
    assert (ONE_PASS_SHADER if drawn == "single_pass" else BRICK_SHADER) in shaders(rc)
    assert want[..., 3].max() > 0.3 and np.abs(got - want).max() <= ONE_STEP
    assert rc.last_frame["levels"] == [0] and rc.last_frame["complete"]


def test_auto_is_the_default_and_draws_a_leaf_of_the_leaves_split_by_passes():
    volume = odd_volume()
    network = ray_caster_network(volume, oblique(volume), "BrickedRayCaster", brick_size=16, lod_bias=FINEST)
    rc = network["rc"]
    assert rc.method == "auto"
    network.evaluate("rc.image", size=SIZE)
    assert rc.drawn_method == "single_pass"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a leaf's image is the resolve of nothing: blank
        planning = LeafPass(bricks=[])  # what the coordinator asks first: the frame's plan
        network.evaluate("rc.image", size=SIZE, context=FrameContext(leaf=planning))
        assert rc.drawn_method == "passes" and planning.plan.bricks
        run = LeafPass(bricks=list(planning.plan.bricks))  # a worker's run: here all the bricks
        network.evaluate("rc.image", size=SIZE, context=FrameContext(leaf=run))
    assert rc.drawn_method == "passes" and BRICK_SHADER in shaders(rc)
    assert run.partial[0][..., 3].max() > 0.3  # the worker's accumulation, for the next to continue


def test_auto_draws_by_passes_where_the_leaf_table_would_pass_the_budgets():
    volume = Volume(field((80, 80, 80)))
    texels, need = leaf_table_need(ArrayPyramid(volume.data, brick=(8, 8, 8)), 1.0)
    assert texels == 1000 and need == 1000 * 20 * 4  # flat: an RGBA32F and an R32F texel a brick, four copies
    budget = 4 * need / 2 ** 20  # MB: the table would be a quarter of it (auto wants an eighth at most)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the budget raises the level (test_bricked_raycaster says so)
        image, _, rc = render(volume, oblique(volume), brick_size=8, method="auto", ram_budget=budget,
                              gl_budget=budget)
    assert rc.drawn_method == "passes" and image[..., 3].max() > 0.1


def test_single_pass_refuses_a_leaf_table_past_the_budgets_by_name():
    volume = Volume(field((80, 80, 80)))  # 1000 level-0 cells: a flat table of 80000 bytes while built
    with pytest.raises(ProcessorError, match=r"rc\.method: single_pass keeps a leaf table of up to 1000 texels "
                                             r".*more than min\(ram_budget, gl_budget\).*use method 'passes'"):
        render(volume, oblique(volume), brick_size=8, method="single_pass", ram_budget=0.05, gl_budget=0.05)


@pytest.mark.parametrize("compositing, drawn", [("dvr", "single_pass"), ("mip", "single_pass")])
def test_the_raycaster_hands_a_volume_wider_than_the_texture_limit_over_by_the_same_rule(gl, compositing, drawn):
    limit = gl.info["GL_MAX_3D_TEXTURE_SIZE"]
    volume = Volume(field((6, 5, limit + 40)), spacing=(0.01, 1.0, 1.0))
    camera = oblique(volume)
    properties = {"compositing": compositing, "transfer_function": WINDOW, "early_termination": 1.0}
    got, got_depth, rc = render(volume, camera, "RayCaster", **properties)
    want, want_depth, bricked = render(volume, camera, method=drawn, brick_size=64, **properties)
    assert rc.last_frame and rc.last_frame["complete"]
    assert shaders(rc) == shaders(bricked) and (ONE_PASS_SHADER in shaders(rc)) == (drawn == "single_pass")
    assert got[..., :3].max() > 0.3 and np.abs(got - want).max() <= ONE_STEP
    np.testing.assert_allclose(got_depth[..., :2], want_depth[..., :2], atol=1e-4)
    assert rc.frame_summary().startswith("single pass" if drawn == "single_pass" else "bricks")
