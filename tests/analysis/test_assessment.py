"""Start analysis: escape table, margins, is_safe against assess, the second critical curves."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tether.analysis import (
    analyze,
    assess,
    critical_distance_field,
    escape_table_of,
    is_safe,
    l_paper,
    l_safe,
)
from tether.analysis.escape_points import sweep_row, sweeps
from tether.arcs import free_arcs
from tether.decomposition import decompose
from tether.errors import InvalidParameterError
from tether.examples import path as example_path
from tether.io import load_map

_V = {}


def verdict(name):
    if name not in _V:
        env = load_map(example_path(name))
        _V[name] = analyze(decompose(env, 2.0))
    return _V[name]


def test_escape_pieces_are_the_splits_with_an_eliminated_side():
    v = verdict("nonconvex_corner")
    t = escape_table_of(v)
    pieces = {int(k) for k in t.piece if k >= 0}
    expect = set()
    for (cid, k), parts in v.graph.partners.items():
        if cid in v.surviving and any(p not in v.surviving for p in parts) \
                and any(p in v.surviving for p in parts):
            expect.add(k)
    assert pieces == expect
    # each goal lies inside the cell's arc at the sample, and is free there (exact arcs)
    for i in np.flatnonzero(t.piece >= 0)[::7]:
        fa = free_arcs(v.dec.env, t.q[i], 2.0)
        mid = t.g_start[i, 0] + 0.5 * ((t.g_end[i, 0] - t.g_start[i, 0]) % (2 * math.pi))
        assert fa.contains(mid % (2 * math.pi))


def test_sweeps_small_cases():
    # K = [0, π], goal = [π/2, 3π/4]: from 0.1 sweep CCW 1.4708; from 3 sweep CW 0.6438
    ks, ke = np.array([0.0]), np.array([math.pi])
    gs, ge = np.array([[math.pi / 2]]), np.array([[3 * math.pi / 4]])
    c, d, s = sweeps(ks, ke, gs, ge, 0.1)
    assert c[0] and d[0] == pytest.approx(math.pi / 2 - 0.1) and s[0] == 1
    c, d, s = sweeps(ks, ke, gs, ge, 3.0)
    assert c[0] and d[0] == pytest.approx(3.0 - 3 * math.pi / 4) and s[0] == -1
    c, _, _ = sweeps(ks, ke, gs, ge, 2.0)  # in the goal
    assert not c[0]
    c, _, _ = sweeps(ks, ke, gs, ge, 4.0)  # outside K: another cell's business
    assert not c[0]


def test_bounds_order():
    d = np.linspace(0.01, 2 * math.pi, 50)
    for vt, vo in ((0.3, 1.0), (0.6, 1.0), (0.9, 1.0)):
        assert np.all(l_paper(d, vt, vo, 2.0) <= l_safe(d, vt, vo, 2.0) + 1e-12)


@pytest.mark.slow
def test_assess_reasons_and_is_safe_agree():
    v = verdict("gallery")
    rng = np.random.default_rng(4)
    env = v.dec.env
    pts, angs = [], []
    while len(pts) < 25:
        x, y = rng.uniform((0, 0), (16, 12))
        if env.contains(x, y) and env.boundary_distance(x, y) > 0.05:
            pts.append((x, y))
            angs.append(rng.uniform(0, 2 * math.pi))
    fast = is_safe(v, 0.3, 1.0, pts, angs)
    for (x, y), a, f in zip(pts, angs, fast, strict=True):
        res = assess(v, 0.3, 1.0, x, y, a)
        assert res.reasons
        if res.safe:
            assert f
        if not f:
            assert not res.safe
        d = res.to_dict()
        for k in ("safe", "cell", "reasons", "escape_points"):
            assert k in d


def test_assess_no_strategy_map():
    v = verdict("convex_corner")
    res = assess(v, 0.5, 1.0, 3.0, 3.0, 0.5)
    assert not res.safe and "Prop. 1" in res.reasons[0]


def test_assess_bad_speeds():
    with pytest.raises(InvalidParameterError):
        assess(verdict("nonconvex_corner"), 1.0, 1.0, 5.0, 1.0, 1.57)


def test_second_critical_curves_are_distance_levels():
    v = verdict("nonconvex_corner")
    xs, ys = np.linspace(0.1, 9.9, 40), np.linspace(0.1, 9.9, 40)
    f = critical_distance_field(v, 0.5, 1.0, 0.0, xs, ys)
    fp = critical_distance_field(v, 0.5, 1.0, 0.0, xs, ys, paper=True)
    assert np.isfinite(f).any()
    assert np.all(fp[np.isfinite(fp)] >= f[np.isfinite(f)] - 1e-9)  # L <= L_g


# --- issue #10: losses of the paper's controller from starts once called safe -------------------
def _gallery_world(vt):
    from tether.sim.protocols import World

    v = verdict("gallery")
    return World(v.dec.env, 2.0, vt, 1.0, v.dec, v)


@pytest.mark.slow
def test_rows_concern_the_blocked_gap_next_to_their_cell():
    """Gallery, vt/vo = 0.6, start (13.885, 7.978, 1.458): the rod points up, into the gap that
    the top wall E2 blocks at the escape piece P120 (x = 14, 10 < y < 12). The follow law
    turns it CW into the corner cell (R66,E2,E2) right at P120; the row must count that sweep.
    It used to be called safe, and the dash target won there (seed 4)."""
    from tether.sim.controller import PaperController
    from tether.sim.simulate import simulate
    from tether.strategies import make_target

    v = verdict("gallery")
    t = escape_table_of(v, 0.6)
    rows = np.flatnonzero(t.piece == 120)
    assert len(rows)
    # every P120 row now concerns the upward rod (it is blocked at q, in the gap next to K)
    concern, _, _ = t.sweeps(1.458)
    assert concern[rows].all()
    st = (13.885, 7.978, 1.458)
    res = assess(v, 0.6, 1.0, *st)
    assert not res.safe and "P120" in res.reasons[0]
    w = _gallery_world(0.6)
    r = simulate(w, PaperController(w), make_target("dash", w), st, duration=6.0, dt=0.02,
                 seed=4)
    assert r.outcome == "lost"  # the verdict is right: this start can be lost


@pytest.mark.slow
def test_prop3_applies_to_vertex_escape_points():
    """Gallery, vt/vo = 0.6, start (0.939, 2.344, 6.143): reflex vertex V6 (5, 4) needs a CW
    sweep toward the floor, V7 (5, 6) a CCW one, and neither order finishes in time (Prop. 3).
    It used to be called safe (conflicts were checked between pieces only); the controller
    served V6, drove the rod steeply into the floor E0 and lost to a random walker (seed 19):
    its committed rotation kept pushing into the floor's arc end. Now the committed sense is
    re-chosen for the rod's arc each step, and this run is held (monitor on)."""
    from tether.sim.controller import PaperController
    from tether.sim.simulate import simulate
    from tether.strategies import make_target

    v = verdict("gallery")
    st = (0.939, 2.344, 6.143)
    res = assess(v, 0.6, 1.0, *st)
    assert not res.safe and any("Prop. 3" in r for r in res.reasons)
    kinds = {res.escape_points[i].piece for pair in res.conflicts for i in pair}
    assert {"V6", "V7"} <= kinds
    w = _gallery_world(0.6)
    r = simulate(w, PaperController(w), make_target("random", w), st, duration=4.0, dt=0.02,
                 seed=19)
    assert r.outcome == "held"


@pytest.mark.slow
def test_wall_rows_cover_every_contact_point_and_inclination():
    """Gallery, vt/vo = 0.3, start (7.95, 2.97, 0.074): a random walker (seed 4) heads right
    along y = 2.97 and the rod's tip meets the hole's wall E10 (x = 11) 7° off its normal,
    near its end V10, within arcsin(vt/vo) = 17.5°. The wall rows sampled only perpendicular
    contacts every lss/2 along the edge, 0.5 away from that contact, so the trigger never fired
    and the run was lost at 3.54 s. The wall's escape point is now the nearest point of the
    whole wall translated by −lss·u(a); the run is held, monitor on."""
    from tether.analysis.escape_points import wall_contact_points
    from tether.sim.controller import PaperController
    from tether.sim.simulate import simulate
    from tether.strategies import make_target

    v = verdict("gallery")
    env = v.dec.env
    # the translated wall is exactly where the rod's tip touches the wall (brute force)
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(0, 2 * math.pi)
        pts = rng.uniform((0, 0), (16, 12), (5, 2))
        near = wall_contact_points(env, np.arange(env.n), 2.0, pts, a)
        tips = near + 2.0 * np.array([math.cos(a), math.sin(a)])
        A, B, _, _ = env.oriented_edges
        e = B - A
        cross = (e[:, None, 0] * (tips[..., 1] - A[:, None, 1])
                 - e[:, None, 1] * (tips[..., 0] - A[:, None, 0]))
        assert np.abs(cross).max() < 1e-9 * 16 * 16
    w = _gallery_world(0.3)
    st = (7.95, 2.97, 0.074)
    assert assess(v, 0.3, 1.0, *st).safe
    r = simulate(w, PaperController(w), make_target("random", w), st, duration=6.0, dt=0.02,
                 seed=4)
    assert r.outcome == "held"


@pytest.mark.slow
def test_committed_rotation_turns_the_other_way_when_pinned():
    """Gallery, vt/vo = 0.3, safe start (4.078, 5.341, 3.17), random walker seed 1: the
    controller committed to a CW sweep for reflex vertex V4 (8, 9) while the rod lay on the
    wall E4 (y = 9), pinned in compliant motion; it never re-chose the sense when the arc
    opened CCW toward the goal, and the rod pivoted about V4 at 17.96 s. Held now. (Since
    the vertex goals were shrunk by ``VERTEX_GOAL_MARGIN`` the start is no longer called safe
    (V6 and V7 conflict, Prop. 3): the run stays as a test of the pinned rotation.)"""
    from tether.sim.controller import PaperController
    from tether.sim.simulate import simulate
    from tether.strategies import make_target

    v = verdict("gallery")
    st = (4.078, 5.341, 3.17)
    assert assess(v, 0.3, 1.0, *st).rod_free
    w = _gallery_world(0.3)
    r = simulate(w, PaperController(w), make_target("random", w), st, duration=19.0, dt=0.02,
                 seed=1)
    assert r.outcome == "held"


_ANG = st.floats(0.0, 2 * math.pi, exclude_max=True, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(ks=_ANG, ke=_ANG, a=st.floats(-10.0, 10.0, allow_nan=False),
       goals=st.lists(st.tuples(_ANG, _ANG), min_size=0, max_size=3), pad=st.integers(0, 2),
       snap=st.booleans())
@pytest.mark.slow
def test_sweep_row_equals_the_vectorized_sweeps(ks, ke, a, goals, pad, snap):
    """The controller's scalar check of one row agrees with the vectorized table sweeps,
    including full circles (equal ends), NaN-padded goal lists and a rod exactly on an arc end."""
    if snap:
        a = ks if not goals else goals[0][1]
    gs = np.array([g[0] for g in goals] + [np.nan] * pad, float)
    ge = np.array([g[1] for g in goals] + [np.nan] * pad, float)
    if not len(gs):
        gs, ge = np.full(1, np.nan), np.full(1, np.nan)
    concern, delta, sense = sweeps(np.array([ks]), np.array([ke]), gs[None, :], ge[None, :], a)
    c1, d1, s1 = sweep_row(ks, ke, gs.tolist(), ge.tolist(), a)
    assert c1 == bool(concern[0])
    if c1:
        assert d1 == pytest.approx(float(delta[0]), abs=1e-12)
        assert s1 == int(sense[0])


def _conflicts_reference(points, vt, vo, lss, a, arc):
    """Prop. 3 pairs the plain way: every pair, every test, no caching."""
    from tether.analysis.assessment import _common_sweep

    out = []
    for i, ei in enumerate(points):
        for j in range(i + 1, len(points)):
            ej = points[j]
            if ei.sense == ej.sense:
                continue
            di = ei.distance - (ei.distance - ei.L_g - ei.margin)
            dj = ej.distance - (ej.distance - ej.L_g - ej.margin)
            i_first = dj >= float(l_safe(2 * ei.sweep + ej.sweep, vt, vo, lss))
            j_first = di >= float(l_safe(2 * ej.sweep + ei.sweep, vt, vo, lss))
            common = bool(ei.goal and ej.goal) and min(di, dj) >= float(
                l_safe(_common_sweep(a, ei.goal, ej.goal, arc), vt, vo, lss))
            if not (i_first or j_first or common):
                out.append((i, j))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name, lss, ratio", [("gallery", 2.0, 0.3),
                                              ("nonconvex_corner", 2.0, 0.6)])
def test_prop3_conflicts_equal_the_plain_pairwise_check(name, lss, ratio):
    """The cached Prop. 3 check gives the pairs of the plain all-pairs computation, on starts
    with many escape points in reach."""
    from tether.analysis.assessment import _arc_at, conflicts

    env = load_map(example_path(name))
    ver = analyze(decompose(env, lss))
    rng = np.random.default_rng(5)
    x0, y0, x1, y1 = env.bounds
    seen = 0
    for _ in range(60):
        x, y = rng.uniform((x0, y0), (x1, y1))
        a = float(rng.uniform(0, 2 * math.pi))
        if not env.contains(x, y):
            continue
        res = assess(ver, ratio, 1.0, x, y, a)
        if not res.rod_free or len(res.escape_points) < 2:
            continue
        arc = _arc_at(env, np.array([x, y]), a, lss)
        pts = list(res.escape_points)
        ref = _conflicts_reference(pts, ratio, 1.0, lss, a, arc)
        assert conflicts(pts, ratio, 1.0, lss, a, arc) == ref
        assert list(res.conflicts) == ref
        seen += len(ref) > 0
    assert seen > 0  # the check met real conflicts
