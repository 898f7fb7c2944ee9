"""The results reported in the user's frame, and the collector's pause around the computation."""

from __future__ import annotations

import gc

from tether.decomposition import gc_paused


class _Node:
    """A small object able to form a reference cycle."""

    def __init__(self) -> None:
        self.other: object = None


def test_gc_paused_restores_the_collector_and_freezes_nothing():
    was = gc.isenabled()
    gc.enable()
    try:
        with gc_paused():
            assert not gc.isenabled()
            with gc_paused():  # nested: the inner pause leaves the collector off
                pass
            assert not gc.isenabled()
            kept = [_Node() for _ in range(1000)]
        assert gc.isenabled()
        assert gc.get_freeze_count() == 0
        # the objects made during the pause were promoted, not lost: a cycle among them is
        # still collected by a full collection
        a, b = kept[0], kept[1]
        a.other, b.other = b, a
        del kept, a, b
        assert gc.collect() >= 2
    finally:
        if not was:
            gc.disable()


def test_gc_paused_leaves_a_callers_frozen_objects_frozen():
    was = gc.isenabled()
    gc.enable()
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        with gc_paused():
            pass
        assert gc.get_freeze_count() == frozen
    finally:
        gc.unfreeze()
        if not was:
            gc.disable()
