"""The replay's default observer start: the middle of the widest free rod arc, with exact ties
(a symmetric corridor) broken toward +x whatever order the arcs come in."""

import dataclasses
import math

import numpy as np
import pytest

import tether.follow.replay as replay_mod
from tether.arcs import free_arcs
from tether.errors import OutsideFreeSpaceError


def test_corridor_tie_goes_ahead(corridor):
    """At (4, 0.5) in the 1-wide corridor the rod's arcs toward -x and +x are exactly equally
    wide (walls at y = 0 and 1, both ends clear of the corner): the start is (5, 0.5)."""
    fa = free_arcs(corridor, np.array([4.0, 0.5]), 1.0)
    assert len(fa.arcs) == 2 and fa.arcs[0].length == fa.arcs[1].length
    o = replay_mod.start_observer(corridor, np.array([4.0, 0.5]), 1.0)
    assert o == pytest.approx([5.0, 0.5], abs=1e-12)


@pytest.mark.parametrize("order", [slice(None), slice(None, None, -1)])
def test_tie_does_not_depend_on_arc_order(corridor, monkeypatch, order):
    real = replay_mod.free_arcs

    def reordered(env, p, lss):
        fa = real(env, p, lss)
        return dataclasses.replace(fa, arcs=list(fa.arcs)[order])

    monkeypatch.setattr(replay_mod, "free_arcs", reordered)
    o = replay_mod.start_observer(corridor, np.array([4.0, 0.5]), 1.0)
    assert o == pytest.approx([5.0, 0.5], abs=1e-12)


def test_widest_wins_and_rod_is_free(corridor):
    """Off the middle the arcs differ; the start is the wider arc's middle, at lss, and the
    rod there is free (checked by sampling the rod against the map)."""
    p = np.array([4.0, 0.3])
    fa = free_arcs(corridor, p, 1.0)
    widest = max(fa.arcs, key=lambda x: x.length)
    o = replay_mod.start_observer(corridor, p, 1.0)
    a = math.atan2(o[1] - p[1], o[0] - p[0])
    assert abs(math.remainder(a - (widest.start + 0.5 * widest.length), 2 * math.pi)) < 1e-12
    assert np.hypot(*(o - p)) == pytest.approx(1.0)
    for s in np.linspace(0.0, 1.0, 101):
        q = p + s * (o - p)
        assert 0.0 < q[1] < 1.0 and 0.0 < q[0] < 6.0


def test_no_free_rod_is_one_clear_error(corridor):
    with pytest.raises(OutsideFreeSpaceError, match="no free rod"):
        replay_mod.start_observer(corridor, np.array([4.0, 0.5]), 10.0)
