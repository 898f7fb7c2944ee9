"""The vectorized overshoot and polylines of the critical curves (all curves of a family at
once) against the scalar one-interval-at-a-time functions they replace: the very same numbers."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, L_SHAPE, SQUARE_HOLE, STAR_HOLE, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether.curves import (
    _critical_intervals,
    _draw_all,
    _overshoot,
    _overshoot_family,
    _polyline,
    candidate_families,
)
from tether.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL


def assert_same_as_scalar(env, lss):
    inner = env.internal
    tol = REL_CURVE_TOL * inner.diameter
    margin = 20 * tol
    for fam in candidate_families(inner, lss * env.frame.scale):
        intervals = _critical_intervals(inner, fam)
        found = _overshoot_family(fam, intervals, margin)
        expect = [(c, [_overshoot(fam, c, iv, margin) for iv in ivs])
                  for c, ivs in enumerate(intervals) if ivs]
        assert [(c, ivs) for _, c, ivs in found] == expect
        for (_, c, ivs), drawn in zip(found, _draw_all(found, tol), strict=True):
            for (lo, hi), (ts, pts) in zip(ivs, drawn, strict=True):
                ts0, pts0 = _polyline(fam, c, lo, hi, tol)
                assert np.array_equal(ts, ts0) and np.array_equal(pts, pts0), (fam.kind, c)


@pytest.mark.parametrize(("env", "lss"), [(SQUARE_HOLE, 2.0), (GENERIC, 2.5), (STAR_HOLE, 1.5),
                                          (GENERIC, 6.0), (L_SHAPE, 3.0)])
def test_test_maps(env, lss):
    assert_same_as_scalar(env, lss)


def test_floor_plan():
    env = floor_plan(60, seed=0)
    assert_same_as_scalar(env, (env.bounds[2] - env.bounds[0]) / 15)


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), lss=st.floats(0.3, 8.0))
def test_random_maps(env, lss):
    assert_same_as_scalar(env, lss)


def test_pruned_conchoid_projection_equals_the_full_search(monkeypatch):
    """Projections on conchoids with the block-pruned nearest-segment search equal those with
    every segment of the curve (points on the polylines, at their vertices, and anywhere)."""
    import tether.curves as C

    env = floor_plan(100, seed=0)
    inner = env.internal
    curves = C.critical_curves(inner, (env.bounds[2] - env.bounds[0]) / 15 * env.frame.scale)
    conchoids = [c.id for c in curves if c.kind == "E"]
    rng = np.random.default_rng(0)
    cid = rng.choice(conchoids, 3000)
    pts = []
    for k in cid[:2000]:
        p = curves[k].polylines[0]
        i = rng.integers(0, len(p) - 1)
        w = rng.choice([0.0, 0.5, rng.random()])
        pts.append(p[i] + w * (p[i + 1] - p[i]))
    x0, y0, x1, y1 = inner.bounds
    q = np.vstack((pts, rng.uniform([x0, y0], [x1, y1], (1000, 2))))
    pruned = C._project_conchoids(curves, cid, q)

    def every_segment(a, b, sc, ncurves, inv, q):
        count = np.bincount(sc, minlength=ncurves)
        first = np.cumsum(count) - count
        return (np.repeat(np.arange(len(inv)), count[inv]),
                C.ragged_arange(first[inv], count[inv]))

    monkeypatch.setattr(C, "_near_segment_pairs", every_segment)
    full = C._project_conchoids(curves, cid, q)
    for x, y in zip(pruned, full, strict=True):
        assert np.array_equal(x, y)


def test_row_norms_are_the_scalar_norms_bit_for_bit():
    from tether.curves import _norms

    rng = np.random.default_rng(5)
    v = rng.normal(size=(20_000, 2)) * rng.uniform(1e-6, 1e6, size=(20_000, 1))
    assert np.array_equal(_norms(v), np.array([np.linalg.norm(x) for x in v]))


def test_first_nearest_is_the_stable_sort_pick():
    """The nearest segment per row by a minimum per row picks what a stable sort by (row,
    distance) picks: the first of equal distances (ties are common: shared vertices)."""
    from tether._util.arrays import first_nearest as _first_nearest

    rng = np.random.default_rng(8)
    row = np.sort(rng.integers(0, 300, 3000))
    row = np.searchsorted(np.unique(row), row)  # every row present
    dist = rng.choice([0.0, 0.5, 1.0, 2.0], len(row)) + rng.choice([0.0, 1e-17], len(row))
    for d in (dist, np.where(rng.random(len(row)) < 0.01, np.nan, dist)):
        order = np.lexsort((d, row))
        want = order[np.r_[True, row[order][1:] != row[order][:-1]]]
        assert np.array_equal(_first_nearest(row, d), want)


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
    import tether.curves as C

    inner = env.internal
    got = C.candidate_families(inner, lss * env.frame.scale)
    with monkeypatch.context() as mp:
        mp.setattr(C, "_mark_apexes", reference_mark_apexes)
        want = C.candidate_families(inner, lss * env.frame.scale)
    apexes = 0
    for f, g in zip(got, want, strict=True):
        assert len(f.marks) == len(g.marks)
        for a, b in zip(f.marks, g.marks, strict=True):
            assert [(type(t), t, p.tolist()) for t, p in a] == \
                [(type(t), t, p.tolist()) for t, p in b]
        apexes += sum(len(m) for m in f.marks) if f.kind == "E" else 0
    assert apexes > 0 or env.n < 100  # the floor plan has apexes


@pytest.mark.parametrize(("env", "lss"), [(GENERIC, 2.5), (STAR_HOLE, 1.5), (L_SHAPE, 3.0),
                                          (floor_plan(150, seed=2), 1.2)])
def test_vertex_estimates_equal_the_scalar_ones(env, lss):
    from tether.curves import _vertex_estimate, _vertex_estimates

    inner = env.internal
    tol = REL_CURVE_TOL * inner.diameter
    found = []
    for fam in candidate_families(inner, lss * env.frame.scale):
        found += _overshoot_family(fam, _critical_intervals(inner, fam), 20 * tol)
    assert _vertex_estimates(found, tol) == [_vertex_estimate(f, c, ivs, tol)
                                             for f, c, ivs in found]


def test_curves_to_user_matches_each_curve():
    """The curves converted to the user's frame all at once are those of ``Curve.to_user``,
    curve by curve: the same names, domains, intervals, polylines and parameters, bit for bit."""
    from tether.curves import critical_curves, curves_to_user

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
