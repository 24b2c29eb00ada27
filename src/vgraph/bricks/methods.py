"""Which bricked method draws a frame (issue #33, item 3): a pass per brick (BrickSampling,
vgraph.bricks.sampling) or one pass through a page table (PagedSampling, vgraph.bricks.paged_sampling).

``auto`` (the BrickedRayCaster's default, and the rule of the RayCaster's hand-over for a volume
one texture cannot hold) takes the single pass where it measured faster and passes elsewhere
(docs/explanations/bricked-ray-casting.md, "Which method draws"):
- dvr (shaded or not, with or without early termination), iso and mip: the single pass, 1.5-3x
  faster than a pass per brick on llvmpipe in dvr and iso, 2-3x in mip since its rays walk a grid
  of block maxima largest first as the RayCaster's (vgraph.bricks.walk_grids; before, front to back,
  it was 1.1-1.2x slower) (bench/bench_paged_bricks.py, bonsai 256^3 and a 512^3 volume, 32^3 and
  64^3 bricks);
- a frame of the leaves split (FrameContext.leaf, vgraph.distributed.leaves): passes. A leaf draws
  its run of bricks into an accumulation that the next worker continues; the single pass has no
  such partial frame;
- a leaf table of more than AUTO_TABLE_SHARE of min(ram_budget, gl_budget) (leaf_table_need):
  passes, whose memory follows the budgets. The table is memory beyond both budgets. Since it is
  a directory and pages (vgraph.bricks.leaf_pages) its size follows the atlas's slots, not the
  volume (the 8192^3 virtual store in 64^3 bricks under 128 + 128 MB: 1.2 MiB where one texel
  per level-0 cell was 32 MiB), so this holds only for budgets of a few slots.
- a volume whose budgets hold its whole pyramid only from level COARSE_LEVEL up
  (``whole_volume_level`` of min(ram_budget, gl_budget); the 8192^3 and 16384^3 virtual stores
  in 64^3 bricks under 256 MB: levels 5 and 6):
  passes, for memory: the 8192^3 store under 128 + 128 MB grew the process's peak memory by
  324 MiB in one pass, past the 256 MB tests/test_virtual_store.py bounds it by, where passes
  stay within it. Speed no longer decides since the single pass steps each level's lattice
  (PAGED_STRIDE, vgraph.bricks.paged_strides): its first frame 5.5-9.4 s against 5.3-6.0 by
  passes (135 s when it sampled level 0's lattice everywhere), each still frame after 3x faster
  (bench/bench_virtual_store.py; docs/explanations/bricked-ray-casting.md, "Which method draws").
  The 1024^3 bonsai store (level 2) stays on the single pass.
``passes`` and ``single_pass`` force one; ``single_pass`` refuses a leaf frame and a leaf table
past the budgets by name.
"""

from __future__ import annotations

import math

from vgraph import derived
from vgraph.bricks.atlas import brick_count, slot_shape_of
from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.cache import HALO, MB, texture_format
from vgraph.bricks.cells import table_of
from vgraph.bricks.leaf_pages import TEXEL_BYTES, table_bound
from vgraph.errors import VGraphError
from vgraph.memory import format_bytes

METHODS = ("auto", "passes", "single_pass")
SINGLE_PASS_MODES = ("dvr", "iso", "mip")  # where the single pass measured faster (module docstring)
# The single pass's leaf table (vgraph.bricks.leaf_pages: RGBA32F entries and R32F wanted values),
# held about this many times while a frame builds and uploads it (leaf, fallback, gathers, bytes)
LEAF_TABLE_COPIES = 4
AUTO_TABLE_SHARE = 1 / 8  # auto's single pass: the leaf table small beside the budgets (module docstring)
COARSE_LEVEL = 3  # auto: passes where the budgets hold the whole volume only from this level up (module docstring)


def whole_volume_level(source, budget_bytes: float) -> int:
    """The finest level of ``source`` whose bricks, with their halos in the texture format, fit
    ``budget_bytes`` together (the top level where none does). Per axis sums, not a table of bricks:
    level 0 of a 16384^3 volume in 64^3 bricks has 16.7 M."""
    itemsize = texture_format(source.dtype, source.value_range).itemsize
    spans = table_of(source).spans  # per level, per axis [z, y, x]: the cores' (starts, stops)
    for level, axes in enumerate(spans):
        if math.prod(int((stops - starts + 2 * HALO).sum()) for starts, stops in axes) * itemsize <= budget_bytes:
            return level
    return len(spans) - 1


def leaf_table_need(source, gl_budget_mb: float) -> tuple[int, int]:
    """(texels, bytes) of the single pass's leaf table for ``source`` (a BrickSource) at most, with
    the atlas's slots of ``gl_budget_mb`` (as many as one byte a voxel gives: the most)."""
    def need() -> tuple[int, int]:
        slots = min(int(gl_budget_mb * MB) // math.prod(slot_shape_of(source)), brick_count(source))
        texels = table_bound(BrickGeometry.of(source), max(slots, 1))
        return texels, texels * TEXEL_BYTES * LEAF_TABLE_COPIES
    # asked every frame (chosen_method): made once per source and budget (vgraph.derived)
    return derived.value(source, "leaf table need", need, params=(float(gl_budget_mb),))


def chosen_method(processor, source, leaf, name: str) -> str:
    """'passes' or 'single_pass' for this frame of ``processor`` (its ``method``, ``compositing``,
    ``ram_budget`` and ``gl_budget``; the RayCaster has no ``method``: auto), drawing ``source``
    with the frame context's ``leaf`` (None outside the leaves split); ``name``: the volume's, for errors."""
    method = getattr(processor, "method", "auto")
    if method == "passes":
        return method
    texels, need = leaf_table_need(source, processor.gl_budget)
    budget = min(processor.ram_budget, processor.gl_budget) * MB
    if method == "single_pass":
        if leaf is not None:
            raise VGraphError(f"{processor.id}.method: single_pass does not draw the leaves split's runs of "
                              f"bricks (a worker's partial frame); use method 'passes' or 'auto'")
        if need > budget:
            raise VGraphError(f"{processor.id}.method: single_pass keeps a leaf table of up to {texels} texels "
                              f"for {name} (a directory and pages), about {format_bytes(need)} while a frame "
                              f"builds it, more than min(ram_budget, gl_budget) = {format_bytes(budget)}: use "
                              f"method 'passes' (its memory follows the budgets) or a larger budget")
        return method
    fits = leaf is None and need <= AUTO_TABLE_SHARE * budget and whole_volume_level(source, budget) < COARSE_LEVEL
    return "single_pass" if fits and processor.compositing in SINGLE_PASS_MODES else "passes"

