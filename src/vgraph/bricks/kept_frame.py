"""What the single pass (vgraph.bricks.paged_sampling) keeps from one frame for the next: each
value with the key it was made from, made again only when the key changes (or its GL objects are
not on the frame's context), in one object per PagedSampling (KeptFrame)."""

from __future__ import annotations


class Kept:
    """A value a frame made and the key it was made from: a later frame with the same key takes it
    instead of making it again, while ``live(value)`` (its GL objects are on the frame's context)."""

    _NOTHING = object()

    def __init__(self):
        self.key, self.value = Kept._NOTHING, None

    def get(self, key, make, live=None):
        if self.key is Kept._NOTHING or self.key != key or (live is not None and not live(self.value)):
            self.key = Kept._NOTHING  # (not kept should make() fail)
            self.value = make()
            self.key = key
        return self.value


class KeptFrame:
    """What PagedSampling's frames keep for the next: each made again only when what it is made
    from changed (a still plan, a camera that moves within the plan's bricks, a new sampling rate:
    none is made again). ``table``: the leaf table (LeafPages, uploaded) of the plan's keys and the
    atlas's bricks; ``walk``: the walk grid's binding (walk_grids) of the table, the mode and the
    skipping opacity, or iso's grid's (walk_grids.iso_grid) of the plan's bricks, the atlas's and
    the level; ``flags``: the block flags' binding of the atlas's blocks, the rule and the
    plan's bricks; ``uniforms``: the pyramid's uniforms of the geometry, the atlas's shape and the
    bricks' format; ``placed``: the set of keys the last frame placed (selection.KeyArray),
    every one in the atlas, with the atlas's state after (paged_sampling.atlas_state), or None."""

    def __init__(self):
        self.table, self.walk, self.flags, self.uniforms = Kept(), Kept(), Kept(), Kept()
        self.placed = None


def on_context(gl: dict, name: str, ctx) -> bool:
    """Whether ``gl`` holds a texture ``name`` made on ``ctx`` (a kept binding's is still usable)."""
    texture = gl.get(name)
    return texture is not None and texture.ctx is ctx
