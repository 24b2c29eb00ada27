"""The bricked frame's plan on arrays (vgraph.bricks.walk_order, selection.selected_arrays): the same
bricks in the same front-to-back order as the recursive walk it replaced, byte sizes from the
per-source table, and nothing made again per frame that did not change."""

from __future__ import annotations

import gc
import itertools
import weakref

import numpy as np
import pytest

from vgraph.bricks.cache import brick_texture_shape, bricks_bytes, level_brick_bytes, texture_format
from vgraph.bricks.cells import cell_grid
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.pyramid import ArrayPyramid, brick_grid
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks import level_tables
from vgraph.bricks.cells import cells_are_bricks, cells_of_bricks
from vgraph.bricks.level_tables import LevelTables, desired_levels, joined_levels, screen_rects
from vgraph.bricks.selection import FramePlan, key_set, select_bricks, selected_arrays
from vgraph.bricks.walk_order import axis_ranks, front_to_back
from vgraph.camera import Camera
from vgraph.gl.tetrahedra.cells import axis_order
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import ray_caster_network
from vgraph.volume import Volume

from helpers.bricked import WINDOW, field


def recursive_walk(source, camera, size, view_projection, visible, lod_bias, floor_level):
    """The walk as it was written before the arrays: cell by cell, recursively, front_to_back at
    every block (the reference the array walk must equal exactly)."""
    geometry = BrickGeometry(source)
    tables = LevelTables(geometry, camera, size, view_projection, visible, lod_bias)
    top = len(source.levels) - 1
    perspective = camera.projection == "perspective"
    forward = camera.basis()[2]
    chosen = []

    def walk(level, cells):
        eye = geometry.eye_in_bricks(camera.position, level)
        rects, wants = tables(level, "rects"), tables(level, "wants")
        for x, y, z in cells:
            rect = rects[z, y, x]
            if rect[2] == 0:
                continue
            if level > min(max(int(wants[z, y, x]), floor_level, 0), top):
                ratio, grid = geometry.ratios[level], geometry.grids[level - 1]
                first = np.array([x, y, z]) * ratio
                walk(level - 1, front_to_back(np.minimum(first + ratio, grid) - first, eye * ratio, forward,
                                              perspective, first))
            elif tables(level, "visible")[z, y, x]:
                chosen.append(((level, z, y, x), tuple(int(v) for v in rect)))

    walk(top, front_to_back(geometry.grids[top], geometry.eye_in_bricks(camera.position, top), forward, perspective))
    return chosen


def cameras(source):
    base = source.levels[0]
    lo = np.asarray(base.origin) - 0.5 * np.asarray(base.spacing)
    hi = lo + np.asarray(base.shape[::-1]) * np.asarray(base.spacing)
    for direction, projection in itertools.product([(-0.5, -0.3, -1.0), (1.0, 0.1, 0.2), (0.3, 0.9, -0.2)],
                                                   ["perspective", "orthographic"]):
        yield Camera.looking_at_box(lo, hi, direction=direction, projection=projection)
    for inside in (0.5, 0.3):  # the eye inside the volume: every axis has cells on both sides
        eye = lo + inside * (hi - lo)
        yield Camera(position=tuple(map(float, eye)), focus=tuple(map(float, eye + (0.3, -0.2, 1.0))), fov=90.0,
                     near=0.01, far=1000.0)


@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.7, 1.0, 2.1)])
@pytest.mark.parametrize("kept_cells", [1 << 15, 20, 0])  # every level joined, the top two, none
def test_the_array_walk_draws_the_recursive_walks_bricks_in_its_order(monkeypatch, spacing, kept_cells):
    """The small levels at the top walked whole (walk_order.JoinedCells), the rest level by level."""
    monkeypatch.setattr(level_tables, "KEPT_CELLS", kept_cells)
    source = ArrayPyramid(field((37, 50, 61)), spacing=spacing, origin=(3.0, -2.0, 1.0), brick=(8, 8, 8))
    rng = np.random.default_rng(3)
    empty = {level: rng.random(brick_grid(source.levels[level].shape, source.brick)) < 0.2
             for level in range(len(source.levels))}

    def visible(level):
        return ~empty[level]

    compared = 0
    for camera in cameras(source):
        for size in [(40, 40), (200, 120)]:
            view_projection = camera.view_projection(size[0] / size[1])
            for lod_bias, floor_level in itertools.product([-16.0, -1.0, 1.5, 4.0], [0, 1]):
                expected = recursive_walk(source, camera, size, view_projection, visible, lod_bias, floor_level)
                assert select_bricks(source, camera, size, view_projection, visible, lod_bias,
                                     floor_level) == expected
                compared += len({key[0] for key, _ in expected}) > 1  # frames of several levels
    assert compared >= 5  # the walk was checked where it goes down to several levels


@pytest.mark.parametrize("kept_cells", [1 << 15, 20, 0])
def test_the_levels_tables_made_in_one_go_are_each_levels_own(monkeypatch, kept_cells):
    """LevelTables makes the rectangles and wanted levels of the small levels together (joined_levels):
    each level's equal screen_rects' and desired_levels' of that level alone, whether all levels,
    the coarser ones or none are joined."""
    monkeypatch.setattr(level_tables, "KEPT_CELLS", kept_cells)
    source = ArrayPyramid(field((37, 50, 61)), spacing=(0.7, 1.0, 2.1), brick=(8, 8, 8))
    geometry = BrickGeometry(source)
    assert joined_levels(geometry) == {1 << 15: 0, 20: 2, 0: len(source.levels)}[kept_cells]
    for camera in cameras(source):
        size = (200, 120)
        view_projection = camera.view_projection(size[0] / size[1])
        tables = LevelTables(geometry, camera, size, view_projection, None, -1.0)
        for level in range(len(source.levels)):
            np.testing.assert_array_equal(tables(level, "rects"), screen_rects(geometry, view_projection, size, level))
            np.testing.assert_array_equal(tables(level, "wants"), desired_levels(geometry, camera, size, level, -1.0))


def box_rect(lo, hi, view_projection, size):
    """The rectangle of one box (x, y, w, h), corner by corner: its 8 corners projected, a pixel
    of margin, clamped to the viewport; the whole viewport where a corner is behind the eye, 0 where
    nothing is left."""
    xs, ys = [], []
    for corner in itertools.product(*zip(lo, hi)):
        clip = np.asarray(view_projection, dtype=np.float64) @ np.array([*corner, 1.0])
        if clip[3] <= 1e-9:
            return (0, 0, size[0], size[1])
        xs.append((clip[0] / clip[3] * 0.5 + 0.5) * size[0])
        ys.append((clip[1] / clip[3] * 0.5 + 0.5) * size[1])
    x0, y0 = max(np.floor(min(xs)) - 1, 0), max(np.floor(min(ys)) - 1, 0)
    w, h = max(min(np.ceil(max(xs)) + 1, size[0]) - x0, 0), max(min(np.ceil(max(ys)) + 1, size[1]) - y0, 0)
    return (0, 0, 0, 0) if w == 0 or h == 0 else (int(x0), int(y0), int(w), int(h))


def test_screen_rects_are_each_boxs_corners_projected():
    """screen_rects (one product over every corner, reduced row against row) gives each brick the
    rectangle of its own 8 corners, for cameras outside, inside (corners behind the eye) and
    orthographic."""
    source = ArrayPyramid(field((37, 50, 61)), spacing=(0.7, 1.0, 2.1), brick=(8, 8, 8))
    geometry = BrickGeometry(source)
    for camera in cameras(source):
        size = (200, 120)
        view_projection = camera.view_projection(size[0] / size[1])
        for level in range(len(source.levels)):
            rects = screen_rects(geometry, view_projection, size, level)
            lo, hi = level_tables.level_boxes(geometry, level)
            for index in np.ndindex(rects.shape[:3]):
                assert tuple(rects[index]) == box_rect(lo[index], hi[index], view_projection, size), (level, index)


def test_a_plan_of_arrays_gives_the_bricks_of_the_walk_and_compares_its_keys_as_sets():
    """FramePlan made of the walk's arrays: its bricks and keys are select_bricks' tuples, its levels
    theirs; key_set is the same for the same keys in any order (packed, or rows past 2^19 bricks
    an axis) and differs for others; key_sequence follows the order."""
    source = ArrayPyramid(field((37, 50, 61)), spacing=(0.7, 1.0, 2.1), brick=(8, 8, 8))
    camera = list(cameras(source))[-1]  # (the eye inside: bricks of two levels)
    size = (40, 40)
    view_projection = camera.view_projection(size[0] / size[1])
    args = (source, camera, size, view_projection, lambda level: np.ones(brick_grid(source.levels[level].shape, source.brick), bool), 1.5)
    plan = FramePlan((), 0, 0, None, selected_arrays(*args))
    assert plan.bricks == select_bricks(*args) and plan.keys() == [key for key, _ in plan.bricks]
    assert len(plan) == len(plan.bricks) and plan.levels() == sorted({key[0] for key in plan.keys()})
    assert len(plan.levels()) > 1  # (a walk of several levels)
    listed = FramePlan(plan.bricks)
    np.testing.assert_array_equal(listed.key_array, plan.key_array)
    reordered = plan.keys()[::-1]
    assert key_set(reordered) == plan.key_set() and hash(key_set(reordered)) == hash(plan.key_set())
    assert FramePlan([(key, (0, 0, 1, 1)) for key in reordered]).key_sequence() != plan.key_sequence()
    assert listed.key_sequence() == plan.key_sequence()
    assert key_set(plan.keys()[1:]) != plan.key_set()
    wide = [(0, 1 << 20, 3, 4), (1, 2, 3, 4), (0, 5, 1 << 19, 0)]
    assert key_set(wide) == key_set(wide[::-1]) and key_set(wide) != key_set(wide[:2])
    assert key_set([(0, 0, 0, 1 << 19)]) != key_set([(0, 0, 1, 0)])  # (not packed: no carry into the next index)


def test_cells_are_bricks_where_cells_of_bricks_changes_nothing(tmp_path):
    from helpers.foreign_stores import ome_zarr_py_image, opened
    data = (field((24, 60, 50)) * 60000).astype(np.uint16)
    path = ome_zarr_py_image(tmp_path / "image.zarr", data, scale_factors=[2, 4, 8, 16],  # y and x floored
                             storage_options={"chunks": (8, 8, 8)})
    store = opened(path)
    rng = np.random.default_rng(5)
    found = set()
    for level in range(len(store.levels)):
        per_brick = rng.random(brick_grid(store.levels[level].shape, store.brick)) < 0.5
        cells = cells_of_bricks(store, level, per_brick)
        same = cells.shape == per_brick.shape and np.array_equal(cells, per_brick)
        assert cells_are_bricks(store, level) == same
        found.add(cells_are_bricks(store, level))
    assert found == {True, False}  # both kinds of level were checked


@pytest.mark.parametrize("count", [1, 2, 5])
def test_axis_ranks_are_the_places_in_the_reversed_axis_order(count):
    cells = np.arange(count)
    for eye in [-3.0, 0.0, 0.5, 1.0, 2.5, 4.0, 9.0]:
        front_first = axis_order(count, eye, 1.0)[::-1]
        assert axis_ranks(cells, count, eye, 1.0, True)[front_first].tolist() == list(range(count))
    for towards in (1.0, -1.0):
        front_first = axis_order(count, None, towards)[::-1]
        assert axis_ranks(cells, count, None, towards, False)[front_first].tolist() == list(range(count))


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_brick_bytes_come_from_one_table_per_source(dtype):
    source = ArrayPyramid((field((20, 24, 28)) * 200).astype(dtype), brick=(8, 8, 8))
    itemsize = texture_format(source.dtype, source.value_range).itemsize
    keys = [(level, *cell) for level in range(len(source.levels)) for cell in np.ndindex(*cell_grid(source, level))]
    each = [int(np.prod(brick_texture_shape(source, key))) * itemsize for key in keys]
    assert bricks_bytes(source, keys) == sum(each)
    assert bricks_bytes(source, np.asarray(keys[3:9])) == sum(each[3:9]) and bricks_bytes(source, []) == 0
    assert level_brick_bytes(source) is level_brick_bytes(source)  # made once


def test_the_kept_geometry_is_one_per_source_and_does_not_keep_it_alive():
    source = ArrayPyramid(field((20, 24, 28)), brick=(8, 8, 8))
    geometry = BrickGeometry.of(source)
    assert BrickGeometry.of(source) is geometry and geometry.source is source
    alive = weakref.ref(source)
    del source
    gc.collect()
    assert alive() is None


@pytest.mark.parametrize("shading, compositing", [("none", "dvr"), ("blinn_phong", "dvr"), ("none", "iso")])
def test_a_still_frame_makes_no_new_block_flags_or_leaf_table(shading, compositing):
    """dvr, shaded or not, walks the frame's grid of skip radii (walk_grids), iso its grid of
    blocks of 4 with their slots (walk_grids.iso_grid): either is made once while the plan stays."""
    volume = Volume(field((40, 36, 44)))
    camera = Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))
    network = ray_caster_network(volume, camera, "BrickedRayCaster", brick_size=16, lod_bias=-16.0,
                                 method="single_pass", shading=shading, transfer_function=WINDOW,
                                 compositing=compositing, iso_level=0.5)
    first = np.asarray(network.evaluate("rc.image", size=(48, 40)))
    paged = network["rc"].parts[PagedSampling]
    flags, walk, table = paged.kept.flags.value, paged.kept.walk.value, paged.resolved
    network.set("rc.sampling_rate", 1.0 + 1e-6)  # evaluates again, the plan unchanged
    second = np.asarray(network.evaluate("rc.image", size=(48, 40)))
    assert paged.kept.flags.value is flags and paged.kept.walk.value is walk and paged.resolved is table
    assert walk is not None  # the frame walks a grid made once
    assert network["rc"].passes[-1].defines.get("PAGED_ISO_GRID" if compositing == "iso" else "PAGED_WALK")
    np.testing.assert_allclose(second, first, atol=1e-5)
