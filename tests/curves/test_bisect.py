"""The bisection of the critical parts' ends with candidate edges found once per transition
against the bisection testing every round's rods from scratch (the earlier form, kept here):
the very same parameters. And the motion bounds it relies on, against dense sampling."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, STAR_HOLE

import tether.curves.critical as critical
from tether.arcs import rod_is_free_many
from tether.curves import candidate_families
from tether.curves.critical import _BISECTIONS, critical_intervals
from tether.examples.floorplan import floor_plan


def _bisect_reference(env, sub, ta, tb, fa):
    """The bisection as it was: every round's rods through ``rod_is_free_many``."""
    for _ in range(_BISECTIONS):
        mid = 0.5 * (ta + tb)
        fm = rod_is_free_many(env, sub.points(None, mid), sub.rod_angles(None, mid), sub.lss)
        move_a = fm == fa
        ta = np.where(move_a, mid, ta)
        tb = np.where(move_a, tb, mid)
    return np.where(fa, ta, tb)


def _families(env, rel):
    inner = env.internal
    return inner, candidate_families(inner, (env.bounds[2] - env.bounds[0]) * rel
                                     * env.frame.scale)


@pytest.mark.parametrize("env, rel", [(floor_plan(150, seed=2), 1 / 15),
                                      (floor_plan(60, seed=7), 1 / 6),
                                      (GENERIC, 0.3), (STAR_HOLE, 0.4)])
@pytest.mark.slow
def test_bisect_matches_reference(env, rel, monkeypatch):
    inner, fams = _families(env, rel)
    calls = []
    real = critical._bisect

    def spy(env_, sub, ta, tb, fa):
        got = real(env_, sub, ta, tb, fa)
        calls.append((sub.kind, got, _bisect_reference(env_, sub, ta, tb, fa)))
        return got

    monkeypatch.setattr(critical, "_bisect", spy)
    for fam in fams:
        critical_intervals(inner, fam)
    assert sum(len(g) for _, g, _ in calls) > 20
    for kind, got, ref in calls:
        assert got.tobytes() == ref.tobytes(), kind


@pytest.mark.parametrize("width", [1e-8, 1e-4, 0.05])
def test_motion_bound_holds(width):
    """Rods sampled densely over each interval stay within the bounds from the rod at its
    start: target end (map units) and direction (radians), up to rounding (``rod_rows``
    adds margins far above it: ``1e-9`` rad, ``1e-12`` of lss)."""
    env = floor_plan(80, seed=4)
    inner, fams = _families(env, 1 / 10)
    rng = np.random.default_rng(0)
    for fam in fams:
        if len(fam) == 0:
            continue
        span = fam.hi - fam.lo
        ta = fam.lo + rng.random(len(fam)) * (1 - width) * span
        tb = ta + width * span
        sub = fam.rows(np.arange(len(fam)))
        dp, du = sub.motion_bound(ta, tb)
        q0, a0 = sub.points(None, ta), sub.rod_angles(None, ta)
        for f in np.linspace(0.0, 1.0, 17):
            t = ta + f * (tb - ta)
            q, a = sub.points(None, t), sub.rod_angles(None, t)
            assert np.all(np.hypot(*(q - q0).T) <= dp * (1 + 1e-9) + 1e-13 * fam.lss), fam.kind
            turn = np.abs((a - a0 + np.pi) % (2 * np.pi) - np.pi)
            assert np.all(turn <= du * (1 + 1e-9) + 1e-13), fam.kind
        assert np.all(np.isfinite(dp[np.isfinite(du)]))
