"""Which bricked method draws a frame (issue #33, item 3): a pass per brick (BrickSampling,
vgraph.bricks.sampling) or one pass through a page table (PagedSampling, vgraph.bricks.paged_sampling).

``auto`` (the BrickedRayCaster's default, and the rule of the RayCaster's hand-over for a volume
one texture cannot hold) takes the single pass where it measured faster and passes elsewhere
(docs/explanations/bricked-ray-casting.md, "Which method draws"):
- dvr (shaded or not, with or without early termination) and iso: the single pass, 1.5-3x faster
  than a pass per brick on llvmpipe (bench/bench_paged_bricks.py, bonsai 256^3 and a 512^3
  volume, 32^3 and 64^3 bricks);
- mip: passes. Its single pass jumps over no block below the running maximum (the pass per brick
  does), so it samples every step of a drawn cell and measured slower with 64^3 bricks;
- a frame of the leaves split (FrameContext.leaf, vgraph.distributed.leaves): passes. A leaf draws
  its run of bricks into an accumulation that the next worker continues; the single pass has no
  such partial frame;
- a leaf table of more than AUTO_TABLE_SHARE of min(ram_budget, gl_budget) (leaf_table_need):
  passes, whose memory follows the budgets. The table is memory beyond both budgets: the 8192^3
  virtual store in 64^3 bricks (a 128 MiB table) under 128 + 128 MB grew the peak RSS by 301 MiB
  in one pass, past the 256 MB that tests/test_virtual_store.py holds it to.
``passes`` and ``single_pass`` force one; ``single_pass`` refuses a leaf frame and a leaf table
past the budgets by name.
"""

from __future__ import annotations

import math

from vgraph.bricks.cache import MB
from vgraph.bricks.pyramid import brick_grid
from vgraph.errors import VGraphError
from vgraph.memory import format_bytes

METHODS = ("auto", "passes", "single_pass")
SINGLE_PASS_MODES = ("dvr", "iso")  # where the single pass measured faster (module docstring)
# The single pass's page table resolves to a leaf table of one RGBA32F texel per level-0 brick,
# held about this many times while a frame builds it (entries, leaf, fallback, the texture):
# 128 MiB at 8192^3 in 64^3 bricks, 1 GiB at 16384^3, which is refused rather than allocated
LEAF_TABLE_BYTES, LEAF_TABLE_COPIES = 16, 4
AUTO_TABLE_SHARE = 1 / 8  # auto's single pass: the leaf table small beside the budgets (module docstring)


def leaf_table_need(source) -> tuple[int, int]:
    """(level-0 bricks, bytes) of the single pass's leaf table for ``source`` (a BrickSource)."""
    cells = math.prod(brick_grid(source.levels[0].shape, source.brick))
    return cells, cells * LEAF_TABLE_BYTES * LEAF_TABLE_COPIES


def chosen_method(processor, source, leaf, name: str) -> str:
    """'passes' or 'single_pass' for this frame of ``processor`` (its ``method``, ``compositing``,
    ``ram_budget`` and ``gl_budget``; the RayCaster has no ``method``: auto), drawing ``source``
    with the frame context's ``leaf`` (None outside the leaves split); ``name``: the volume's, for errors."""
    method = getattr(processor, "method", "auto")
    if method == "passes":
        return method
    cells, need = leaf_table_need(source)
    budget = min(processor.ram_budget, processor.gl_budget) * MB
    if method == "single_pass":
        if leaf is not None:
            raise VGraphError(f"{processor.id}.method: single_pass does not draw the leaves split's runs of "
                              f"bricks (a worker's partial frame); use method 'passes' or 'auto'")
        if need > budget:
            raise VGraphError(f"{processor.id}.method: single_pass keeps a leaf table of one RGBA32F texel per "
                              f"level-0 brick ({cells} bricks of {name}), about "
                              f"{format_bytes(need)} while a frame builds it, more than min(ram_budget, "
                              f"gl_budget) = {format_bytes(budget)}: use method 'passes' (its memory follows "
                              f"the budgets) or larger bricks")
        return method
    fits = leaf is None and need <= AUTO_TABLE_SHARE * budget
    return "single_pass" if fits and processor.compositing in SINGLE_PASS_MODES else "passes"

