"""The candidate families: the apex marks of all conchoids at once against the former loop,
and the curves converted to the user's frame at once against each curve's own conversion."""

from __future__ import annotations

import pytest
from conftest import GENERIC, STAR_HOLE

import tether.curves.families as F
from tether.curves import critical_curves, curves_to_user
from tether.examples.floorplan import floor_plan


def reference_mark_apexes(fa, fe):
    """The former conchoid-by-conchoid loop of ``_mark_apexes``."""
    fe.marks.extend([] for _ in range(len(fe)))
    for c, feats in enumerate(fe.features):
        i = int(feats[1][1:])
        d = fe.d[c]
        s = float((fe.p[c] - fe.w[c]) @ d / (d @ d))
        if fe.lo[c] < s < fe.hi[c]:
            q = fa.p[i] + s * fa.d[i]
            fa.marks[i].append((s, q))
            fe.marks[c].append((s, q))


@pytest.mark.parametrize(("env", "lss"), [(GENERIC, 2.5), (STAR_HOLE, 1.5),
                                          (floor_plan(150, seed=2), 1.2)])
def test_mark_apexes_equals_the_loop(env, lss, monkeypatch):
    """The apex marks computed for all conchoids at once: the loop's floats and points."""
    inner = env.internal
    got = F.candidate_families(inner, lss * env.frame.scale)
    with monkeypatch.context() as mp:
        mp.setattr(F, "_mark_apexes", reference_mark_apexes)
        want = F.candidate_families(inner, lss * env.frame.scale)
    apexes = 0
    for f, g in zip(got, want, strict=True):
        assert len(f.marks) == len(g.marks)
        for a, b in zip(f.marks, g.marks, strict=True):
            assert [(type(t), t, p.tolist()) for t, p in a] == \
                [(type(t), t, p.tolist()) for t, p in b]
        apexes += sum(len(m) for m in f.marks) if f.kind == "E" else 0
    assert apexes > 0 or env.n < 100  # the floor plan has apexes


def test_curves_to_user_matches_each_curve():
    """The curves converted to the user's frame all at once are those of ``Curve.to_user``,
    curve by curve: the same names, domains, intervals, polylines and parameters, bit for bit."""
    env = floor_plan(60, seed=3)
    assert not env.is_internal
    curves = critical_curves(env.internal, (env.bounds[2] - env.bounds[0]) / 8 * env.frame.scale)
    names = env.feature_names_map()
    got = curves_to_user(curves, env.frame, names)
    want = [c.to_user(env.frame, names) for c in curves]
    assert len(got) == len(want) > 50 and {c.kind for c in got} == set("ABCDE")
    for g, w in zip(got, want, strict=True):
        assert (g.id, g.kind, g.features, g.domain, g.intervals) == (
            w.id, w.kind, w.features, w.domain, w.intervals)
        assert g.family is w.family and g.index == w.index and g.frame is w.frame
        assert len(g.polylines) == len(w.polylines) and len(g.params) == len(w.params)
        for a, b in zip(g.polylines + g.params, w.polylines + w.params, strict=True):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    assert curves_to_user([], env.frame, names) == []
