"""The regions and pieces stages' vectorized helpers against their plain definitions: structures
compared as integer rows against frozenset equality."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, interior_points
from hypothesis import given, settings
from hypothesis import strategies as st

import tether.decomposition as D
from tether import free_arcs_many, load_map, spatial
from tether.curves import critical_curves
from tether.decomposition import arrangement
from tether.decomposition import pieces as pieces_mod
from tether.decomposition import structure as structure_mod
from tether.examples import path as example_path
from tether.examples.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL


def _points_and_structures(env, lss, n, seed):
    pts = interior_points(env, n, seed)
    table = free_arcs_many(env.internal, env.frame.to_internal(pts), lss * env.frame.scale,
                           check=False)
    return table, D.structures(env.internal, table, len(pts))


def test_structure_rows_compare_as_frozensets():
    """Every pair of sampled points: rows equal iff structures equal, both for rows built from
    the arc table and from the structure objects (shared or not)."""
    for env, lss in ((GENERIC, 2.5), (load_map(example_path("gallery")), 2.0),
                     (floor_plan(30, seed=1), 0.6)):
        inner = env.internal
        table, st = _points_and_structures(env, lss, 300, seed=4)
        rows = structure_mod.table_rows(inner, table, len(st))
        base = 2 * inner.n + 1
        copies = [frozenset(s) if isinstance(s, frozenset) else s for s in st]  # not shared
        sets, of = structure_mod.set_rows(copies, base)
        shared, of_shared = structure_mod.set_rows(st, base)
        i, j = (a.ravel() for a in np.meshgrid(np.arange(len(st)), np.arange(len(st))))
        want = np.array([st[a] == st[b] for a, b in zip(i.tolist(), j.tolist(), strict=True)])
        assert want.sum() > len(st) and not want.all()  # some equal, some not
        assert np.array_equal(structure_mod.rows_equal(rows, i, rows, j), want)
        assert np.array_equal(structure_mod.rows_equal(rows, i, sets, of[j]), want)
        assert np.array_equal(structure_mod.rows_equal(shared, of_shared[i], rows, j), want)
        assert len(shared.kind) == len({id(s) for s in st})


def test_structure_rows_of_empty_and_full():
    inner = GENERIC.internal
    sets, of = structure_mod.set_rows(["EMPTY", "FULL", "FULL", frozenset({(1, 2)})],
                                      2 * inner.n + 1)
    i = np.arange(4)
    eq = structure_mod.rows_equal(sets, of[np.repeat(i, 4)], sets, of[np.tile(i, 4)]).reshape(4, 4)
    assert np.array_equal(eq, [[1, 0, 0, 0], [0, 1, 1, 0], [0, 1, 1, 0], [0, 0, 0, 1]])


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.01, 0.5))
def test_staged_clearance_equals_brute_force(seed, reach):
    """The clearance searched within growing radii equals the nearest other-owner segment's
    distance over all segments (capped at ``reach``), bit for bit."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(0, 1, (300, 2))
    b = a + rng.normal(0, 0.05, (300, 2))
    sowner = rng.integers(0, 40, 300)
    k = rng.integers(0, 300, 200)
    pts = 0.5 * (a[k] + b[k])
    got = pieces_mod._clearance(pts, sowner[k], a, b, sowner, spatial.segment_tree(a, b), reach)
    d = spatial.point_segment_distance(np.repeat(pts, 300, axis=0), np.tile(a, (200, 1)),
                                  np.tile(b, (200, 1))).reshape(200, 300)
    d[sowner[k][:, None] == sowner[None, :]] = np.inf
    assert np.array_equal(got, np.minimum(d.min(axis=1), reach))


def test_crossing_table_gathers_each_points_rows():
    """The gathered table has, for output point ``d``, exactly the rows of its source point in
    its round's table, in order (several rounds, sides swapped)."""
    env = load_map(example_path("gallery"))
    inner = env.internal
    rng = np.random.default_rng(5)
    tables = [free_arcs_many(inner, env.frame.to_internal(interior_points(env, k, seed=k)),
                             2.0 * env.frame.scale, check=False) for k in (40, 30, 20)]
    m = 25
    rnd = rng.integers(0, 3, m)
    size = np.array([40, 30, 20])[rnd]
    at = np.column_stack((rnd, rng.integers(0, size), rng.integers(0, size)))
    given = list(tables)
    got = pieces_mod._crossing_table(given, at)
    assert given == []  # emptied: the rounds' columns freed as they are gathered
    for d in range(2 * m):
        r, s = at[d % m, 0], at[d % m, 1 + d // m]
        want, have = tables[r].rows_of(int(s)), got.rows_of(d)
        assert got.full[d] == tables[r].full[s]
        for f in ("start", "end", "start_code", "end_code"):
            assert np.array_equal(getattr(got, f)[have], getattr(tables[r], f)[want])
    assert np.array_equal(got.point, np.sort(got.point))


@pytest.mark.slow
def test_part_candidates_cached_in_batches_equal_one_pass():
    """Candidates asked for some parts, then for more (cached, two batches), equal those of
    all the parts at once, in (part, rank) order."""
    env = floor_plan(30, seed=1).internal
    lss = 0.15 * (env.bounds[2] - env.bounds[0])
    tol = REL_CURVE_TOL * env.diameter
    curves = critical_curves(env, lss, REL_CURVE_TOL)
    arr = arrangement.arrangement(env, curves, tol)
    rng = np.random.default_rng(2)
    first = rng.random(len(arr.parts)) < 0.5
    both = first | (rng.random(len(arr.parts)) < 0.5)
    pieces_mod.part_candidates(arr, first, tol, lss)
    got = pieces_mod.part_candidates(arr, both, tol, lss)
    fresh = arrangement.arrangement(env, curves, tol)
    want = pieces_mod.part_candidates(fresh, both, tol, lss)
    assert len(want[0]) > 100
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g, w)


def test_arcs_across_in_batches_equal_one_table(monkeypatch):
    """The crossings' arcs and structures made in batches (joined column by column) equal
    those of one free-arcs call and one structure pass over all the points."""
    env = floor_plan(60, seed=3).internal
    lss = 0.12 * (env.bounds[2] - env.bounds[0])
    rng = np.random.default_rng(1)
    q = interior_points(env, 400, seed=2)
    a = rng.uniform(0, 2 * np.pi, len(q))
    n = np.column_stack((np.cos(a), np.sin(a)))
    eps = rng.uniform(1e-6, 1e-3, len(q)) * lss
    pts = D.crossing_points(q, n, eps)
    whole = free_arcs_many(env, pts, lss, check=False)
    rows = structure_mod.table_rows(env, whole, len(pts))
    for batch in (7, 100, 10_000):
        monkeypatch.setattr(pieces_mod, "ACROSS_BATCH", batch)
        table, sides = pieces_mod._arcs_across(env, lss, q, n, eps)
        for f in ("point", "start", "end", "start_code", "end_code", "full"):
            got, want = getattr(table, f), getattr(whole, f)
            assert got.dtype == want.dtype and np.array_equal(got, want), f
        for f in ("kind", "ptr", "pairs"):
            got, want = getattr(sides, f), getattr(rows, f)
            assert got.dtype == want.dtype and np.array_equal(got, want), f
    assert len(whole.point) > len(pts)


def _project_on_sources_reference(curves, srcs, which, q0):
    """:func:`_project_on_sources` as first written: a lexsort by (row, distance)."""
    from tether._util.arrays import ragged_arange
    from tether.curves import project_many

    q, n = q0.copy(), np.tile([0.0, 1.0], (len(q0), 1))
    ptr, src = srcs
    count = ptr[which + 1] - ptr[which]
    if count.sum() == 0:
        return q, n
    row = np.repeat(np.arange(len(which)), count)
    cid = src[ragged_arange(ptr[which], count)]
    _, p, nrm = project_many(curves, cid, q0[row])
    dist = np.hypot(*(p - q0[row]).T)
    order = np.lexsort((dist, row))
    best = order[np.r_[True, row[order][1:] != row[order][:-1]]]
    q[row[best]] = p[best]
    n[row[best]] = nrm[best]
    return q, n


def test_project_on_sources_equals_the_sorted_choice():
    """Each point's nearest projection among its chain's curves (none, one or several, of
    every kind, repeats included) equals the one a sort by (row, distance) picks, bit for
    bit."""
    from tether.curves import critical_curves

    env = GENERIC.internal
    curves = critical_curves(env, 2.5 * GENERIC.frame.scale)
    assert {c.kind for c in curves} >= {"A", "B", "C", "E"}
    rng = np.random.default_rng(3)
    count = rng.integers(0, 4, 400)
    ptr = np.r_[0, np.cumsum(count)]
    src = rng.integers(0, len(curves), int(ptr[-1]))
    which = rng.permutation(400)[:300]
    q0 = np.vstack([c.polylines[0][len(c.polylines[0]) // 2] for c in curves])[
        rng.integers(0, len(curves), 300)] + rng.normal(0, 1e-3, (300, 2))
    got = pieces_mod._project_on_sources(curves, (ptr, src), which, q0)
    want = _project_on_sources_reference(curves, (ptr, src), which, q0)
    for a, b in zip(got, want, strict=True):
        assert a.tobytes() == b.tobytes()
    assert not np.array_equal(got[0], q0)
