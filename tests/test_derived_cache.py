"""The one cache for derived data (vgraph.derived): hits and misses counted, entries keyed by the
source and the parameters, released with the source or the context, GL memory given back."""

import gc
import re
import weakref

import moderngl
import numpy as np

from vgraph import derived
from vgraph.box_frame import BoxFrame
from vgraph.camera import Camera
from vgraph.gl_context import collect_garbage, get_context
from vgraph.gl.raycasting.framed_view import volume_in_frame
from vgraph.implicit import sample
from vgraph.leaks import live_gl_textures
from vgraph.shown_content import voxels_under
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import rendering_network
from helpers.paths import REPO

SIZE = (24, 20)
# What a shaded frame with precomputed gradients and empty-space skipping derives from its volume.
FRAME_KINDS = ("volume texture", "gradient texture", "gradient scale", "block ranges")


class Source:
    """A stand-in source object (anything that can be weakly referenced)."""


class OtherContext:
    """A stand-in for a second context (entries are keyed by the context's identity), so that
    forgetting it leaves the shared context's entries of the other tests alone."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def camera_of(volume, direction) -> Camera:
    """A camera on the volume's box centre from ``direction``, three box sizes away."""
    low, high = volume.world_box()
    centre = (low + high) / 2
    position = centre + 3.0 * float(np.max(high - low)) * np.asarray(direction, dtype=float)
    return Camera(position=tuple(position), focus=tuple(centre))


def shaded_network(volume):
    camera = camera_of(volume, (0.6, 0.4, 0.7))
    return rendering_network(volume, camera, compositing="dvr", shading="blinn_phong",
                             derivatives="precomputed")


def counts(kinds=FRAME_KINDS) -> dict:
    stats = derived.stats()
    return {kind: (stats[kind].hits, stats[kind].misses) for kind in kinds}


def test_a_value_is_made_once_and_a_changed_parameter_misses():
    source, made = Source(), []

    def make(value):
        return lambda: made.append(value) or value

    derived.reset_stats()
    assert derived.value(source, "test kind", make("a"), params=1) == "a"
    assert derived.value(source, "test kind", make("b"), params=1) == "a"   # a hit: not made again
    assert derived.value(source, "test kind", make("c"), params=2) == "c"   # other params: made anew
    assert derived.value(source, "test kind", make("d"), params=2) == "c"
    assert made == ["a", "c"]
    stats = derived.stats()["test kind"]
    assert (stats.hits, stats.misses, stats.entries) == (2, 2, 1)  # the new params replaced the entry


def test_a_second_frame_of_the_same_volume_hits():
    volume = sample("sphere", 16, "float32")
    network = shaded_network(volume)
    derived.reset_stats()
    first = network.evaluate("rc.image", size=SIZE)
    after_first = counts()
    assert all(misses == 1 for _, misses in after_first.values()), after_first
    network.set("eep.camera", camera_of(volume, (-0.5, 0.4, 0.75)))
    second = network.evaluate("rc.image", size=SIZE)
    after_second = counts()
    assert all(misses == 1 for _, misses in after_second.values()), after_second  # nothing made again
    for kind in ("volume texture", "gradient texture"):  # asked again (the block ranges are not:
        assert after_second[kind][0] > after_first[kind][0], (kind, after_second)  # same skip blocks)
    assert first[..., 3].max() > 0.5 and not np.array_equal(first, second)  # a real, other view


def test_a_volume_moved_into_another_frame_is_a_miss_and_the_same_frame_a_hit():
    volume = sample("sphere", 16, "float32")
    derived.reset_stats()
    near, far = BoxFrame(centre=(1.0, 2.0, 3.0), scale=1e-3), BoxFrame(centre=(5.0, 0.0, 0.0), scale=1e3)
    copy = volume_in_frame(volume, near)
    assert volume_in_frame(volume, near) is copy
    other = volume_in_frame(volume, far)
    assert other is not copy and np.allclose(other.spacing, np.asarray(volume.spacing) / 1e3, rtol=1e-12)
    stats = derived.stats()["volume in frame"]
    assert (stats.hits, stats.misses) == (1, 2)


def test_entries_go_with_their_volume_and_their_gl_memory_is_freed():
    ctx = get_context()

    def render_and_drop():
        volume = sample("torus", 16, "float32")
        network = shaded_network(volume)
        network.evaluate("rc.image", size=SIZE)
        texture = derived.peek(volume, "volume texture", ctx=ctx)
        gradients = derived.peek(volume, "gradient texture", ctx=ctx)
        assert texture is not None and gradients is not None
        alive = weakref.ref(volume)
        del network, volume
        gc.collect()
        collect_garbage()
        assert alive() is None
        return texture, gradients, live_gl_textures(ctx)

    texture, gradients, before = render_and_drop()
    entries = {kind: derived.stats()[kind].entries for kind in FRAME_KINDS}
    for _ in range(3):
        texture, gradients, after = render_and_drop()
        assert isinstance(texture.mglo, moderngl.InvalidObject)
        assert isinstance(gradients.mglo, moderngl.InvalidObject)
        assert {kind: derived.stats()[kind].entries for kind in FRAME_KINDS} == entries
    assert after <= before


def test_entries_made_on_a_context_are_released_with_it():
    ctx, other, source = get_context(), OtherContext(), Source()
    texture = derived.value(source, "test texture", lambda: ctx.texture((4, 4), 1), ctx=other)
    shared = derived.value(source, "test texture", lambda: ctx.texture((4, 4), 1), ctx=ctx)
    kept = derived.value(source, "test number", lambda: 42)
    derived.forget_context(other)  # what vgraph.gl_context does when a context is released
    assert isinstance(texture.mglo, moderngl.InvalidObject)
    assert derived.peek(source, "test texture", ctx=other) is None
    assert derived.peek(source, "test texture", ctx=ctx) is shared  # another context's: kept
    assert not isinstance(shared.mglo, moderngl.InvalidObject)
    assert derived.peek(source, "test number") == kept == 42  # not made on a context: kept


def test_a_gl_object_released_by_someone_else_is_made_again():
    ctx, source = get_context(), Source()
    texture = derived.value(source, "test texture", lambda: ctx.texture((4, 4), 1), ctx=ctx)
    texture.release()
    again = derived.value(source, "test texture", lambda: ctx.texture((4, 4), 1), ctx=ctx)
    assert again is not texture and not isinstance(again.mglo, moderngl.InvalidObject)


def test_no_module_level_cache_dictionaries_and_no_private_moderngl_api_remain():
    """Derived data lives in vgraph.derived only: no WeakKeyDictionary elsewhere, nothing stamped
    onto moderngl's objects, no ``program._members``."""
    offenders = []
    for folder in ("src/vgraph", "processors"):
        for path in sorted((REPO / folder).rglob("*.py")):
            if path.name == "derived.py":
                continue
            text = path.read_text(encoding="utf-8")
            for pattern in (r"WeakKeyDictionary", r"\._members\b", r"\._vgraph_\w+"):
                offenders += [f"{path.relative_to(REPO)}: {m.group(0)}" for m in re.finditer(pattern, text)]
    assert offenders == []


def test_what_a_renderer_shows_is_kept_in_the_cache_not_on_the_volume():
    """The blank-image diagnosis asks each frame what a renderer's input shows (vgraph.shown_content):
    worked out once per rule and planes, kept by vgraph.derived, nothing stashed in the volume."""
    volume = Volume(np.linspace(0.0, 1.0, 64, dtype=np.float32).reshape(4, 4, 4))
    high_only = TransferFunction(points=[[0.0, 1, 1, 1, 0.0], [0.6, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 1.0]])
    derived.reset_stats()
    shown = voxels_under("volume", volume, high_only)
    # opacity above 0 from 0.6 up: the voxels 38 / 63 .. 63 / 63
    assert shown.share() == voxels_under("volume", volume, high_only).share() == 26 / 64
    shown.presence()
    shown.presence()
    stats = derived.stats()
    assert [(stats[kind].hits, stats[kind].misses) for kind in ("shown share: transfer_function",
                                                                "shown presence: transfer_function")] == [(1, 1), (1, 1)]
    assert [key for key in vars(volume) if "shown" in str(key)] == []
