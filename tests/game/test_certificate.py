"""The certified arc field: each inequality the soundness argument relies on, checked against
brute force (docs/kernel.md, "The certified kernel").

- the exact free windows and the free check: rods from dense points of a triangle at dense
  orientations of the window are free by the independent rod test;
- the end conditions' lower bound: never above the densely sampled minimum;
- the whole argument: targets (random, wall-seeking, circling, greedy) against the field's
  controller, every step monitored (never outside the field, the rod always free, the
  observer's chord within vo·dt); the rod that never turns, as a negative control, fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether import Environment
from tether.arcs import rod_is_free_many
from tether.game import certificate as C
from tether.game.cells import triangle_blocked_any
from tether.game.certificate import lifted_ends
from tether.game.field_lp import free_windows


def _room(w: float = 4.0, h: float = 4.0, holes=()) -> Environment:
    return Environment([(0, 0), (w, 0), (w, h), (0, h)], holes=list(holes))


def _points_in(tri: np.ndarray, n: int, rng) -> np.ndarray:
    """n points per triangle (m, 3, 2): vertices, edge points and random interior points."""
    r = rng.uniform(size=(len(tri), n, 2))
    flip = r.sum(-1) > 1
    r[flip] = 1 - r[flip]
    bary = np.concatenate([np.eye(3)[None].repeat(len(tri), 0),
                           np.stack([1 - r.sum(-1), r[..., 0], r[..., 1]], -1)], axis=1)
    return np.einsum("mkv,mvd->mkd", bary, tri)


def _random_triangles(env: Environment, m: int, size: float, rng) -> np.ndarray:
    x0, y0, x1, y1 = env.bounds
    c = rng.uniform([x0, y0], [x1, y1], size=(m, 1, 2))
    return c + rng.uniform(-size, size, size=(m, 3, 2))


@pytest.mark.parametrize("seed", [0, 1])
def test_free_windows_are_free_by_the_rod_test(seed):
    """Every orientation of a triangle's exact free window is free from every sampled point of
    the triangle's free part (the independent rod test), near walls, corners and a pillar."""
    rng = np.random.default_rng(seed)
    env = _room(4, 4, holes=[[(1.5, 1.5), (2.5, 1.5), (2.5, 2.5), (1.5, 2.5)]])
    lss = 1.0
    tri = _random_triangles(env, 300, 0.2, rng)
    ref = rng.uniform(0, math.tau, len(tri))
    f_lo, f_hi = free_windows(env, tri, ref, lss)
    ok = (f_lo < f_hi)
    assert ok.sum() > 50
    checked = 0
    for t in np.flatnonzero(ok):
        lo, hi = max(f_lo[t], ref[t] - math.pi), min(f_hi[t], ref[t] + math.pi)
        pts = _points_in(tri[t:t + 1], 40, rng)[0]
        pts = pts[env.contains(pts[:, 0], pts[:, 1])]
        if not len(pts):
            continue
        ang = np.linspace(lo + 1e-7, hi - 1e-7, 48)
        P = np.repeat(pts, len(ang), 0)
        A = np.tile(ang, len(pts))
        assert rod_is_free_many(env, P, A, lss).all(), (tri[t].tolist(), lo, hi)
        checked += 1
    assert checked > 50


def test_free_window_is_tight_at_a_wall():
    """A triangle touching the right wall of a room: its window is the closed half-plane
    facing away ([π/2, 3π/2]), to the angle margin; a pinned exact case."""
    env = _room(4, 4)
    tri = np.array([[[4.0, 2.0], [3.9, 2.1], [3.9, 1.9]]])
    f_lo, f_hi = free_windows(env, tri, np.array([math.pi]), 1.0)
    assert f_lo[0] == pytest.approx(math.pi / 2, abs=1e-8)
    assert f_hi[0] == pytest.approx(3 * math.pi / 2, abs=1e-8)


def test_free_window_at_exactly_lss_from_a_wall():
    """Points exactly lss from a wall (a power of two): the rod pointing at the wall touches it
    (free); the window of the triangle reaching to lss is the whole circle minus that touch."""
    env = _room(4, 4)
    lss = 1.0
    tri = np.array([[[2.0, 3.0], [2.5, 3.0], [2.25, 2.5]]])  # top edge exactly 1 from y = 4
    f_lo, f_hi = free_windows(env, tri, np.array([-math.pi / 2]), lss)
    # the rod pointing straight up from y = 3 touches y = 4: blocked only to the margin
    assert f_hi[0] - f_lo[0] >= math.tau - 1e-6
    assert rod_is_free_many(env, np.array([[2.0, 3.0]]), np.array([math.pi / 2]), lss)[0]


def test_blocked_check_agrees_with_the_windows():
    """triangle_blocked_any (the certificate's free check) finds nothing blocked inside a free
    window and finds the block when the interval reaches one sampled blocked rod."""
    rng = np.random.default_rng(3)
    env = _room(4, 4)
    lss = 1.0
    tri = _random_triangles(env, 200, 0.15, rng)
    ref = rng.uniform(0, math.tau, len(tri))
    f_lo, f_hi = free_windows(env, tri, ref, lss)
    ok = (f_lo < f_hi) & np.isfinite(f_lo) & np.isfinite(f_hi)
    lo, hi = f_lo[ok] + 1e-6, f_hi[ok] - 1e-6
    blocked, meets = triangle_blocked_any(env, tri[ok], lo, hi, lss)
    assert not (blocked & meets).any()
    # widened past the window by 0.05 rad: now blocked, and a sampled rod confirms it
    blocked, meets = triangle_blocked_any(env, tri[ok], lo - 0.05, hi, lss)
    assert (blocked | ~meets).all()


@pytest.mark.slow
@pytest.mark.parametrize("upper", [False, True])
def test_end_slack_is_a_lower_bound(upper):
    """end_slack never exceeds the minimum of the end condition over a dense grid of target
    headings and orientations (random gradients and orientation ranges, vt/vo up to 0.9)."""
    rng = np.random.default_rng(7 + upper)
    for vt in (0.3, 0.6, 0.9):
        n = 64
        G = rng.normal(0, 2.0, size=(n, 2))
        a0 = rng.uniform(0, math.tau, n)
        a1 = a0 + rng.uniform(0, 0.6, n)
        lss, vo = 1.3, 1.0
        bound = C.end_slack(G, a0, a1, lss, vt, vo, upper)
        th = np.linspace(0, math.tau, 4096, endpoint=False)
        sgn = 1.0 if upper else -1.0
        dense = np.full(n, np.inf)
        for q in np.linspace(0, 1, 97):
            a = a0 + q * (a1 - a0)
            x = th[None, :] - a[:, None]
            F = (np.sqrt(vo * vo - (vt * np.cos(x)) ** 2) + sgn * vt * np.sin(x)
                 + sgn * lss * vt * (G[:, :1] * np.cos(th) + G[:, 1:] * np.sin(th)))
            dense = np.minimum(dense, F.min(axis=1))
        assert (bound <= dense + 1e-12).all()
        assert (dense - bound).max() < 0.1  # and not uselessly loose


def test_lift_is_the_same_on_both_sides_of_an_edge():
    """Gap centres lifted per triangle give every shared edge the same lifted difference of
    ``lo`` in both of its triangles (the field is continuous across the edge): the wrapped
    difference of the centres plus half the change of the gap; a triangle whose centres wind
    is flagged."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        c = rng.uniform(0, math.tau, 4)
        c[1:] = c[0] + rng.uniform(-1.0, 1.0, 3)  # centres that do not wind
        w = rng.uniform(0.1, math.tau, 4)
        lo = np.mod(c + (math.tau - w) / 2, math.tau)
        tri = np.array([[0, 1, 2], [2, 1, 3]])  # edge (1, 2) shared
        L, H, winds = lifted_ends(lo, w, tri)
        assert not winds.any()
        assert L[0, 2] - L[0, 1] == pytest.approx(L[1, 0] - L[1, 1], abs=1e-12)
        want = (c[2] - c[1]) - (w[2] - w[1]) / 2
        assert L[0, 2] - L[0, 1] == pytest.approx(want, abs=1e-12)
        assert np.allclose(H - L, w[tri])
    # centres 0, 2π/3, 4π/3 around one triangle wind once
    w = np.ones(3)
    lo = np.array([0.0, math.tau / 3, 2 * math.tau / 3]) + (math.tau - w) / 2
    _, _, winds = lifted_ends(lo, w, np.array([[0, 1, 2]]))
    assert winds.all()


@pytest.mark.slow
@pytest.mark.parametrize("sgn", [-1.0, 1.0])
def test_lp_rate_bound_is_a_lower_bound(sgn):
    """The LP's bound S (a sparse table of minima over the circle) is never above the minimum
    over a densely sampled orientation range, for ranges short, long and over a full turn."""
    from tether.game.certificate import window_min

    rng = np.random.default_rng(5)
    amin = rng.uniform(-10, 10, 200)
    amax = amin + np.concatenate([rng.uniform(0, 0.05, 100), rng.uniform(0, 7, 100)])
    th = np.linspace(0, math.tau, 48, endpoint=False)
    for vt in (0.3, 0.9):
        bound = window_min(amin, amax, th, vt, 1.0, sgn)
        dense = np.full(bound.shape, np.inf)
        for q in np.linspace(0, 1, 2001):
            x = th[None, :] - (amin + q * (amax - amin))[:, None]
            dense = np.minimum(dense, np.sqrt(1 - (vt * np.cos(x)) ** 2) + sgn * vt * np.sin(x))
        assert (bound <= dense + 1e-12).all()
        assert (dense - bound).max() < 0.01


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
@pytest.mark.parametrize("bad_lo, bad_w", [(np.nan, 0.5), (0.0, np.nan), (np.inf, 0.5),
                                           (0.0, np.inf)])
def test_certify_fails_non_finite_arcs(bad_lo, bad_w):
    """A NaN end or width compares False everywhere and would pass every check: ``certify``
    fails exactly the triangles that hold such a vertex (as not open); with finite arcs no
    triangle fails that check."""
    env = _room(10.0, 10.0)
    h = 1.0
    xs = np.arange(0.0, 10.0 + h / 2, h)
    pts, tri, _ = C.free_mesh(env, h, np.stack(np.meshgrid(xs, xs), axis=-1).reshape(-1, 2))
    lo, w = np.zeros(len(pts)), np.full(len(pts), 0.5)
    assert not C.certify(C.ArcField(pts, tri, lo, w), env, 0.5, 0.3, 1.0).open.any()
    k = int(np.argmin(np.hypot(*(pts - [5, 5]).T)))
    lo[k], w[k] = bad_lo, bad_w
    checks = C.certify(C.ArcField(pts, tri, lo, w), env, 0.5, 0.3, 1.0)
    holds = (tri == k).any(axis=1)
    assert not checks.passed
    assert np.array_equal(checks.open, holds)
