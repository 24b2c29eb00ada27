"""PagedSampling's kept values (vgraph.bricks.kept_frame.Kept): made again exactly when the key
changes or the value is no longer live, and never kept from a make() that failed."""

import pytest

from vgraph.bricks.kept_frame import Kept


def test_a_kept_value_is_made_again_only_for_a_new_key_or_a_dead_value():
    kept, made = Kept(), []

    def make(value):
        def build():
            made.append(value)
            return value
        return build

    assert kept.get(("a", 1), make("x")) == "x"
    assert kept.get(("a", 1), make("y")) == "x" and made == ["x"]
    assert kept.get(("a", 2), make("y")) == "y" and made == ["x", "y"]
    assert kept.get(("a", 2), make("z"), live=lambda value: value == "y") == "y"
    assert kept.get(("a", 2), make("z"), live=lambda value: False) == "z" and made == ["x", "y", "z"]
    assert kept.get(None, make(None)) is None and kept.get(None, make("w")) is None  # None is a key too


def test_a_failed_make_keeps_nothing():
    kept = Kept()
    kept.get(1, lambda: "x")

    def fail():
        raise RuntimeError("no GL")
    with pytest.raises(RuntimeError):
        kept.get(2, fail)
    assert kept.get(1, lambda: "again") == "again"  # the old value is not taken for its key after the failure
