"""The single pass's leaf table in a directory and pages (vgraph.bricks.leaf_pages; issue #33):
every level-0 cell, looked up as the shader does (bricks/paged_sampling.glsl, leaf_texel), finds
the entry of the flat leaf table that PageTable.resolve makes over the whole volume, at every
directory level, on plans with levels mixed, missing cells, empty cells and stale atlas bricks;
the wanted values name the missing cell holding each level-0 cell; the shader's look-up through
the directory draws the in-core image; and the table's size is bounded by the atlas's slots, not
the volume."""

import itertools
import math

import numpy as np
import pytest

from vgraph.bricks import leaf_pages
from vgraph.bricks.leaf_pages import POINTER, build, directory_level, table_bound
from vgraph.bricks.implicit_url import open_implicit
from vgraph.bricks.page_table import PageTable
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.paged_sampling import PagedSampling
from vgraph.bricks.brick_geometry import BrickGeometry

from helpers.bricked import FINEST, WINDOW, odd_volume, oblique, render
from helpers.networks import UNSHADED_RAMP


def looked_up(leaf, grid0) -> tuple[np.ndarray, np.ndarray]:
    """The entry and the wanted value of every level-0 cell ([z, y, x] of ``grid0``), read as leaf_texel
    reads them: the directory entry of the cell's directory cell, and the page's texel where it points."""
    cells = leaf.page_cells
    entries = np.zeros(tuple(grid0) + (4,), dtype=np.float32)
    wanted = np.zeros(tuple(grid0), dtype=np.float32)
    for z, y, x in np.ndindex(*grid0):
        cell = np.array([x, y, z])
        directory = cell // cells
        entry = leaf.table[directory[2], directory[1], directory[0]]
        at = entry[:3].astype(int) + cell - directory * cells if entry[3] >= POINTER else directory
        entries[z, y, x], wanted[z, y, x] = leaf.table[at[2], at[1], at[0]], leaf.wanted[at[2], at[1], at[0]]
    return entries, wanted


def random_frame(geometry: BrickGeometry, rng):
    """A plan as the walk makes them (cells refined down the octree, planned, or left out: empty),
    and atlas bricks of any level (some planned, some not: the atlas keeps earlier frames' bricks)."""
    planned = []

    def walk(level, index):
        if any(i >= n for i, n in zip(index, geometry.grids[level][::-1])):
            return
        draw = rng.random()
        if level > 0 and draw < 0.55:
            ratio = [int(r) for r in geometry.ratios[level][::-1]]
            for step in itertools.product(*[range(r) for r in ratio]):
                walk(level - 1, tuple(i * r + s for i, r, s in zip(index, ratio, step)))
        elif draw < 0.85:
            planned.append((level,) + index)

    top = len(geometry.grids) - 1
    for index in np.ndindex(*geometry.grids[top][::-1]):
        walk(top, tuple(index))
    every = [(level,) + index for level in range(top + 1) for index in np.ndindex(*geometry.grids[level][::-1])]
    resident = np.asarray([key for key in every if rng.random() < 0.3], dtype=np.int64).reshape(-1, 4)
    return planned, resident, np.round(rng.random((len(resident), 3)) * 100.0, 1)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_level_0_cell_finds_the_flat_leaf_tables_entry_at_every_directory_level(seed):
    rng = np.random.default_rng(seed)
    source = ArrayPyramid(np.zeros((37, 50, 45), dtype=np.float32), brick=(4, 4, 4))  # 12 x 13 x 10 cells, 5 levels
    geometry = BrickGeometry(source)
    planned, resident, offsets = random_frame(geometry, rng)
    lows = {level: rng.random(tuple(geometry.grids[level][::-1])) for level in range(len(geometry.grids))}
    flat = PageTable.resolve(geometry, PageTable.entries(geometry, planned, (resident, offsets), lows.__getitem__))
    in_atlas = {tuple(key) for key in resident.tolist()}
    missing = [key for key in planned if key not in in_atlas]
    levels = {key[0] for key in planned}
    assert len(levels) >= 3 and missing and (flat[..., 3] < 0).any() and (flat[..., 3] > 1).any()  # a mixed frame
    pages = []
    for directory in range(len(geometry.grids)):
        leaf = build(geometry, planned, resident, offsets, lows.__getitem__, slots=64, directory=directory)
        entries, wanted = looked_up(leaf, flat.shape[:3])
        np.testing.assert_array_equal(entries, flat)
        assert [tuple(key) for key in leaf.missing.tolist()] == missing
        assert leaf.undrawn == bool((flat[..., 3] < 0).any())
        assert leaf.pages <= len([key for key in planned if key[0] < directory])  # a page per finer cell at most
        pages.append(leaf.pages)
        # wanted: 1 + the index of the missing cell holding the level-0 cell
        for z, y, x in np.ndindex(*flat.shape[:3]):
            holder = [i for i, key in enumerate(missing) if
                      all(c * s <= v * s0 < (c + 1) * s for c, v, s, s0 in
                          zip(key[1:], (z, y, x), geometry.spans[key[0]][::-1], geometry.spans[0][::-1]))]
            assert wanted[z, y, x] == (holder[0] + 1 if holder else 0)
    assert pages[0] == 0 and min(pages[1:-1]) > 0  # flat at 0; pointers and pages between


def test_the_directory_is_flat_for_small_volumes_and_pages_past_them():
    small = BrickGeometry(ArrayPyramid(np.zeros((64, 64, 64), dtype=np.uint8), brick=(8, 8, 8)))
    assert directory_level(small, 10) == 0 and table_bound(small, 10) == 512
    large = BrickGeometry.of(open_implicit("implicit:torus?size=16384&brick=64"))  # 256^3 level-0 cells
    for slots in (10, 426, 853):
        level = directory_level(large, slots)
        texels = math.prod(int(n) for n in large.grids[level]) + slots * 8 ** level
        assert level > 0 and table_bound(large, slots) == texels
        assert texels * leaf_pages.TEXEL_BYTES < 7 * 2 ** 20 < 256 ** 3 * 16  # 6 MiB at most where flat is 256 MiB


@pytest.mark.parametrize("compositing", ["dvr", "iso"])
def test_the_shader_through_the_directory_and_pages_draws_the_in_core_image(monkeypatch, compositing):
    """A small volume gets the flat table; with FLAT_CELLS at 0 it gets a directory, pointers and
    pages (PAGE_DIRECTORY), and the image at level 0 is the flat table's, the in-core RayCaster's."""
    volume = odd_volume()
    camera = oblique(volume)
    properties = {**UNSHADED_RAMP, "compositing": compositing,
                  **({"transfer_function": WINDOW, "early_termination": 0.99} if compositing == "dvr"
                     else {"iso_level": 0.3, "shading": "blinn_phong"})}
    want, _, _ = render(volume, camera, "RayCaster", **properties)
    flat, _, rc = render(volume, camera, method="single_pass", brick_size=8, lod_bias=FINEST, **properties)
    assert rc.parts[PagedSampling].resolved.level == 0
    monkeypatch.setattr(leaf_pages, "FLAT_CELLS", 0)
    got, _, rc = render(volume, camera, method="single_pass", brick_size=8, lod_bias=FINEST, **properties)
    table = rc.parts[PagedSampling].resolved
    assert table.level > 0 and table.pages > 0
    assert rc.last_frame["levels"] == [0] and want[..., 3].max() > 0.3
    np.testing.assert_allclose(got, flat, atol=1e-6)
    assert np.abs(got - want).max() <= 1 / 255
