"""The batched paths against the scalar ones they replace: the certified controller's
``step_many`` and ``rollout`` against its ``step`` (and against the rule it had before, kept
here as written then), :class:`FieldArcs` against ``CertifiedKernel.arcs``, the search
target's batched scores against its one-plan-at-a-time loop, and the planner's
``contains_many`` against ``contains``. The fields are random arcs on a mesh (no
certification needed: the arcs, the rates and the scores are defined for any field), so the
states fall inside, outside and across the arcs, and on the mesh's edges and vertices."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether import Environment
from tether.game.certificate import FULL, ArcField, lifted_ends
from tether.game.certified import CertifiedKernel
from tether.game.controller import CertifiedController, FieldArcs, _landing, landing_many
from tether.rates import observer_velocity, step_rate_interval
from tether.sim.protocols import Command, Mode, World
from tether.sim.simulate import simulate
from tether.strategies import make_target

#: A room with a square pillar: rods near it have partial free arcs.
ROOM = Environment([(0, 0), (6, 0), (6, 6), (0, 6)], holes=[[(2.5, 2.5), (3.5, 2.5),
                                                              (3.5, 3.5), (2.5, 3.5)]])
LSS, VT, VO = 1.0, 0.3, 1.0


def random_field(seed: int, h: float = 0.75) -> CertifiedKernel:
    """Random arcs on a triangulated grid over the room's box (some whole circles)."""
    rng = np.random.default_rng(seed)
    g = np.arange(0.0, 6.0 + 1e-9, h)
    X, Y = np.meshgrid(g, g, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    k = len(g)
    i, j = np.meshgrid(np.arange(k - 1), np.arange(k - 1), indexing="ij")
    v00, v10, v01, v11 = (i * k + j).ravel(), ((i + 1) * k + j).ravel(), \
        (i * k + j + 1).ravel(), ((i + 1) * k + j + 1).ravel()
    tri = np.concatenate([np.column_stack([v00, v10, v11]), np.column_stack([v00, v11, v01])])
    lo = rng.uniform(-math.pi, math.pi, len(pts))
    w = rng.uniform(0.3, 2 * math.pi, len(pts))
    w[rng.random(len(pts)) < 0.3] = 2 * math.pi
    return CertifiedKernel(ROOM, LSS, VT, VO, h, ArcField(pts, tri, lo, w), None)


def old_step(ck: CertifiedKernel, world: World, p, v, a: float, dt: float) -> Command:
    """``CertifiedController.step`` as it was before the batched path (main f164eea)."""
    lss, vo = world.lss, world.vo
    p = np.asarray(p, dtype=float)
    v = np.asarray(v, dtype=float)
    r_lo, r_hi = (float(x) for x in step_rate_interval(v, a, lss, vo, dt))
    r_lo, r_hi = max(r_lo, -np.pi / dt), min(r_hi, np.pi / dt)
    lo, hi, ok = ck.arcs(np.vstack([p, p + v * dt]))
    if not ok[1]:
        rate = min(max(0.0, r_lo), r_hi)
        return Command(rate, observer_velocity(v, a, rate, lss), Mode.CERTIFIED)
    width = hi[1] - lo[1]
    w0 = hi[0] - lo[0]
    if ok[0] and w0 < FULL:
        x = float(np.mod(a - lo[0], math.tau))
        s = x / w0 if x <= w0 else (0.0 if math.tau - x < x - w0 else 1.0)
        aim = lo[1] + s * width
    else:
        aim = a
    end = _landing(a, a + r_lo * dt, a + r_hi * dt, lo[1], width, aim)
    rate = (end - a) / dt
    return Command(rate, observer_velocity(v, a, rate, lss), Mode.CERTIFIED)


def random_states(rng, n: int, ck: CertifiedKernel) -> tuple:
    """Points in and just off the mesh (a quarter on its edges and vertices), target
    velocities up to ``vt`` (some zero), orientations inside, outside and at the arcs'
    ends."""
    p = rng.uniform(-0.2, 6.2, (n, 2))
    on_grid = rng.random(n) < 0.25
    p[on_grid] = np.round(p[on_grid] / ck.h) * ck.h  # vertices
    on_edge = rng.random(n) < 0.15
    p[on_edge, 0] = np.round(p[on_edge, 0] / ck.h) * ck.h  # vertical edges
    v = VT * rng.uniform(0, 1, (n, 1)) * np.column_stack(
        [np.cos(t := rng.uniform(0, 2 * math.pi, n)), np.sin(t)])
    v[rng.random(n) < 0.1] = 0.0
    lo, hi, ok = ck.arcs(p)
    a = rng.uniform(-2 * math.pi, 4 * math.pi, n)
    at_end = ok & (rng.random(n) < 0.2)
    a[at_end] = np.where(rng.random(at_end.sum()) < 0.5, lo[at_end], hi[at_end])
    return p, v, a


def old_arcs(ck: CertifiedKernel, points: np.ndarray):
    """``CertifiedKernel.arcs`` as it was before the per-field cache of the triangles'
    lifted ends (main 084451e): the ends lifted for the located triangles only."""
    t = ck.locate(points)
    pts = ck.frame.to_internal(points)
    ok = t >= 0
    lo, hi = np.full(len(pts), np.nan), np.full(len(pts), np.nan)
    tri = ck.field.tri[t[ok]]
    L, H, _ = lifted_ends(ck.field.lo, ck.field.w, tri)
    a, b, c = (ck.field.points[tri][:, k] for k in range(3))
    v0, v1, v2 = b - a, c - a, pts[ok] - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    l1 = (v2[:, 0] * v1[:, 1] - v2[:, 1] * v1[:, 0]) / det
    l2 = (v0[:, 0] * v2[:, 1] - v0[:, 1] * v2[:, 0]) / det
    lam = np.stack([1 - l1 - l2, l1, l2], axis=1)
    lo[ok] = (lam * L).sum(axis=1)
    hi[ok] = np.minimum((lam * H).sum(axis=1), lo[ok] + 2 * math.pi)
    whole = (ck.field.w[tri] >= FULL).all(axis=1)
    hi[np.flatnonzero(ok)[whole]] = lo[ok][whole] + 2 * math.pi
    return lo, hi, ok


def test_cached_triangle_ends_give_the_former_arcs_and_follow_a_new_field():
    ck = random_field(2)
    p, _, _ = random_states(np.random.default_rng(12), 500, ck)
    for _ in range(2):  # the second call uses the cache
        for w_, g_ in zip(old_arcs(ck, p), ck.arcs(p), strict=True):
            np.testing.assert_array_equal(g_, w_)
    ck.field = random_field(3).field  # a replaced field: its own ends, not the cached ones
    for w_, g_ in zip(old_arcs(ck, p), ck.arcs(p), strict=True):
        np.testing.assert_array_equal(g_, w_)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_field_arcs_equal_the_kernels_arcs(seed):
    ck = random_field(seed)
    rng = np.random.default_rng(seed + 10)
    p, _, _ = random_states(rng, 600 if seed == 0 else 3000, ck)
    want = ck.arcs(p)
    fa = FieldArcs(ck)
    ok, lo, hi = np.array([fa.arc_one(*q) for q in p.tolist()]).T
    np.testing.assert_array_equal(ok.astype(bool), want[2])
    np.testing.assert_array_equal(lo, want[0])
    np.testing.assert_array_equal(hi, want[1])
    assert sum(fa._locate_one(*((q - ck.frame.origin) * ck.frame.scale)) is None
               for q in p) > 30  # the exact fallback was taken (points on edges)


def test_landing_many_equals_the_scalar_landing():
    rng = np.random.default_rng(3)
    n = 3000
    a = rng.uniform(-10, 10, n)
    lo_r = a - rng.uniform(0, 0.1, n)
    hi_r = a + rng.uniform(0, 0.1, n)
    lo = rng.uniform(-10, 10, n)
    width = np.where(rng.random(n) < 0.1, 2 * math.pi, rng.uniform(0, 2 * math.pi, n))
    aim = np.where(rng.random(n) < 0.5, a, lo + rng.uniform(0, 1, n) * width)
    near = rng.random(n) < 0.3  # the arc's ends on the reach's ends: the ties
    lo[near] = lo_r[near] + rng.integers(-2, 3, near.sum()) * 2 * math.pi
    want = [_landing(*map(float, row)) for row in zip(a, lo_r, hi_r, lo, width, aim,
                                                        strict=True)]
    np.testing.assert_array_equal(landing_many(a, lo_r, hi_r, lo, width, aim), want)


@pytest.mark.parametrize("dt", [0.02, pytest.param(0.5, marks=pytest.mark.slow)])
def test_step_many_equals_step_and_the_old_step(dt):
    ck = random_field(2)
    world = World(ROOM, LSS, VT, VO)
    ctrl = CertifiedController(ck)
    ctrl.reset(world, np.array([1.0, 1.0]), 0.0)
    rng = np.random.default_rng(4)
    p, v, a = random_states(rng, 150 if dt == 0.02 else 600, ck)
    many = ctrl.step_many(p, v, a, dt)
    one = np.array([ctrl.step(p[i], v[i], float(a[i]), dt).rate for i in range(len(p))])
    old = np.array([old_step(ck, world, p[i], v[i], float(a[i]), dt).rate
                    for i in range(len(p))])
    assert np.isfinite(many).all()
    np.testing.assert_array_equal(one, old)
    np.testing.assert_array_equal(many, old)


def test_rollout_equals_steps_one_by_one():
    ck = random_field(6)
    world = World(ROOM, LSS, VT, VO)
    ctrl = CertifiedController(ck)
    ctrl.reset(world, np.array([1.0, 1.0]), 0.0)
    rng = np.random.default_rng(11)
    p, _, a = random_states(rng, 6, ck)
    v = VT * rng.uniform(-0.7, 0.7, (6, 12, 2))
    A = ctrl.rollout(p, v, a, 0.1)
    for i in range(6):
        q, b = p[i].copy(), float(a[i])
        for k in range(12):
            b = b + ctrl.step(q, v[i, k], b, 0.1).rate * 0.1
            q = q + v[i, k] * 0.1
            assert A[i, k + 1] == b


def _search(ck: CertifiedKernel | None, seed: int):
    world = World(ROOM, LSS, VT, VO)
    if ck is not None:
        ctrl = CertifiedController(ck)
        ctrl.reset(world, np.array([1.0, 1.0]), 0.0)
        world.extra["controller"] = ctrl
    tgt = make_target("search", world)
    tgt.reset(world, np.array([1.0, 1.0]), 0.0, np.random.default_rng(seed))
    return tgt


@pytest.mark.slow
def test_batched_scores_equal_the_scalar_loop():
    ck = random_field(5)
    tgt = _search(ck, 0)
    rng = np.random.default_rng(6)
    p, _, a = random_states(rng, 60, ck)
    inside = ROOM.contains(p[:, 0], p[:, 1])
    kinds = set()
    for q, b in zip(p[inside][:12], a[inside][:12], strict=True):
        h = rng.uniform(0, 2 * math.pi, 16)
        g = h + rng.choice([-1, 1], 16) * math.pi / 2
        cands = [[VT * np.array([math.cos(x), math.sin(x)]),
                  VT * np.array([math.cos(y), math.sin(y)])] for x, y in zip(h, g, strict=True)]
        many = tgt._score_many(q, float(b), cands)
        loop = np.array([tgt._score(q.copy(), float(b), legs) for legs in cands])
        np.testing.assert_array_equal(many, loop)
        kinds |= {"wall" if s == math.inf else "lost" if s < 0 else "gap" for s in loop}
    assert kinds == {"wall", "lost", "gap"}  # every way a plan can end was compared


def test_search_without_rollout_keeps_the_loop():
    tgt = _search(None, 0)  # no controller to attack: the scalar loop, rate 0
    cands = [[np.array([VT, 0.0])] * 2, [np.array([0.0, VT])] * 2]
    assert tgt._scores(np.array([1.0, 1.0]), 0.3, cands) == [
        tgt._score(np.array([1.0, 1.0]), 0.3, legs) for legs in cands]


def test_planner_contains_many_equals_contains():
    tgt = _search(None, 0)
    pl = tgt.planner
    rng = np.random.default_rng(7)
    pts = np.concatenate([rng.uniform(-0.5, 6.5, (300, 2)),
                          np.asarray(pl.space.exterior.coords),  # on the boundary
                          np.asarray(pl.space.interiors[0].coords)])
    np.testing.assert_array_equal(pl.contains_many(pts), [pl.contains(q) for q in pts])


@pytest.mark.slow
def test_search_run_is_the_same_with_and_without_the_batch():
    """A whole run against ``search``: the batched target and the loop pick the same plans."""
    ck = random_field(8, h=1.0)

    class Plain(CertifiedController):  # the same rule without rollout: the loop
        rollout = property(lambda self: (_ for _ in ()).throw(AttributeError))

    runs = []
    for cls in (CertifiedController, Plain):
        world = World(ROOM, LSS, VT, VO)
        ctrl = cls(ck)
        assert hasattr(ctrl, "rollout") == (cls is CertifiedController)
        runs.append(simulate(world, ctrl, make_target("search", world), (1.0, 1.0, 0.0),
                             duration=1.2, dt=0.02, seed=3, monitor=False))
    np.testing.assert_array_equal(runs[0].trace.p, runs[1].trace.p)
    np.testing.assert_array_equal(runs[0].trace.a, runs[1].trace.a)


@pytest.mark.parametrize("name", ["gallery", pytest.param("nonconvex_corner",
                                                         marks=pytest.mark.slow)])
def test_monitor_shortcut_gives_the_exact_tests_answer(name):
    """``Monitor.ok`` (a clearance shortcut before the exact rod test) against the exact test
    alone, on rods near and across the walls and vertices."""
    from tether.arcs import rod_is_free
    from tether.examples import path as example_path
    from tether.io import load_map
    from tether.sim.simulate import Monitor

    env = load_map(example_path(name))
    mon = Monitor(World(env, 1.0, VT, VO))
    rng = np.random.default_rng(9)
    x0, y0, x1, y1 = env.bounds
    verts = env.vertices
    p = np.concatenate([rng.uniform([x0, y0], [x1, y1], (150, 2)),  # rods through vertices:
                        verts[rng.integers(0, len(verts), 50)] + rng.normal(0, 1e-7, (50, 2))])
    a = rng.uniform(0, 2 * math.pi, len(p))
    lss = mon.lss
    for q, b in zip(p, a, strict=True):
        o = q + lss * np.array([math.cos(b), math.sin(b)])
        want = bool(env.contains(o[0], o[1])) and rod_is_free(env, q, b, lss)
        assert mon.ok(q, b) == want
